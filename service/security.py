"""The API token: who may use the service when it listens beyond the loopback.

Without a token, anyone who reaches the port can list, read, cancel and delete
every job (issue 18). So:

- with ``BRDFFIT_API_TOKEN`` set, every route asks for
  ``Authorization: Bearer <token>`` (compared in constant time,
  :func:`hmac.compare_digest`), except :data:`PUBLIC`: ``/health`` (for load
  balancers and the container's health check), the web page's own files (the
  page asks the user for the token and sends it on its API calls), and the API
  documentation (``/docs``, its assets, ``/openapi.json``: no data);
- :func:`check_listen` refuses to start on an address beyond the loopback
  without a token, unless told (``--insecure`` or ``BRDFFIT_ALLOW_NO_TOKEN=1``);
- a server without a token started some other way (``uvicorn ... --host
  0.0.0.0``) answers 401 to a client whose address is not the loopback.
"""

from __future__ import annotations

import hmac
import ipaddress

from .errors import error_body, error_response
from .settings import Settings, SettingsError

__all__ = ["PUBLIC", "TokenAuth", "check_listen", "is_loopback"]

#: Paths anyone may GET: liveness, the page's files, the API's documentation.
PUBLIC = {"/health", "/", "/openapi.json", "/docs", "/docs/oauth2-redirect"}
PUBLIC_PREFIXES = ("/static/", "/docs/assets/")


def is_loopback(host: str) -> bool:
    """True for ``localhost`` and loopback addresses (127.0.0.0/8, ::1)."""
    host = host.strip("[]")
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def check_listen(settings: Settings, host: str, insecure: bool = False) -> Settings:
    """The settings to serve on ``host`` with; a :class:`SettingsError` for an address
    beyond the loopback without a token, unless ``insecure`` (or the setting
    ``allow_no_token``) says so."""
    if insecure:
        settings = settings.model_copy(update={"allow_no_token": True})
    if is_loopback(host) or settings.api_token is not None or settings.allow_no_token:
        return settings
    raise SettingsError(
        f"--host {host} listens beyond this machine, where anyone who reaches the port "
        "could read, cancel and delete every job: set an API token (BRDFFIT_API_TOKEN; "
        "clients send 'Authorization: Bearer <token>'), or say --insecure "
        "(BRDFFIT_ALLOW_NO_TOKEN=1) to serve without one"
    )


def _unauthorized(message: str):
    body = error_body(message, "authorization", "Unauthorized")
    return error_response(401, body, headers={"WWW-Authenticate": "Bearer"})


class TokenAuth:
    """ASGI middleware asking for the bearer token of ``settings`` (see the module)."""

    def __init__(self, app, settings: Settings):
        self.app = app
        token = settings.api_token
        self.token = None if token is None else token.get_secret_value().encode()
        self.open_to_remote = settings.allow_no_token

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http" or self._public(scope):
            return await self.app(scope, receive, send)
        if self.token is None:
            client = (scope.get("client") or ("",))[0]
            if self.open_to_remote or not _remote(client):
                return await self.app(scope, receive, send)
            answer = _unauthorized(
                "this server has no API token and answers only clients on its own "
                "machine; its operator can set BRDFFIT_API_TOKEN"
            )
            return await answer(scope, receive, send)
        header = dict(scope.get("headers") or ()).get(b"authorization", b"")
        scheme, _, given = header.partition(b" ")
        if scheme.lower() != b"bearer" or not hmac.compare_digest(given.strip(), self.token):
            what = "a wrong token" if header else "no token"
            answer = _unauthorized(
                f"this server needs its API token: the request has {what}; "
                "send the header 'Authorization: Bearer <token>'"
            )
            return await answer(scope, receive, send)
        return await self.app(scope, receive, send)

    @staticmethod
    def _public(scope) -> bool:
        path = scope.get("path", "")
        if scope.get("method") not in ("GET", "HEAD"):
            return False
        return path in PUBLIC or path.startswith(PUBLIC_PREFIXES)


def _remote(client: str) -> bool:
    """True for a client address that is an IP beyond the loopback (a test client's
    name, or a Unix socket's empty address, is local)."""
    try:
        return not ipaddress.ip_address(client).is_loopback
    except ValueError:
        return False
