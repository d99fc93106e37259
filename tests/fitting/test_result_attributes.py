"""FitResult's public names are the ones its docstring documents, no more.

``is_valid`` was a property nothing used and nothing documented (not in the
docstring's Attributes, nor DESIGN.md's contract); this test failed on it.
"""

from __future__ import annotations

import dataclasses
import inspect

from brdffit.fitting.result import FitResult

#: Methods (documented by their own docstrings), not attributes.
METHODS = {"to_dict", "from_dict"}


def documented_attributes() -> set:
    doc = inspect.getdoc(FitResult)
    section = doc.split("Attributes\n----------\n", 1)[1]
    names = set()
    for line in section.splitlines():
        if line and not line.startswith(" "):  # "name : type" or "a, b, c : int"
            names |= {n.strip() for n in line.split(" : ")[0].split(",")}
    return names


def test_every_public_attribute_of_a_fit_result_is_documented():
    fields = {f.name for f in dataclasses.fields(FitResult)}
    public = {n for n in dir(FitResult) if not n.startswith("_")} | fields
    assert public - METHODS == documented_attributes()
