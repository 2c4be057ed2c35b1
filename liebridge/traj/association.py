"""Association of two trajectories by their timestamps, as evo does it.

Timestamps are seconds (``float64``), one per pose, **strictly increasing** (a repeated or
decreasing stamp is an error here, naming its index; evo falls back to a linear search instead).
Two stamps are associated when ``|t_ref − (t_est + offset)| ≤ max_diff``; the defaults,
``max_diff = 0.01`` s and ``offset = 0`` s, are evo's (``evo.core.sync.associate_trajectories``,
evo 1.38, file ``evo/core/sync.py``).

Matching follows evo exactly: the trajectory with fewer poses (the estimate when both have the
same number) is walked, and each of its stamps takes the nearest stamp of the other one (ties go
to the earlier stamp), if it is within ``max_diff``. A pose of the longer trajectory can be
matched twice when its neighbours in the shorter one are both nearest to it; evo keeps such
pairs, and so does :func:`associate`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from .. import _validate as validate
from .._validate import FloatArray

__all__ = ["MAX_DIFF", "associate", "check_timestamps"]

#: evo's default largest time difference of an associated pair, in seconds.
MAX_DIFF = 0.01

IntArray = npt.NDArray[np.intp]


def check_timestamps(t: Any, name: str) -> FloatArray:
    """Validate a 1-D, finite, strictly increasing array of timestamps (seconds).

    Raises
    ------
    ValueError
        Naming ``name``, the first index where a stamp does not increase and both stamps.
    """
    arr = validate.as_float_array(t, name)
    if arr.ndim != 1:
        raise ValueError(f"{name}: expected shape (N,), got {arr.shape}")
    if arr.size == 0:
        raise ValueError(f"{name}: no poses")
    validate.check_finite(arr, name, core_ndim=0)
    bad = np.flatnonzero(arr[1:] <= arr[:-1])  # not np.diff: ±1e308 apart overflows
    if bad.size:
        i = int(bad[0]) + 1
        what = "repeats" if arr[i] == arr[i - 1] else "goes back in time from"
        raise ValueError(
            f"{name}: timestamps are not strictly increasing: stamp {i} ({float(arr[i])!r}) "
            f"{what} stamp {i - 1} ({float(arr[i - 1])!r}); {bad.size} such place(s) in all"
        )
    return arr


def _match(short: FloatArray, long: FloatArray, max_diff: float) -> tuple[IntArray, IntArray]:
    """Match sorted stamps as evo's ``matching_time_indices`` does, vectorised."""
    idx = np.searchsorted(long, short, side="right")
    idx = np.minimum(idx, long.size - 1)
    diff_ub = long[idx] - short
    prev = np.maximum(idx - 1, 0)
    diff_lb = np.where(idx > 0, short - long[prev], np.inf)
    inside = (short >= long[0] - max_diff) & (short <= long[-1] + max_diff)
    take_ub = (diff_ub <= max_diff) & (diff_ub < diff_lb)
    take_lb = ~take_ub & (diff_lb <= max_diff) & (diff_lb <= diff_ub)
    ok = inside & (take_ub | take_lb)
    best = np.where(take_ub, idx, idx - 1)
    return np.flatnonzero(ok).astype(np.intp), best[ok].astype(np.intp)


def associate(
    t_ref: Any, t_est: Any, *, max_diff: float = MAX_DIFF, offset: float = 0.0
) -> tuple[IntArray, IntArray]:
    """Return the indices of the associated poses of a reference and an estimate.

    Parameters
    ----------
    t_ref, t_est : array_like, shape (N,), (M,)
        Timestamps in seconds, strictly increasing.
    max_diff : float
        Largest ``|t_ref − (t_est + offset)|`` of a pair (evo's default 0.01 s).
    offset : float
        Added to the estimate's stamps before matching (evo's ``offset_2``, default 0).

    Returns
    -------
    i_ref, i_est : ndarray of int, shape (K,)
        ``t_ref[i_ref[k]]`` is associated with ``t_est[i_est[k]]``; increasing in the walked
        (shorter) trajectory's index.

    Raises
    ------
    ValueError
        On bad stamps (see :func:`check_timestamps`), a negative ``max_diff``, or when no stamp
        pair is within ``max_diff`` (naming both time ranges).
    """
    a = check_timestamps(t_ref, "t_ref")
    b = check_timestamps(t_est, "t_est")
    if not (np.isfinite(max_diff) and max_diff >= 0):
        raise ValueError(f"max_diff: expected a finite number ≥ 0, got {max_diff!r}")
    if not np.isfinite(offset):
        raise ValueError(f"offset: expected a finite number, got {offset!r}")
    if b.size > a.size:  # walk the reference, match into the (longer) estimate
        i_ref, i_est = _match(a, b + offset, max_diff)
    else:  # walk the estimate, match into the reference (evo: offset with the opposite sign)
        i_est, i_ref = _match(b, a - offset, max_diff)
    if i_ref.size == 0:
        a0, a1, b0, b1 = (float(x) for x in (a[0], a[-1], b[0] + offset, b[-1] + offset))
        raise ValueError(
            f"no overlapping timestamps: reference spans [{a0!r}, {a1!r}] s, estimate "
            f"(offset {offset!r} s) spans [{b0!r}, {b1!r}] s; no pair is within "
            f"max_diff = {max_diff!r} s"
        )
    return i_ref, i_est
