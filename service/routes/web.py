"""The web page at ``/`` and the small routes only it needs (issue 16).

The page is three static files in ``service/web/`` (HTML, CSS, plain
JavaScript; nothing fetched from elsewhere), shipped as package data. It talks
to the service through the same JSON routes as any client: ``GET /models``,
``POST /comparisons/file`` (:mod:`.comparisons`), ``GET /jobs/{id}``,
``GET /jobs/{id}/plot.png`` (:mod:`.plots`), ``GET /jobs``.

``GET /examples`` lists the files of the repository's ``data_synthetic/``
folder, and ``GET /examples/{name}`` answers one, so the page can offer them;
the folder is not part of the installed package, so an installed service
without a checkout lists none.
"""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

from fastapi import APIRouter
from fastapi.responses import FileResponse, Response
from pydantic import BaseModel

from ..errors import ApiError
from ..schemas import ErrorOut
from .comparisons import router as compare_router
from .plots import router as plots_router

__all__ = ["EXAMPLES", "WEB", "page_file", "router", "routers"]

#: The repository's synthetic examples (absent from an installed package).
EXAMPLES = Path(__file__).resolve().parents[2] / "data_synthetic"
#: The page's files, as package data.
WEB = resources.files(__name__.split(".")[0]) / "web"  # brdffit_service, or service in a checkout
STATIC = {"app.css": "text/css", "app.js": "text/javascript"}

router = APIRouter()


def page_file(name: str) -> bytes:
    """The bytes of one of the page's files (``index.html``, ``app.css``, ``app.js``)."""
    return (WEB / name).read_bytes()


@router.get("/", include_in_schema=False)
def page():
    return Response(page_file("index.html"), media_type="text/html; charset=utf-8")


@router.get("/static/{name}", include_in_schema=False)
def static(name: str):
    if name not in STATIC:
        raise ApiError(404, f"there is no static file {name!r}", "name")
    return Response(page_file(name), media_type=f"{STATIC[name]}; charset=utf-8",
                    headers={"Cache-Control": "no-cache"})  # fmt: skip


class ExampleOut(BaseModel):
    name: str
    model: str | None
    n: int | None
    url: str


def _examples() -> dict[str, dict]:
    if not EXAMPLES.is_dir():
        return {}
    truth_path = EXAMPLES / "truth.json"
    truth = json.loads(truth_path.read_text()).get("files", {}) if truth_path.exists() else {}
    out = {}
    for path in sorted(EXAMPLES.glob("*.csv")):
        about = truth.get(path.name, {})
        out[path.name] = {"name": path.name, "model": about.get("model"), "n": about.get("n"),
                          "url": f"/examples/{path.name}"}  # fmt: skip
    return out


@router.get("/examples", response_model=list[ExampleOut], tags=["examples"])
def list_examples():
    """The synthetic datasets of the repository's ``data_synthetic/`` (none when the
    service runs from an installed package without the checkout)."""
    return list(_examples().values())


@router.get("/examples/{name}", response_class=FileResponse, tags=["examples"],
            responses={404: {"model": ErrorOut, "description": "No such example."}})  # fmt: skip
def get_example(name: str):
    """One example file (CSV), to upload as any other."""
    if name not in _examples():
        raise ApiError(404, f"there is no example {name!r}; GET /examples lists them", "name")
    return FileResponse(EXAMPLES / name, media_type="text/csv", filename=name)


#: Every router of the page, for ``create_app``.
routers = [router, compare_router, plots_router]
