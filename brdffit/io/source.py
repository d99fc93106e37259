"""Where measurements come from and go to: a path, bytes, or a binary file object.

Every reader takes a :class:`Source` and every writer returns bytes, so a
format is written once for all three kinds of place. A source has a ``name``
for messages: the path, else the ``name`` attribute of a file object when it is
a string or a path (``open`` gives one; set ``f.name = "upload.csv"`` on an
``io.BytesIO`` to name an upload), else :data:`NAMELESS`. The name also gives
the extension from which :func:`brdffit.io.read` infers the format.
"""

from __future__ import annotations

import os

from ..errors import FormatError

__all__ = ["NAMELESS", "Source", "as_source", "file_name", "put_bytes"]

#: The name errors give a source that has none (bytes, an unnamed file object).
NAMELESS = "<bytes>"


def file_name(place) -> str | None:
    """The name of a path or a file object (its ``name`` when a string or a path)."""
    if isinstance(place, (str, os.PathLike)):
        return str(os.fspath(place))
    name = getattr(place, "name", None)
    return str(os.fspath(name)) if isinstance(name, (str, os.PathLike)) else None


class Source:
    """The bytes of something to read, read once when first needed, and its name.

    Parameters
    ----------
    source : str, os.PathLike, bytes, bytearray, memoryview or binary file object
        A file object is read from its current position to its end.
    """

    def __init__(self, source):
        self._path = self._raw = self._file = None
        if isinstance(source, (str, os.PathLike)):
            self._path = os.fspath(source)
            self.filename = str(self._path)
        elif isinstance(source, (bytes, bytearray, memoryview)):
            self._raw = bytes(source)
            self.filename = None
        elif callable(getattr(source, "read", None)):
            self._file = source
            self.filename = file_name(source)
        else:
            raise FormatError(
                f"cannot read from a {type(source).__name__}; pass a path, bytes or a "
                "binary file object",
                "source",
            )

    @property
    def name(self) -> str:
        """The name messages give the source: its path or file name, else ``<bytes>``."""
        return self.filename if self.filename is not None else NAMELESS

    @property
    def path(self) -> str | None:
        """The path, when the source is a file named by its path (None otherwise)."""
        return self._path

    def __str__(self) -> str:
        return self.name

    def read(self) -> bytes:
        """Every byte of the source (a path is read, a file object read to its end, once)."""
        if self._raw is None:
            if self._path is not None:
                with open(self._path, "rb") as f:
                    self._raw = f.read()
            else:
                raw = self._file.read()
                if not isinstance(raw, (bytes, bytearray)):
                    raise FormatError(
                        f"{self.name} is open in text mode (read() gave "
                        f"{type(raw).__name__}); open it in binary mode, 'rb'",
                        "source",
                    )
                self._raw = bytes(raw)
        return self._raw

    def head(self, size: int = 4096) -> bytes:
        """The first ``size`` bytes (a path is not read whole for them)."""
        if self._raw is None and self._path is not None:
            with open(self._path, "rb") as f:
                return f.read(size)
        return self.read()[:size]

    def text(self) -> str:
        """The source decoded as UTF-8, or FormatError naming it.

        A byte order mark, which spreadsheets write at the start of a saved file,
        is skipped: UTF-8's, or UTF-16's when the text after it decodes as UTF-16
        to Latin letters, digits and punctuation (the formats' text), so that
        binary bytes that happen to start like one are not taken for text.
        """
        raw = self.read()
        if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
            try:
                text = raw.decode("utf-16")
            except UnicodeDecodeError:
                text = None
            if text is not None and all(ord(c) < 0x250 for c in text):
                return text
        try:
            return raw.decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise FormatError(
                f"{self.name} is not a UTF-8 text file (byte {exc.start} cannot be decoded); "
                "a text format needs a text file",
                "source",
            ) from None


def as_source(source) -> Source:
    """``source`` as a :class:`Source` (one already is one)."""
    return source if isinstance(source, Source) else Source(source)


def put_bytes(target, content: bytes) -> None:
    """Write ``content`` to a path (created or replaced) or to a binary file object."""
    if isinstance(target, (str, os.PathLike)):
        with open(target, "wb") as f:
            f.write(content)
    elif callable(getattr(target, "write", None)):
        try:
            target.write(content)
        except TypeError:
            raise FormatError(
                f"cannot write bytes to {file_name(target) or 'the file object'}; open it "
                "in binary mode, 'wb'",
                "target",
            ) from None
    else:
        raise FormatError(
            f"cannot write to a {type(target).__name__}; pass a path or a binary file object",
            "target",
        )
