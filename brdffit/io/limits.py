"""How large a file the readers take: the sample limit, checked before allocating.

Every reader takes ``max_samples``, the most direction pairs it builds, and
checks the count it finds in the file's header (or in its rows) against it
before it allocates the arrays of those samples or decompresses anything, so a
small file that claims a huge table (an NPZ zip bomb, a forged header) costs a
few bytes of reading and a :class:`~brdffit.errors.FormatError`, never the
memory it claims. :data:`DEFAULT_MAX_SAMPLES` is the library's default (four
times a full MERL file); ``max_samples=None`` lifts the limit. The HTTP service
passes its own, smaller limit.
"""

from __future__ import annotations

from ..errors import FormatError

__all__ = ["DEFAULT_MAX_SAMPLES", "ELEMENTS_PER_SAMPLE", "check_samples", "checked_limit"]

#: The readers' default sample limit: 5 million direction pairs (a full MERL file
#: has 1.1 million); a Measurements of that size with 3 channels and sigma holds
#: about 0.5 GB of arrays.
DEFAULT_MAX_SAMPLES = 5_000_000

#: The numbers per sample an NPZ archive may hold on average at the sample limit:
#: 6 for the two directions, 4 angles, and values and sigma of up to 35 channels.
ELEMENTS_PER_SAMPLE = 80


def checked_limit(max_samples) -> int | None:
    """``max_samples`` checked: a whole number >= 1, or None for no limit."""
    if max_samples is None:
        return None
    if isinstance(max_samples, bool) or not isinstance(max_samples, int) or max_samples < 1:
        raise FormatError(
            f"max_samples={max_samples!r} is not allowed; it must be a whole number >= 1, "
            "or None for no limit",
            "max_samples",
        )
    return max_samples


def check_samples(n: int, max_samples: int | None, where: str, what: str, hint: str = "") -> None:
    """FormatError (field ``source``) when ``n`` samples exceed ``max_samples``.

    ``where`` names the file, ``what`` says where the count comes from (``"by
    its header at byte 40"``, ``"counted in its rows"``), ``hint`` what the user
    may do instead.
    """
    if max_samples is not None and n > max_samples:
        raise FormatError(
            f"{where} holds {n:,} samples ({what}), more than the sample limit of "
            f"{max_samples:,} (max_samples){hint}",
            "source",
        )
