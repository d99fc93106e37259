"""``/docs``: Swagger UI served from the package, so that it works offline.

FastAPI's own ``/docs`` page loads Swagger UI's script and style from a CDN,
and is blank on a machine without internet access (issue 17). Here the page is
FastAPI's (:func:`fastapi.openapi.docs.get_swagger_ui_html`, the self-hosting
recipe of FastAPI's documentation, "Custom Docs UI Static Assets") pointed at
a copy of ``swagger-ui-dist`` 5.35.0 (npm; Apache-2.0, its LICENSE and NOTICE
beside it) in ``service/web/swagger-ui/``, shipped as package data. ReDoc,
which FastAPI also loads from a CDN, is not offered.
"""

from __future__ import annotations

from fastapi import APIRouter, Request
from fastapi.openapi.docs import get_swagger_ui_html, get_swagger_ui_oauth2_redirect_html
from fastapi.responses import Response

from ..errors import ApiError
from .web import WEB

__all__ = ["ASSETS", "SWAGGER_UI_VERSION", "router"]

SWAGGER_UI_VERSION = "5.35.0"
#: The files of Swagger UI the page needs, and their media types.
ASSETS = {
    "swagger-ui-bundle.js": "text/javascript; charset=utf-8",
    "swagger-ui.css": "text/css; charset=utf-8",
    "favicon-32x32.png": "image/png",
    "LICENSE": "text/plain; charset=utf-8",
    "NOTICE": "text/plain; charset=utf-8",
}
PREFIX = "/docs/assets"

router = APIRouter(include_in_schema=False)


@router.get("/docs")
def docs(request: Request):
    return get_swagger_ui_html(
        openapi_url=request.app.openapi_url,
        title=f"{request.app.title}: HTTP API",
        swagger_js_url=f"{PREFIX}/swagger-ui-bundle.js",
        swagger_css_url=f"{PREFIX}/swagger-ui.css",
        swagger_favicon_url=f"{PREFIX}/favicon-32x32.png",
        oauth2_redirect_url="/docs/oauth2-redirect",
        swagger_ui_parameters={"persistAuthorization": True},
    )


@router.get("/docs/oauth2-redirect")
def oauth2_redirect():
    return get_swagger_ui_oauth2_redirect_html()


@router.get(PREFIX + "/{name}")
def asset(name: str):
    if name not in ASSETS:
        raise ApiError(404, f"there is no documentation asset {name!r}", "name")
    content = (WEB / "swagger-ui" / name).read_bytes()
    return Response(content, media_type=ASSETS[name],
                    headers={"Cache-Control": "public, max-age=86400"})  # fmt: skip
