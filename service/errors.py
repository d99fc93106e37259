"""The error the routes raise for HTTP reasons (not found, conflict, too large...)."""

from __future__ import annotations

from starlette.exceptions import HTTPException

__all__ = ["ApiError"]

KINDS = {404: "NotFound", 405: "MethodNotAllowed", 409: "Conflict", 413: "TooLarge",
         503: "Unavailable"}  # fmt: skip


class ApiError(HTTPException):
    """An answer with a status, the field at fault and a sentence."""

    def __init__(self, status: int, message: str, field: str | None = None, kind: str = ""):
        super().__init__(status, message)
        self.field = field
        self.kind = kind or KINDS.get(status, "HTTPError")
