"""ASGI middleware of the service: the limit on the size of request bodies."""

from __future__ import annotations

from .errors import ApiError, error_body, error_response

__all__ = ["BodyLimit"]


class TooLarge(ApiError):
    """A body above the server's limit (413)."""

    def __init__(self, limit: int):
        super().__init__(413, f"the request body is larger than {limit} bytes, this server's "
                         "limit (BRDFFIT_MAX_BODY_BYTES)", "body")  # fmt: skip

    def response(self):
        return error_response(413, error_body(self.detail, "body", self.kind))


class BodyLimit:
    """Refuse bodies above ``max_bytes`` with 413, whether they announce their length
    or stream it (the count stops reading at the limit)."""

    def __init__(self, app, max_bytes: int):
        self.app, self.max_bytes = app, max_bytes

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        length = dict(scope.get("headers") or ()).get(b"content-length")
        if length is not None:
            if not length.isdigit():
                body = error_body("the Content-Length header is not a number", "content-length",
                                  "HTTPError")  # fmt: skip
                return await error_response(400, body)(scope, receive, send)
            if int(length) > self.max_bytes:
                return await TooLarge(self.max_bytes).response()(scope, receive, send)
        received = 0
        started = False

        async def counted():
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > self.max_bytes:
                    raise TooLarge(self.max_bytes)
            return message

        async def watched(message):
            nonlocal started
            started = started or message["type"] == "http.response.start"
            await send(message)

        try:
            await self.app(scope, counted, watched)
        except TooLarge as exc:
            if started:
                raise
            await exc.response()(scope, receive, send)
