"""Counts in sentences: ``plural(1, "sample")`` is "1 sample", ``plural(2, "sample")``
"2 samples". Every message that prints a count goes through it (issue 17)."""

from __future__ import annotations

__all__ = ["plural"]


def plural(n, word: str, many: str | None = None) -> str:
    """``f"{n} {word}"`` with the plural form (``many``, default ``word + "s"``) unless
    ``n`` is 1; ``n`` is printed as given (an int, or a str already formatted)."""
    one = str(n).strip().replace(",", "") in ("1", "1.0")
    return f"{n} {word if one else (many or word + 's')}"
