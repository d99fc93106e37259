"""Running the service under uvicorn: :func:`serve`, what ``brdffit serve`` calls.

Before uvicorn starts, :func:`serve` refuses what would start badly: an
address beyond the loopback without an API token (:mod:`.security`), or a
job store that another server holds (:mod:`.lock`); each is one sentence, not
a traceback. It runs uvicorn with :class:`JsonH11Protocol`, so that a request
the HTTP parser refuses (a ``Content-Length`` of ``abc``, ``-1`` or 30 digits)
is answered with the service's JSON error, naming the header, instead of
uvicorn's plain-text 400. Running ``uvicorn brdffit_service.app:app`` directly
works too; pass ``--http brdffit_service.server:JsonH11Protocol`` for the JSON
400s.
"""

from __future__ import annotations

import json
import sys

import h11
from uvicorn.protocols.http.h11_impl import H11Protocol

from .errors import error_body
from .lock import StoreLock
from .security import check_listen
from .settings import Settings

__all__ = ["JsonH11Protocol", "parse_error_body", "serve"]


def parse_error_body(reason: str) -> dict:
    """The JSON of the 400 answering a request that HTTP cannot parse."""
    if "content-length" in reason.lower():
        message = (f"the Content-Length header is not valid ({reason}): it must be the "
                   "body's length in bytes, a whole number from 0")  # fmt: skip
        return error_body(message, "content-length", "HTTPError")
    return error_body(f"the request is not valid HTTP/1.1 ({reason})", "request", "HTTPError")


class JsonH11Protocol(H11Protocol):
    """uvicorn's h11 protocol whose 400 for an unparsable request is the service's JSON
    (:class:`~brdffit_service.schemas.ErrorOut`), naming the header at fault."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.parse_error = ""
        next_event = self.conn.next_event

        def watched_next_event():
            try:
                return next_event()
            except h11.RemoteProtocolError as exc:
                self.parse_error = str(exc)
                raise

        self.conn.next_event = watched_next_event

    def send_400_response(self, msg: str) -> None:
        body = json.dumps(parse_error_body(self.parse_error or msg)).encode()
        head = (
            "HTTP/1.1 400 Bad Request\r\ncontent-type: application/json\r\n"
            f"content-length: {len(body)}\r\nconnection: close\r\n\r\n"
        )
        self.transport.write(head.encode("ascii") + body)
        self.transport.close()


def serve(settings: Settings, host: str, port: int, log_level: str = "info",
          insecure: bool = False) -> None:  # fmt: skip
    """Run the service on ``host:port`` until stopped.

    Raises
    ------
    SettingsError
        ``host`` is beyond the loopback and no token is set (unless ``insecure``).
    StoreInUse
        Another server holds the job store.
    """
    import uvicorn

    import brdffit

    from .app import create_app

    settings = check_listen(settings, host, insecure)
    StoreLock(settings.store_path).acquire().release()  # one sentence now, not at start-up
    token = "a token" if settings.api_token is not None else "no token"
    where = f"jobs in {settings.store_path} ({settings.workers} workers), {token}"
    print(f"brdffit {brdffit.__version__}: http://{host}:{port}/docs, {where}", file=sys.stderr)
    uvicorn.run(create_app(settings), host=host, port=port, log_level=log_level,
                http=JsonH11Protocol)  # fmt: skip
