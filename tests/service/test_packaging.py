"""The folder service/ installs as ``brdffit_service``, not as a top-level ``service``.

A top-level ``service`` package collides with other distributions' (pip writes
both into site-packages/service/, and uninstalling one breaks the other) and
with any project's own ``service`` folder in the working directory, which
Python and uvicorn put first on the path. pyproject.toml maps the folder to
the name ``brdffit_service`` and lists every package: the list is checked here
against the folders, so a new subpackage cannot be left out of an install.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

tomllib = pytest.importorskip("tomllib", reason="tomllib is in the standard library from 3.11")

ROOT = Path(__file__).resolve().parents[2]


def folders(top: str, name: str) -> set[str]:
    base = ROOT / top
    return {
        ".".join((name, *init.parent.relative_to(base).parts))
        for init in base.rglob("__init__.py")
        if "__pycache__" not in init.parts
    }


def test_pyproject_installs_the_service_folder_as_brdffit_service_with_every_package():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert config["package-dir"] == {"brdffit_service": "service"}
    expected = folders("brdffit", "brdffit") | folders("service", "brdffit_service")
    assert set(config["packages"]) == expected
    assert not any(p == "service" or p.startswith("service.") for p in config["packages"])


def test_a_project_with_its_own_service_package_does_not_shadow_the_service(tmp_path):
    """Run from a folder that has a ``service`` package of its own, as a user's project
    may: the brdffit service and the command line's ``serve`` still import."""
    own = tmp_path / "service"
    own.mkdir()
    (own / "__init__.py").write_text("raise ImportError('the project of the user')\n")
    code = (
        "import brdffit_service, brdffit.cli.commands as c; "
        "from brdffit_service.app import create_app; print(brdffit_service.__name__)"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "brdffit_service"
