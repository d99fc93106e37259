"""The README's layout names every module of brdffit/ and service/, and no other.

The section is a tree: a folder (``io/``) or a module (``words.py``) starts a
line at two spaces per level; what follows on the line, and on the lines
indented to the description column, names that folder's modules. Before, the
layout left out words.py, data/angle_units.py, io/limits.py, plot/residuals.py,
cli/fittable.py, the service's lock, pool, security, server and exports, and more.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DESCRIPTION_COLUMN = 22
MODULE = re.compile(r"\b(\w+\.py)\b")


def layout_section() -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("\n## Layout\n", 1)[1].split("\n## ", 1)[0]
    return section.split("```\n", 2)[1]


def listed_modules() -> set:
    """Paths of the modules the layout names, from its tree."""
    folders: list[str] = []
    current = ""
    found = set()
    for line in layout_section().splitlines():
        indent = len(line) - len(line.lstrip(" "))
        body = line
        if line.strip() and indent < DESCRIPTION_COLUMN:
            head, _, body = line.strip().partition(" ")
            depth = indent // 2
            if head.endswith("/"):
                folders = [*folders[:depth], head]
                current = "".join(folders)
            else:
                current = "".join(folders[:depth])
                if head.endswith(".py"):
                    found.add(current + head)
        found |= {current + name for name in MODULE.findall(body)}
    return found


def test_the_layout_names_every_module_and_only_real_ones():
    real = {
        str(p.relative_to(ROOT))
        for top in ("brdffit", "service")
        for p in (ROOT / top).rglob("*.py")
        if p.name != "__init__.py"
    }
    listed = {p for p in listed_modules() if p.startswith(("brdffit/", "service/"))}
    listed = {p for p in listed if not p.endswith("/__init__.py")}
    assert sorted(real - listed) == [], "modules the README's layout leaves out"
    assert sorted(listed - real) == [], "names in the README's layout that are no module"
