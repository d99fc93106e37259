"""The Wald-Wolfowitz runs test of residual signs (:mod:`brdffit.fitting.misfit`).

The signs of the standardised residuals, in an order of the samples, as int8 codes
(:func:`sign_codes`), and their runs counted per channel (:func:`runs`): too few
runs means residuals of one sign in whole regions (Wald and Wolfowitz 1940,
Ann. Math. Statist. 11, 147; on residuals ordered by a regressor: Draper and
Smith, *Applied Regression Analysis*, 3rd ed., sec. 7.2).
"""

from __future__ import annotations

import math

import numpy as np

from .. import kernels

__all__ = [
    "MAX_BUCKETS",
    "VECTOR_LENGTH",
    "VECTOR_ROWS",
    "lexsort",
    "orders",
    "residual_signs",
    "runs",
    "runs_by_row",
    "sign_codes",
]

#: :func:`orders` sorts by counting where the keys' distinct values make at most this
#: many pairs (8 MB of counts), and at most four a key.
MAX_BUCKETS = 1 << 20
#: :func:`runs` counts rows together from this many rows of at most VECTOR_LENGTH signs.
VECTOR_ROWS = 8
VECTOR_LENGTH = 4096


def lexsort(primary: np.ndarray, secondary: np.ndarray) -> np.ndarray:
    """``np.lexsort((secondary, primary))`` as one stable sort of complex keys
    ``primary + i secondary`` (numpy orders complex numbers by their real parts, then
    their imaginary parts): the same order; on a MERL file 1.3x faster than two stable
    sorts, 2.5x than ``np.lexsort``."""
    keys = np.empty(primary.size, dtype=np.complex128)
    keys.real, keys.imag = primary, secondary
    return np.argsort(keys, kind="stable")


def orders(key_a: np.ndarray, key_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(lexsort(key_a, key_b), lexsort(key_b, key_a))``: from
    :data:`~brdffit.kernels.MIN_PAIRS` keys on, where the kernels run and the keys
    take few distinct values (a measured table's angles; at most :data:`MAX_BUCKETS`
    pairs of them, no NaN), by the counting sorts of
    :mod:`brdffit.kernels.loops_runs` (the same orders, element for element; a MERL
    file's 11 -> 7.5 ms), else by :func:`lexsort`."""
    if len(key_a) >= kernels.MIN_PAIRS and kernels.wanted(len(key_a), modules=("loops_runs",)):
        ranked = _ranks(key_a, key_b)
        if ranked is not None:
            from ..kernels import loops_runs

            (a, n_a), (b, n_b) = ranked
            out = np.empty((2, len(a)), dtype=np.intp)
            loops_runs.order_by_ranks(a, b, n_b, out[0])
            loops_runs.order_by_ranks(b, a, n_a, out[1])
            return out[0], out[1]
    return lexsort(key_a, key_b), lexsort(key_b, key_a)


def _ranks(*keys: np.ndarray) -> list | None:
    """Each key's ranks among its distinct values (int32) and their number; None where
    a key has a NaN (a stable sort keeps the order of NaNs, which are unequal) or the
    pairs of distinct values exceed :data:`MAX_BUCKETS` or four a key."""
    from ..kernels import loops_runs

    out, buckets = [], 1
    for key in keys:
        if not key.size:
            return None
        # every distinct value starts a run of equal keys: the distinct values of the
        # runs' first keys (a MERL file's 274,054 keys start 14,584 and 19,303 runs)
        starts = np.empty(key.size, dtype=bool)
        starts[0] = True
        np.not_equal(key[1:], key[:-1], out=starts[1:])
        values = np.unique(key[starts])  # sorted; -0.0 == 0.0: one value
        if np.isnan(values[-1]):  # numpy sorts NaN last
            return None
        buckets *= values.size
        if buckets > min(MAX_BUCKETS, 4 * key.size):
            return None
        out.append((np.ascontiguousarray(key, dtype=float), values))
    ranked = []
    for key, values in out:
        rank = np.empty(key.size, dtype=np.int32)
        loops_runs.ranks(key, values, rank)
        ranked.append((rank, values.size))
    return ranked


def residual_signs(pred: np.ndarray, values: np.ndarray, step: int) -> np.ndarray:
    """:func:`sign_codes` of ``pred - values`` (N, C) on every ``step``-th sample: from
    :data:`~brdffit.kernels.MIN_PAIRS` such samples on, where the kernels run, in one
    compiled pass over those rows (:func:`brdffit.kernels.loops_runs.sign_codes_every`;
    the same codes)."""
    rows = -(-len(pred) // step)
    compiled = pred.ndim == 2 and pred.shape == values.shape and rows >= kernels.MIN_PAIRS
    if compiled and kernels.wanted(rows, modules=("loops_runs",)):
        from ..kernels import loops_runs

        codes = np.empty((pred.shape[1], rows), dtype=np.int8)
        f, y = np.ascontiguousarray(pred, dtype=float), np.ascontiguousarray(values, dtype=float)
        loops_runs.sign_codes_every(f, y, step, codes)
        return codes
    return sign_codes(np.subtract(pred[::step].T, values[::step].T).T)  # (C, N) rows


def sign_codes(z: np.ndarray) -> np.ndarray:
    """The signs of ``z`` (N, C) as int8 rows (C, N): 2 above 0, 1 below (and NaN,
    which ``> 0`` calls negative), 0 for an exact 0, which the runs test leaves out."""
    codes = (z > 0).view(np.int8) + (z != 0).view(np.int8)
    return np.ascontiguousarray(codes.T)


def runs(codes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Wald-Wolfowitz runs test of the signs of each row of ``codes`` (C, M) in its order
    (:func:`sign_codes`; zeros left out).

    Returns the runs counted, the runs expected of independent signs
    (``2 n+ n- / n + 1``), and ``z = (expected - counted) / sd`` with
    ``sd^2 = 2 n+ n- (2 n+ n- - n) / (n^2 (n - 1))`` (Wald and Wolfowitz 1940,
    Ann. Math. Statist. 11, 147): large when residuals of one sign cluster. Signs,
    not values: one large residual cannot decide it, and unequal variances do not
    matter. Fewer short rows without a zero are counted by two sums along the rows
    (a fit's 3 rows of 600 signs: 12 -> 8 us). Many short rows (:data:`VECTOR_ROWS`,
    :data:`VECTOR_LENGTH`) are counted
    together, those without a zero by three reductions over every row, and their
    statistics formed at once (a 31-band fit's 31 rows of 1,439 signs: 120 -> 60 us);
    others as :func:`runs_by_row` does (numpy's reductions along rows take 0.7 ns a
    value, its flat counts 0.2: three rows of 275,000 signs, 575 against 146 us). The
    same integers and operations either way, so the same values.
    """
    c, m = codes.shape
    if c < VECTOR_ROWS and 0 < m <= VECTOR_LENGTH and codes.all():  # few short rows, no 0:
        n1 = (codes == 2).sum(axis=1).tolist()  # _count's integers, 2 us a row less
        changes = (codes[:, 1:] != codes[:, :-1]).sum(axis=1).tolist()
        return _statistics([(m, a, 1 + b) for a, b in zip(n1, changes)])
    if c < VECTOR_ROWS or m > VECTOR_LENGTH:
        return runs_by_row(codes)
    whole = codes.min(axis=1) > 0 if m else np.zeros(c, dtype=bool)
    n, n1, counted = np.full(c, m), np.empty(c, dtype=np.int64), np.empty(c, dtype=np.int64)
    if whole.any():
        rows = codes[whole] if not whole.all() else codes
        n1[whole] = np.count_nonzero(rows == 2, axis=1)
        counted[whole] = 1 + np.count_nonzero(rows[:, 1:] != rows[:, :-1], axis=1)
    for i in np.flatnonzero(~whole):
        n[i], n1[i], counted[i] = _count(codes[i])
    # _statistics' formulas on arrays: the same operations in the same order on doubles
    # (the counts are below 2**53), so the same values
    n2 = n - n1
    mu = 2.0 * n1 * n2 / np.maximum(n, 1) + 1.0
    var = 2.0 * n1 * n2 * (2.0 * n1 * n2 - n) / np.maximum(n * n * (n - 1), 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        z = np.where(var > 0, (mu - counted) / np.sqrt(np.maximum(var, 0.0)), 0.0)
    return counted, mu, z


def runs_by_row(codes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`runs` row by row: the plain way, which the tests hold it to."""
    return _statistics([_count(row) for row in codes])


def _count(row: np.ndarray) -> tuple[int, int, int]:
    """Signs, positive signs and runs of one row of codes, its zeros left out."""
    if not row.all():
        row = row[row != 0]
    n = row.size
    n1 = int(np.count_nonzero(row == 2))
    return n, n1, 1 + int(np.count_nonzero(row[1:] != row[:-1])) if n else 0


def _statistics(counts: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Runs, expected runs and ``z`` of each row's (signs, positive signs, runs)."""
    out_r, out_mu, out_z = [], [], []
    for n, n1, counted in counts:
        n2 = n - n1
        mu = 2.0 * n1 * n2 / max(n, 1) + 1.0
        var = 2.0 * n1 * n2 * (2.0 * n1 * n2 - n) / max(n * n * (n - 1), 1)
        out_r.append(counted)
        out_mu.append(mu)
        out_z.append((mu - counted) / math.sqrt(var) if var > 0 else 0.0)
    return np.array(out_r), np.array(out_mu), np.array(out_z)
