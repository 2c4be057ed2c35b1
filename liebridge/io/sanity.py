"""Trajectory-file sanity: the quaternion-order check and the policy for imperfect real files.

A quaternion read in the wrong storage order (``xyzw`` as ``wxyz``) is still a unit quaternion,
and — tempting and false — the obvious checks cannot see it: the norm, the sign of ``q_i·q_{i+1}``
and the implied angular rate ``2·acos|q_i·q_{i+1}|/Δt`` are all unchanged by permuting the
components. Nor can any check of the rotations alone: a cyclic shift of the four components is
an improper orthogonal map of ℝ⁴, ``q ↦ a·q̄·b`` for fixed unit quaternions ``a, b``, so the
misread rotations are ``R'_i = A·R_iᵀ·B``: the same trajectory with world and body swapped (its
body angular velocity is the true world angular velocity turned by a fixed rotation, and vice
versa), every bit as smooth. Within one file only the **translation** can tell the two readings
apart: a vehicle, a robot, a drone or a camera carried through a scene travels in a direction
that is steady in its own frame, and the misread rotations scatter that direction.
:func:`quaternion_order_evidence` measures it (:class:`OrderEvidence`); without enough
translation and rotation it says it cannot tell. Across two files of one motion, the body-frame
rotation increments decide (:func:`relative_order_evidence`): the misread file's are the other's
world-frame increments. The weaker, writer-dependent evidence is the **hemisphere**: writers
commonly store ``w ≥ 0`` (GTSAM's ``Rot3::toQuaternion``, the TUM tools), and a sample pair whose
sign flips is where the true ``w`` crosses 0 — but liebridge's own writers keep hemisphere
continuity, so ``w`` of a 360° turn takes both signs; it is used only when the translation cannot
be measured. So:

* norms: ``|‖q‖ − 1| > norm_tol`` (count, first index, worst);
* sign flips: ``q_i·q_{i+1} < 0`` (count, first index; reported, and part of the warning only
  as evidence of the order): at the flips the component nearest 0 is the true scalar of a
  ``w ≥ 0`` writer — if that is not the assumed scalar slot, the order is likely wrong;
* order: the translation evidence first (:func:`quaternion_order_evidence`, when positions are
  given): a warning only when the other reading keeps the direction of travel steadier in the
  body frame by a clear factor, saying how sure (``"strong"``, ``"moderate"``); when the
  translation cannot be measured (no positions, too little translation or rotation), the sign
  pattern of a ``w ≥ 0`` writer (sign flips where one slot is near 0; the assumed scalar slot
  takes both signs while a larger slot never goes negative) as ``"weak"`` evidence;
* implied angular rate ``2·acos(min(1, |q_i·q_{i+1}|))/(t_{i+1} − t_i)`` above ``max_rate``
  (default 30 rad/s ≈ 1700 °/s; with no timestamps, a step above 90°) in more than 1 % of the
  steps (a noisy estimate at a high rate has isolated fast steps; garbled columns or stamps in
  the wrong unit make most steps fast).

:func:`check_quaternions` returns a :class:`QuaternionReport` and emits one
:class:`QuaternionOrderWarning` listing what it found. :func:`hemisphere_continuous` is what
liebridge's TUM and EuRoC writers apply (:func:`liebridge.io.trajectory.tum_quaternions`: the first
quaternion with ``w ≥ 0``, then each sample the sign nearest the previous one,
``q_i·q_{i−1} ≥ 0``), so component-wise interpolation and differencing of the written file behave.

**Imperfect real files** (one policy for every trajectory reader and the ``traj`` command):

* repeated timestamps (TUM ``fr2/desk`` ground truth, evo's EuRoC estimates): equal consecutive
  stamps are collapsed by :func:`repeated_stamps` — ``duplicates="first"`` (default) keeps the
  first of each run and warns with the count (an :class:`ImperfectFileWarning`), ``"last"`` keeps
  the last, ``"error"`` raises :class:`RepeatedStampError` naming file, line and count;
* quaternions off unit: :func:`unit_quaternions` normalises those within ``quat_tolerance``
  (:data:`QUAT_TOLERANCE`, ``1e-3``: 4-decimal TUM ground truth, ``%.18e`` prints of 5-decimal
  numbers and EuRoC ground truth are off by up to ~1.5e-4) and warns with the worst deviation
  when it is more than the printed precision explains; beyond the tolerance it raises
  :class:`QuaternionNormError` naming file, line and deviation.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray

__all__ = [
    "DUPLICATE_POLICIES",
    "QUAT_TOLERANCE",
    "ImperfectFileWarning",
    "OrderEvidence",
    "QuaternionNormError",
    "QuaternionOrderConflictError",
    "QuaternionOrderWarning",
    "QuaternionReport",
    "RepeatedStampError",
    "check_quaternions",
    "hemisphere_continuous",
    "other_reading",
    "quaternion_order_evidence",
    "relative_order_evidence",
    "repeated_stamps",
    "unit_quaternions",
]

#: What a reader does with repeated timestamps.
DUPLICATE_POLICIES: tuple[str, ...] = ("first", "last", "error")
#: Largest ``|‖q‖ − 1|`` a reader normalises (beyond: :class:`QuaternionNormError`).
QUAT_TOLERANCE = 1e-3

_SCALAR_SLOT = {"xyzw": 3, "wxyz": 0}
_ORDER_WITH_SCALAR_AT = {3: "xyzw", 0: "wxyz"}


class QuaternionOrderWarning(UserWarning):
    """Quaternions that look unnormalised, garbled, too fast or stored in another order."""


class ImperfectFileWarning(UserWarning):
    """A real file read as it is: repeated stamps dropped, quaternions off unit normalised."""


class RepeatedStampError(ValueError):
    """Repeated timestamps under ``duplicates="error"``.

    ``str()`` names the Python keyword; ``detail`` is the message without it (the CLI adds its
    flag).
    """

    def __init__(self, detail: str, hint: str) -> None:
        super().__init__(f"{detail}; {hint}")
        self.detail = detail


class QuaternionNormError(ValueError):
    """A quaternion off unit by more than ``quat_tolerance`` (``detail``: without the hint)."""

    def __init__(self, detail: str, hint: str) -> None:
        super().__init__(f"{detail}; {hint}")
        self.detail = detail


class QuaternionOrderConflictError(ValueError):
    """A file's header names one quaternion order and the caller asked for the other.

    The header wins: reading on in the asked order would be a silent wrong answer.
    """

    def __init__(self, detail: str, hint: str) -> None:
        super().__init__(f"{detail}; {hint}")
        self.detail = detail


def _line_numbers(lines: Any) -> Callable[[int], int] | None:
    if lines is None:
        return None
    if callable(lines):
        return lambda r: int(lines(r))
    arr = np.asarray(lines).reshape(-1)
    return lambda r: int(arr[r])


def repeated_stamps(
    stamps: Any,
    duplicates: str = "first",
    *,
    source: str = "timestamps",
    lines: Any = None,
    warn: bool = True,
) -> Any:
    """Rows to keep under the repeated-timestamp policy (equal consecutive stamps form a run).

    Parameters
    ----------
    stamps : array_like, shape (N,)
        As read (float seconds, or integer nanoseconds for exact comparison).
    duplicates : {"first", "last", "error"}
        Keep the first of each run of equal stamps (default; the first sample logged), the last,
        or raise :class:`RepeatedStampError`.
    source : str
        The file, named in the warning and the error.
    lines : array_like of int, shape (N,), or callable, optional
        1-based line numbers of the rows (or ``lines(row) -> int``), named in the messages.
    warn : bool
        Emit an :class:`ImperfectFileWarning` with the count when rows are dropped.

    Returns
    -------
    ndarray of intp, shape (M,)
        Indices of the rows kept, increasing (``arange(N)`` when no stamp repeats).
    """
    if duplicates not in DUPLICATE_POLICIES:
        raise ValueError(
            f"duplicates: expected one of {', '.join(DUPLICATE_POLICIES)}, got {duplicates!r}"
        )
    t = np.asarray(stamps).reshape(-1)
    n = t.size
    same = np.flatnonzero(t[1:] == t[:-1])  # row same+1 repeats row same
    if same.size == 0:
        return np.arange(n, dtype=np.intp)
    rows = same + 1
    line_of = _line_numbers(lines)
    where = f"line {line_of(int(rows[0]))}" if line_of is not None else f"row {int(rows[0])}"
    what = (
        f"{source}: {same.size} repeated timestamp(s) (first at {where}: {t[rows[0]].item()!r} "
        f"repeats the stamp before it)"
    )
    if duplicates == "error":
        raise RepeatedStampError(what, 'duplicates="first" or "last" keeps one of each')
    drop = same + 1 if duplicates == "first" else same
    keep = np.ones(n, dtype=bool)
    keep[drop] = False
    if warn:
        warnings.warn(
            f"{what}; kept the {duplicates} of each, dropped {same.size}",
            ImperfectFileWarning,
            stacklevel=2,
        )
    return np.flatnonzero(keep).astype(np.intp)


def unit_quaternions(
    q: Any,
    quat_tolerance: float = QUAT_TOLERANCE,
    *,
    source: str = "quaternions",
    lines: Any = None,
    explained: Any = None,
    warn: bool = True,
) -> FloatArray:
    """Normalise quaternions read from a file under the off-unit policy.

    Parameters
    ----------
    q : array_like, shape (N, 4)
        As read, any storage order (the norm does not depend on it).
    quat_tolerance : float
        Largest ``|‖q‖ − 1|`` normalised; beyond it :class:`QuaternionNormError` names the file,
        line and deviation of the first such row.
    source : str
        The file.
    lines : array_like of int, shape (N,), or callable, optional
        1-based line numbers (or ``lines(row) -> int``), for the messages.
    explained : callable, optional
        ``explained(row) -> float``: the deviation the printed precision of that row explains
        (:func:`liebridge.io.poses.text_quaternion_tol`); no warning when the worst deviation is
        within it. Default: ``1e-6``.
    warn : bool
        Emit an :class:`ImperfectFileWarning` with the count and the worst deviation when some
        deviation is more than the printed precision explains.

    Returns
    -------
    ndarray, shape (N, 4)
        Unit quaternions (a new array).
    """
    tol = float(quat_tolerance)
    if not (math.isfinite(tol) and tol >= 0):
        raise ValueError(f"quat_tolerance: expected a finite number ≥ 0, got {quat_tolerance!r}")
    a = validate.as_float_array(q, "q")
    if a.ndim != 2 or a.shape[-1] != 4:
        raise ValueError(f"q: expected shape (N, 4), got {a.shape}")
    norm = np.linalg.norm(a, axis=-1)
    err = np.abs(norm - 1.0)
    line_of = _line_numbers(lines)

    def where(r: int) -> str:
        return f"{source}:{line_of(r)}" if line_of is not None else f"{source}: row {r}"

    bad = np.flatnonzero(~(err <= tol))
    if bad.size:
        r = int(bad[0])
        raise QuaternionNormError(
            f"{where(r)}: quaternion norm off by {err[r]:.3g} (tolerance {tol:g}; {bad.size} such "
            f"line(s) in all)",
            "quat_tolerance= accepts and normalises more",
        )
    r = int(np.argmax(err)) if a.shape[0] else 0
    if a.shape[0] and warn and err[r] > validate.QUATERNION_TOL:  # else nothing to explain
        limit = float(explained(r)) if explained is not None else validate.QUATERNION_TOL
        if err[r] > limit:
            many = int(np.count_nonzero(err > validate.QUATERNION_TOL))
            at = f"line {line_of(r)}" if line_of is not None else f"row {r}"
            warnings.warn(
                f"{source}: normalised {many} quaternion(s) off unit by more than 1e-06; worst "
                f"{err[r]:.3g} at {at}",
                ImperfectFileWarning,
                stacklevel=2,
            )
    return np.asarray(a / norm[:, None], dtype=np.float64)


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
    #: How sure the order finding is: ``"strong"``/``"moderate"`` (translation evidence, for
    #: or against ``order``), ``"weak"`` (the sign pattern only), ``"none"``.
    order_confidence: str = "none"
    #: The translation evidence (None without positions).
    order_evidence: OrderEvidence | None = None

    @property
    def ok(self) -> bool:
        """No finding."""
        return not self.messages


@dataclass(frozen=True)
class OrderEvidence:
    """What the direction of travel says about a quaternion storage order.

    Returned by :func:`quaternion_order_evidence`.

    Attributes
    ----------
    order : str
        The order the quaternions were read in.
    likely_order : str or None
        The order the evidence favours (``order`` itself when it is supported), None when it
        cannot tell.
    confidence : {"strong", "moderate", "none"}
        ``"strong"``: the other reading scatters the body-frame direction of travel 10× more (or
        less); ``"moderate"``: 3×; ``"none"``: less than 3×, or too little translation or
        rotation to judge.
    ratio : float
        ``(D_other + 0.01) / (D_read + 0.01)``, with ``D`` the dispersion (below); > 1 favours
        ``order``. NaN when not measured.
    dispersion_read, dispersion_other : float
        ``D = 1 − λ_max(mean u uᵀ)`` of the unit body-frame directions of travel ``u`` (0: one
        axis; 2/3: all directions), read in ``order`` and in the other order.
    segments : int
        Number of travel segments measured.
    reason : str
        One line: what was measured, or why it cannot tell.
    """

    order: str
    likely_order: str | None
    confidence: str
    ratio: float
    dispersion_read: float
    dispersion_other: float
    segments: int
    reason: str


def _matrices(u: FloatArray, order: str) -> FloatArray:
    """Rotation matrices of unit quaternions ``u`` stored in ``order`` (Hamilton)."""
    if order == "xyzw":
        x, y, z, w = u[:, 0], u[:, 1], u[:, 2], u[:, 3]
    else:
        w, x, y, z = u[:, 0], u[:, 1], u[:, 2], u[:, 3]
    R = np.empty((u.shape[0], 3, 3))
    R[:, 0, 0] = 1 - 2 * (y * y + z * z)
    R[:, 0, 1] = 2 * (x * y - z * w)
    R[:, 0, 2] = 2 * (x * z + y * w)
    R[:, 1, 0] = 2 * (x * y + z * w)
    R[:, 1, 1] = 1 - 2 * (x * x + z * z)
    R[:, 1, 2] = 2 * (y * z - x * w)
    R[:, 2, 0] = 2 * (x * z - y * w)
    R[:, 2, 1] = 2 * (y * z + x * w)
    R[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return R


#: Samples the order evidence looks at (evenly strided; bounds its cost on huge files).
_EVIDENCE_SAMPLES = 20000


#: Most travel segments measured (bounds the Python loop of :func:`_travel_segments`).
_MAX_SEGMENTS = 2000


def _travel_segments(p: FloatArray, d: float) -> tuple[Any, Any]:
    """Greedy chords ``(lo, hi)`` with ``|p[hi] − p[lo]| ≥ d``, each ``hi`` the next ``lo``.

    Chords, not path length: a noisy position jitters a long path in place, never a long chord.
    Each sample is scanned about once (chunks doubling from 64), so the cost is O(N).
    """
    n = p.shape[0]
    lo: list[int] = []
    hi: list[int] = []
    a = 0
    while a < n - 1 and len(lo) < _MAX_SEGMENTS:
        found, start, chunk = -1, a + 1, 64
        while start < n:
            stop = min(n, start + chunk)
            far = np.flatnonzero(np.linalg.norm(p[start:stop] - p[a], axis=-1) >= d)
            if far.size:
                found = start + int(far[0])
                break
            start, chunk = stop, 2 * chunk
        if found < 0:
            break
        lo.append(a)
        hi.append(found)
        a = found
    return np.asarray(lo, dtype=np.intp), np.asarray(hi, dtype=np.intp)


def quaternion_order_evidence(q: Any, order: str, positions: Any) -> OrderEvidence:
    """Weigh ``order`` against the other storage order by the direction of travel.

    The trajectory is cut into travel segments by path length (``1/50`` of the extent of the
    positions; at most about 2000); each segment's chord ``p_b − p_a`` is turned into the body
    frame by the rotation at its middle sample, read once in ``order`` and once in the other
    order. A body that moves along a steady axis of its own (a car or robot forward, a drone or
    a camera mostly forward or sideways) gives unit directions ``u`` near one axis (axial
    dispersion ``D = 1 − λ_max(mean u uᵀ)`` near 0, reversing included) in the right reading
    and scattered ones in the wrong reading, which turns with the world instead of the body.
    When neither reading's ``D`` reaches 0.05 (the rotation is too small to separate them) or
    fewer than 8 segments exist (no translation), it cannot tell. A body that moves in any
    direction of its own frame (a hand-held camera waved about) gives a ratio near 1:
    ``"none"``, never a guess.

    Parameters
    ----------
    q : array_like, shape (N, 4)
        Unit quaternions as stored, in ``order``.
    order : {"xyzw", "wxyz"}
    positions : array_like, shape (N, 3)
        ``t_world_body`` of the same rows.

    Returns
    -------
    OrderEvidence
    """
    if order not in _SCALAR_SLOT:
        raise ValueError(f"order: expected 'xyzw' or 'wxyz', got {order!r}")
    other = "wxyz" if order == "xyzw" else "xyzw"
    a = validate.vector(q, "q", 4)
    p = validate.vector(positions, "positions", 3)
    if a.ndim != 2 or p.shape != (a.shape[0], 3):
        raise ValueError(
            f"positions: expected shape ({a.shape[0] if a.ndim == 2 else 'N'}, 3) to match q, "
            f"got {p.shape}"
        )
    if a.shape[0] > _EVIDENCE_SAMPLES:
        pick = np.linspace(0, a.shape[0] - 1, _EVIDENCE_SAMPLES).astype(np.intp)
        a, p = a[pick], p[pick]
    with np.errstate(all="ignore"):  # 1e300 positions: "cannot tell", never a numpy warning
        return _order_evidence(a, p, order, other)


def _order_evidence(a: FloatArray, p: FloatArray, order: str, other: str) -> OrderEvidence:
    nan = float("nan")

    def none(reason: str, segs: int = 0, d1: float = nan, d2: float = nan) -> OrderEvidence:
        return OrderEvidence(order, None, "none", nan, d1, d2, segs, reason)

    n = a.shape[0]
    if n < 3 or not (np.isfinite(a).all() and np.isfinite(p).all()):
        return none("too few poses to judge by the direction of travel")
    u = a / np.maximum(np.linalg.norm(a, axis=-1, keepdims=True), 1e-300)
    extent = float(np.linalg.norm(p.max(axis=0) - p.min(axis=0)))
    if not math.isfinite(extent):
        return none("positions too large to measure the direction of travel")
    if not extent > 0:
        return none("no translation: the order cannot be told from rotations alone")
    lo, hi = _travel_segments(p, extent / 50.0)
    if lo.size < 8:
        return none(
            f"too little translation ({lo.size} travel segments): the order cannot be told from "
            "rotations alone",
            int(lo.size),
        )
    chord = p[hi] - p[lo]
    length = np.linalg.norm(chord, axis=-1)
    mid = (lo + hi) // 2
    c = chord / length[:, None]

    def dispersion(o: str) -> float:
        R = _matrices(u[mid], o)
        v = np.einsum("nji,nj->ni", R, c)  # Rᵀ c: the direction in the body frame
        S = np.einsum("ni,nj->ij", v, v) / v.shape[0]
        return float(1.0 - np.linalg.eigvalsh(S)[-1])

    d_read, d_other = dispersion(order), dispersion(other)
    segs = int(lo.size)
    if max(d_read, d_other) < 0.05:
        return none(
            f"the rotation is too small to tell the orders apart (dispersion {d_read:.3f} read "
            f"as {order}, {d_other:.3f} as {other})",
            segs,
            d_read,
            d_other,
        )
    ratio = (d_other + 0.01) / (d_read + 0.01)
    if ratio >= 3.0 or ratio <= 1.0 / 3.0:
        likely = order if ratio > 1 else other
        conf = "strong" if max(ratio, 1.0 / ratio) >= 10.0 else "moderate"
    else:
        likely, conf = None, "none"
    reason = (
        f"the direction of travel in the body frame has dispersion {d_read:.3f} read as {order} "
        f"and {d_other:.3f} as {other} ({segs} segments)"
    )
    return OrderEvidence(order, likely, conf, float(ratio), d_read, d_other, segs, reason)


def other_reading(R: Any, order: str) -> FloatArray:
    """Read the same stored numbers in the other storage order: the rotations they give.

    Parameters
    ----------
    R : array_like, shape (N, 3, 3)
        Rotations as read in ``order`` (the sign of the stored quaternion does not matter).
    order : {"xyzw", "wxyz"}
        The order they were read in.

    Returns
    -------
    ndarray, shape (N, 3, 3)
        The stored four numbers (recovered up to sign) read in the other order.
    """
    if order not in _SCALAR_SLOT:
        raise ValueError(f"order: expected 'xyzw' or 'wxyz', got {order!r}")
    from ..lie import quaternion as quat

    q = quat.from_matrix(validate.as_float_array(R, "R"), order="xyzw")  # as read: x y z w
    stored = q if order == "xyzw" else q[..., [3, 0, 1, 2]]
    return _matrices(np.asarray(stored).reshape(-1, 4), "wxyz" if order == "xyzw" else "xyzw")


def _wahba_residual(a: FloatArray, b: FloatArray) -> float:
    """``min_B Σ|b − B a|² / Σ(|a|² + |b|²)`` over rotations ``B`` (a, b: (K, 3))."""
    H = b.T @ a
    U, _, Vt = np.linalg.svd(H)
    D = np.diag([1.0, 1.0, float(np.sign(np.linalg.det(U @ Vt)) or 1.0)])
    B = U @ D @ Vt
    r = b - a @ B.T
    return float(np.sum(r * r) / max(float(np.sum(a * a) + np.sum(b * b)), 1e-300))


def relative_order_evidence(R_ref: Any, R_est: Any, order_est: str) -> OrderEvidence:
    """Weigh EST's storage order against the other by REF's rotations (associated pairs).

    Whatever the world and body frames of two trajectories of one motion, their **body**
    increments ``R_iᵀ R_j`` are conjugate by one fixed rotation (the body-frame offset), and
    drift does not change that. EST misread is the same motion with world and body swapped
    (:mod:`liebridge.io.sanity`): its body increments are REF's *world* increments, conjugate to
    REF's body increments only when the motion turns about one fixed axis (planar motion, where
    the translation must decide: :func:`quaternion_order_evidence`). The rotation vectors of the
    body increments over pairs ``(i, i + k)`` (``k`` about ``N/100``; pairs turning less than 2°
    left out) are fitted by one rotation (Wahba) for EST read in ``order_est`` and in the other
    order; the normalised residuals are compared as in :func:`quaternion_order_evidence`
    (``dispersion_*`` hold the residuals; ``"none"`` when neither reaches 0.05).

    Parameters
    ----------
    R_ref, R_est : array_like, shape (N, 3, 3)
        Rotations of associated poses (row ``i`` of each at the same time).
    order_est : {"xyzw", "wxyz"}
        The order EST's quaternions were read in.
    """
    if order_est not in _SCALAR_SLOT:
        raise ValueError(f"order_est: expected 'xyzw' or 'wxyz', got {order_est!r}")
    from ..lie import so3

    other = "wxyz" if order_est == "xyzw" else "xyzw"
    A = validate.as_float_array(R_ref, "R_ref")
    E = validate.as_float_array(R_est, "R_est")
    if A.ndim != 3 or A.shape[1:] != (3, 3) or E.shape != A.shape:
        raise ValueError(f"R_est: expected shape {A.shape} to match R_ref, got {E.shape}")
    nan = float("nan")
    if A.shape[0] > _EVIDENCE_SAMPLES:  # evenly strided: bounds the cost on 10⁶ poses
        pick = np.linspace(0, A.shape[0] - 1, _EVIDENCE_SAMPLES).astype(np.intp)
        A, E = A[pick], E[pick]
    n = A.shape[0]
    k = max(1, n // 100)
    if n - k < 8:
        return OrderEvidence(order_est, None, "none", nan, nan, nan, 0, "too few pairs")

    def increments(R: FloatArray) -> FloatArray:
        return np.asarray(so3.log(np.einsum("nji,njk->nik", R[:-k], R[k:])))

    a = increments(A)
    keep = np.linalg.norm(a, axis=-1) > math.radians(2.0)
    if np.count_nonzero(keep) < 8:
        return OrderEvidence(
            order_est, None, "none", nan, nan, nan, 0, "REF turns too little to judge by"
        )
    a = a[keep]
    r_read = _wahba_residual(a, increments(E)[keep])
    r_other = _wahba_residual(a, increments(other_reading(E, order_est))[keep])
    pairs = int(a.shape[0])
    reason = (
        f"REF's body-frame rotation increments fit EST's with residual {r_read:.3f} read as "
        f"{order_est} and {r_other:.3f} as {other} ({pairs} pairs)"
    )
    if max(r_read, r_other) < 0.05:
        return OrderEvidence(order_est, None, "none", nan, r_read, r_other, pairs, reason)
    ratio = (r_other + 0.01) / (r_read + 0.01)
    if ratio >= 3.0 or ratio <= 1.0 / 3.0:
        likely = order_est if ratio > 1 else other
        conf = "strong" if max(ratio, 1.0 / ratio) >= 10.0 else "moderate"
    else:
        likely, conf = None, "none"
    return OrderEvidence(order_est, likely, conf, float(ratio), r_read, r_other, pairs, reason)


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
    positions: Any = None,
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
    positions : array_like, shape (N, 3), optional
        ``t_world_body`` of the same rows: enables :func:`quaternion_order_evidence`, which
        decides the order finding when it can (the sign pattern is then not used).
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
        # only one slot near 0 there (planar motion keeps two vector slots at 0 throughout)
        if slot != s and near0[slot] < 0.5 * np.sort(near0)[1]:
            suggested = _ORDER_WITH_SCALAR_AT.get(slot)
    neg = (u < 0).any(axis=0)
    # only where the file shows sign flips, i.e. a w ≥ 0 writer, not a hemisphere-continuous one
    # (whose scalar takes both signs over a turn beyond 180°, liebridge's writers included)
    if n >= 10 and flips.size and neg[s] and not neg.all():
        never = [k for k in range(4) if not neg[k] and k != s]
        # a w ≥ 0 writer's scalar is the large one; a component that merely stays on one side
        # (a small fixed tilt during a turn, written with hemisphere continuity) is not it
        if (
            len(never) == 1
            and never[0] in _ORDER_WITH_SCALAR_AT
            and np.abs(u[:, never[0]]).mean() > np.abs(u[:, s]).mean()
        ):
            suggested = _ORDER_WITH_SCALAR_AT[never[0]]
    evidence = None
    if positions is not None:
        with np.errstate(all="ignore"):  # 1e300 positions: no evidence, never a numpy warning
            evidence = quaternion_order_evidence(u, order, positions)
    confidence = "none"
    if evidence is not None and evidence.confidence != "none":
        confidence = evidence.confidence
        suggested = evidence.likely_order if evidence.likely_order != order else None
        if suggested is not None:
            msgs.append(
                f"the order is likely {suggested!r}, not {order!r} ({confidence} evidence: "
                f"{evidence.reason})"
            )
    elif (
        suggested is not None
        and suggested != order
        and (evidence is None or not math.isfinite(evidence.ratio))
    ):
        # the sign pattern only where the translation could not be measured: where it was and
        # left the question open, the sign pattern of real writers (Eigen's from-matrix branch
        # choice, as ORB-SLAM's output shows) is no better than a guess
        confidence = "weak"
        if flips.size:
            msgs.append(flip_msg)
        why = "no positions given" if evidence is None else evidence.reason
        msgs.append(
            f"the scalar read as w (slot {s}) takes both signs where slot "
            f"{_SCALAR_SLOT[suggested]} behaves like the scalar of a w ≥ 0 writer: the order "
            f"is likely {suggested!r}, not {order!r} (weak evidence, the sign pattern only: {why})"
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
        order_confidence=confidence,
        order_evidence=evidence,
    )
    if warn and msgs:
        warnings.warn(
            f"{source} (read as {order}): " + "; ".join(msgs),
            QuaternionOrderWarning,
            stacklevel=2,
        )
    return report
