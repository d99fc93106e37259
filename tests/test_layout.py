"""The house rules of DESIGN.md that code can check: modules under 400 lines,
functions under 60, and no import of a private library name from the service."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOURCES = sorted([*ROOT.glob("brdffit/**/*.py"), *ROOT.glob("service/**/*.py")])


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_module_and_function_sizes(path):
    text = path.read_text()
    assert text.count("\n") <= 400, f"{path.name} has {text.count(chr(10))} lines (> 400)"
    long = [
        f"{node.name} ({node.end_lineno - node.lineno + 1} lines)"
        for node in ast.walk(ast.parse(text))
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
        and node.end_lineno - node.lineno + 1 > 60
    ]
    assert not long, f"{path.name}: functions over 60 lines: {long}"


def test_the_service_imports_no_private_library_name():
    private = re.compile(r"from brdffit[\w.]* import [^\n]*\b_(?!_)\w|brdffit(\.\w+)*\._(?!_)\w")
    found = [
        f"{path.relative_to(ROOT)}: {m.group(0)}"
        for path in ROOT.glob("service/**/*.py")
        for m in private.finditer(path.read_text())
    ]
    assert not found, found
