"""Quaternion sanity checks for trajectory files: warnings, vectorised, never errors.

A quaternion read in the wrong storage order (``xyzw`` as ``wxyz``) is still a unit quaternion,
and — tempting and false — the obvious checks cannot see it: the norm, the sign of ``q_i·q_{i+1}``
and the implied angular rate ``2·acos|q_i·q_{i+1}|/Δt`` are all unchanged by permuting the
components. They catch other faults (unnormalised or garbled numbers, columns shifted, time in
the wrong unit). What does reveal the order is the **hemisphere**: writers commonly store
``w ≥ 0`` (GTSAM's ``Rot3::toQuaternion``, the TUM tools), and a sample pair whose sign flips
is where the true ``w`` crosses 0. So:

* norms: ``|‖q‖ − 1| > norm_tol`` (count, first index, worst);
* sign flips: ``q_i·q_{i+1} < 0`` (count, first index; reported, and part of the warning only
  as evidence of the order): at the flips the component nearest 0 is the true scalar of a
  ``w ≥ 0`` writer — if that is not the assumed scalar slot, the order is likely wrong;
* order: the assumed scalar slot takes both signs while another slot never goes negative —
  warn and name the order that would make that slot the scalar;
* implied angular rate ``2·acos(min(1, |q_i·q_{i+1}|))/(t_{i+1} − t_i)`` above ``max_rate``
  (default 30 rad/s ≈ 1700 °/s; with no timestamps, a step above 90°) in more than 1 % of the
  steps (a noisy estimate at a high rate has isolated fast steps; garbled columns or stamps in
  the wrong unit make most steps fast).

:func:`check_quaternions` returns a :class:`QuaternionReport` and emits one
:class:`QuaternionOrderWarning` listing what it found. :func:`hemisphere_continuous` is what
liebridge's TUM and EuRoC writers apply (:func:`liebridge.io.trajectory.tum_quaternions`: the first
quaternion with ``w ≥ 0``, then each sample the sign nearest the previous one,
``q_i·q_{i−1} ≥ 0``), so component-wise interpolation and differencing of the written file behave.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray

__all__ = [
    "QuaternionOrderWarning",
    "QuaternionReport",
    "check_quaternions",
    "hemisphere_continuous",
]

_SCALAR_SLOT = {"xyzw": 3, "wxyz": 0}
_ORDER_WITH_SCALAR_AT = {3: "xyzw", 0: "wxyz"}


class QuaternionOrderWarning(UserWarning):
    """Quaternions that look unnormalised, garbled, too fast or stored in another order."""


@dataclass(frozen=True)
class QuaternionReport:
    """What :func:`check_quaternions` found (indices 0-based; ``-1`` for none)."""

    n: int
    order: str
    bad_norms: int
    first_bad_norm: int
    worst_norm_error: float
    sign_flips: int
    first_sign_flip: int
    too_fast: int
    first_too_fast: int
    max_rate: float
    suggested_order: str | None
    messages: tuple[str, ...]

    @property
    def ok(self) -> bool:
        """No finding."""
        return not self.messages


def hemisphere_continuous(q: Any) -> FloatArray:
    """Flip signs so consecutive quaternions have ``q_i·q_{i−1} ≥ 0`` (same rotations).

    Parameters
    ----------
    q : array_like, shape (N, 4)
        Any storage order (the sign choice does not depend on it).
    """
    a = validate.vector(q, "q", 4)
    if a.ndim != 2:
        raise ValueError(f"q: expected shape (N, 4), got {a.shape}")
    if a.shape[0] < 2:
        return a.copy()
    dots = np.einsum("ij,ij->i", a[1:], a[:-1])
    sign = np.concatenate([[1.0], np.cumprod(np.where(dots < 0, -1.0, 1.0))])
    return np.asarray(a * sign[:, None], dtype=np.float64)


def check_quaternions(
    q: Any,
    order: str,
    timestamps: Any = None,
    *,
    norm_tol: float = 1e-3,
    max_rate: float = 30.0,
    source: str = "quaternions",
    warn: bool = True,
) -> QuaternionReport:
    """Look for signs of a wrong storage order or garbled quaternions; warn, never raise.

    Parameters
    ----------
    q : array_like, shape (N, 4)
        As stored (before normalisation), in ``order``.
    order : {"xyzw", "wxyz"}
        The order they are read in.
    timestamps : array_like, shape (N,), optional
        Seconds; enables the angular-rate check in rad/s.
    norm_tol, max_rate : float
    source : str
        Named in the warning (a file name).
    warn : bool
        Emit a :class:`QuaternionOrderWarning` when something is found.
    """
    if order not in _SCALAR_SLOT:
        raise ValueError(f"order: expected 'xyzw' or 'wxyz', got {order!r}")
    a = validate.vector(q, "q", 4)
    if a.ndim != 2:
        raise ValueError(f"q: expected shape (N, 4), got {a.shape}")
    n = a.shape[0]
    msgs: list[str] = []
    norm_err = np.abs(np.linalg.norm(a, axis=-1) - 1.0)
    bad = np.flatnonzero(norm_err > norm_tol)
    if bad.size:
        msgs.append(
            f"{bad.size} of {n} quaternions are not unit (first at index {int(bad[0])}, worst "
            f"norm error {float(norm_err.max()):.3g})"
        )
    u = a / np.maximum(np.linalg.norm(a, axis=-1, keepdims=True), 1e-300)
    dots = np.einsum("ij,ij->i", u[1:], u[:-1]) if n > 1 else np.zeros(0)
    flips = np.flatnonzero(dots < 0)
    s = _SCALAR_SLOT[order]
    suggested: str | None = None
    flip_msg = ""
    if flips.size:
        # a w ≥ 0 writer flips where the true scalar crosses 0: the slot nearest 0 there
        near0 = np.abs(0.5 * (np.abs(u[flips]) + np.abs(u[flips + 1]))).mean(axis=0)
        slot = int(np.argmin(near0))
        flip_msg = (
            f"{flips.size} sign flips between consecutive samples (first between "
            f"{int(flips[0])} and {int(flips[0]) + 1}), where slot {slot} is nearest 0"
        )
        if slot != s and near0[slot] < 0.5 * near0[s]:
            suggested = _ORDER_WITH_SCALAR_AT.get(slot)
    neg = (u < 0).any(axis=0)
    if n >= 10 and neg[s] and not neg.all():
        never = [k for k in range(4) if not neg[k] and k != s]
        if len(never) == 1 and never[0] in _ORDER_WITH_SCALAR_AT:
            suggested = _ORDER_WITH_SCALAR_AT[never[0]]
    if suggested is not None and suggested != order:
        if flips.size:
            msgs.append(flip_msg)
        msgs.append(
            f"the scalar read as w (slot {s}) takes both signs where slot "
            f"{_SCALAR_SLOT[suggested]} behaves like the scalar of a w ≥ 0 writer: the order "
            f"is likely {suggested!r}, not {order!r}"
        )
    else:
        suggested = None
    ang = 2.0 * np.arccos(np.clip(np.abs(dots), 0.0, 1.0))
    if timestamps is not None and n > 1:
        t = validate.as_float_array(timestamps, "timestamps").reshape(-1)
        dt = np.diff(t) if t.size == n else np.full(n - 1, np.nan)
        with np.errstate(divide="ignore", invalid="ignore"):
            rate = np.where(dt > 0, ang / dt, 0.0)  # stamps that do not increase: not judged here
        fast = np.flatnonzero(rate > max_rate)
        limit = f"{max_rate:g} rad/s"
    else:
        rate = ang
        fast = np.flatnonzero(ang > 0.5 * math.pi)
        limit = "90° per sample"
    top = float(np.max(rate)) if rate.size else 0.0
    if fast.size > 0.01 * max(n - 1, 1):  # isolated fast steps are noise; garbling is systematic
        msgs.append(
            f"{fast.size} steps turn faster than {limit} (first between {int(fast[0])} and "
            f"{int(fast[0]) + 1}, fastest {top:.3g}); garbled columns or timestamps in the "
            f"wrong unit?"
        )
    report = QuaternionReport(
        n=n,
        order=order,
        bad_norms=int(bad.size),
        first_bad_norm=int(bad[0]) if bad.size else -1,
        worst_norm_error=float(norm_err.max()) if n else 0.0,
        sign_flips=int(flips.size),
        first_sign_flip=int(flips[0]) if flips.size else -1,
        too_fast=int(fast.size),
        first_too_fast=int(fast[0]) if fast.size else -1,
        max_rate=top,
        suggested_order=suggested,
        messages=tuple(msgs),
    )
    if warn and msgs:
        warnings.warn(
            f"{source} (read as {order}): " + "; ".join(msgs),
            QuaternionOrderWarning,
            stacklevel=2,
        )
    return report
