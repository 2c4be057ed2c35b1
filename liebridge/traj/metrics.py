"""APE and RPE with evo's definitions, batched; KITTI's per-segment odometry errors.

Poses are ``T_world_body`` ``(N, 4, 4)``, associated (same length, pose ``i`` of both at the same
time) and, if wanted, aligned (:mod:`liebridge.traj.align`).

APE (evo ``metrics.APE``, evo 1.38 ``evo/core/metrics.py``)
    Error pose ``E_i = T_est,i⁻¹ · T_ref,i``; ``"trans_part"`` (the default) is
    ``‖p_est,i − p_ref,i‖`` (evo computes it on the positions, so it is not ``‖t(E_i)‖``).
RPE (evo ``metrics.RPE``)
    For index pairs ``(i, j)``: ``E = (Q_i⁻¹ Q_j)⁻¹ · (P_i⁻¹ P_j)`` with ``Q`` the reference and
    ``P`` the estimate; ``"trans_part"`` is ``‖t(E)‖``. Pairs: with ``unit="frames"``
    ``(0, Δ), (Δ, 2Δ), …`` (non-overlapping, evo's default) or all ``(i, i + Δ)`` with
    ``all_pairs``; with ``unit="m"`` the path length of the **estimate** decides (evo's
    ``filter_pairs_by_path``): consecutive pairs restart when the accumulated length reaches
    ``Δ``; all pairs take, from every ``i``, the ``j`` whose path length from ``i`` is nearest to
    ``Δ``, kept if within ``0.1 Δ``.

Pose relations (evo's ``-r`` names): ``"trans_part"`` (m), ``"rot_part"`` ``‖R(E) − I‖_F``
(dimensionless), ``"full"`` ``‖E − I‖_F``, ``"angle_rad"``/``"angle_deg"`` ``|Log(R(E))|``,
``"point_distance"`` (RPE: ``|‖Δp_ref‖ − ‖Δp_est‖|``; APE: as ``"trans_part"``).

Statistics (:class:`Statistics`): rmse, mean, median, **population** std (``ddof = 0``, as evo's
``np.std``), min, max, sse.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from .. import _validate as validate
from .._validate import FloatArray
from ..lie import unchecked as lu

__all__ = [
    "KITTI_LENGTHS",
    "POSE_RELATIONS",
    "KittiSegments",
    "PoseRelation",
    "Statistics",
    "ape",
    "kitti_segment_errors",
    "rpe",
    "rpe_pairs",
    "statistics",
]

PoseRelation = Literal["trans_part", "rot_part", "full", "angle_rad", "angle_deg", "point_distance"]
#: Accepted pose relations (evo's ``--pose_relation`` names).
POSE_RELATIONS: tuple[str, ...] = (
    "trans_part",
    "rot_part",
    "full",
    "angle_rad",
    "angle_deg",
    "point_distance",
)
#: The KITTI odometry benchmark's segment lengths, metres (devkit ``evaluate_odometry.cpp``).
KITTI_LENGTHS: tuple[float, ...] = (100.0, 200.0, 300.0, 400.0, 500.0, 600.0, 700.0, 800.0)

IntArray = npt.NDArray[np.intp]


@dataclass(frozen=True)
class Statistics:
    """Summary of an error array (evo's ``get_all_statistics``; ``std`` with ``ddof = 0``)."""

    rmse: float
    mean: float
    median: float
    std: float
    min: float
    max: float
    sse: float
    n: int

    def as_dict(self) -> dict[str, float]:
        """Return the fields as a plain ``dict`` (JSON-ready)."""
        return {k: (int(x) if k == "n" else float(x)) for k, x in asdict(self).items()}


def statistics(errors: Any) -> Statistics:
    """Statistics of a non-empty 1-D error array.

    Errors too large to square in float64 (above ≈ 1e154) are summed after an exact power-of-two
    rescaling, so ``rmse``, ``mean`` and ``std`` stay finite for every finite input.

    Raises
    ------
    ValueError
        An empty or non-1-D array, NaN/Inf (naming the index), or a sum of squares ``sse`` that
        is itself beyond float64 (naming the largest error).
    """
    e = validate.as_float_array(errors, "errors")
    if e.ndim != 1 or e.size == 0:
        raise ValueError(f"errors: expected a non-empty shape (N,), got {e.shape}")
    validate.check_finite(e, "errors", core_ndim=0)
    big = float(np.max(np.abs(e)))
    if big < _SQUARE_SAFE:
        sq = e * e
        rmse, mean, std = float(np.sqrt(np.mean(sq))), float(np.mean(e)), float(np.std(e))
        sse = float(np.sum(sq))
    else:  # exact rescaling by a power of two: the squares and the sums stay in range
        scale = math.ldexp(1.0, math.frexp(big)[1] - 1)  # |e| / scale < 2
        u = e / scale
        usq = u * u
        rmse = scale * float(np.sqrt(np.mean(usq)))
        mean, std = scale * float(np.mean(u)), scale * float(np.std(u))
        sse = scale * scale * float(np.sum(usq))  # Python floats: inf on overflow, no warning
        if not math.isfinite(sse):
            raise ValueError(
                f"errors: the sum of squares (sse) overflows float64 (largest error {big:.3g}); "
                "express the errors in a larger unit"
            )
    return Statistics(
        rmse=rmse,
        mean=mean,
        median=float(np.median(e)),
        std=std,
        min=float(np.min(e)),
        max=float(np.max(e)),
        sse=sse,
        n=int(e.size),
    )


#: Below this magnitude a float64 can be squared and summed (10⁸ terms) without overflow.
_SQUARE_SAFE = 1e145


def _norm(x: FloatArray, axis: int | tuple[int, int] = -1) -> FloatArray:
    """Euclidean (Frobenius) norm over ``axis`` that does not overflow for finite entries.

    The plain ``np.linalg.norm`` squares the entries (inf above ≈ 1e154); rows holding such
    entries are rescaled by an exact power of two first. A norm beyond float64 itself (entries
    near 1e308) stays inf and is reported by the caller.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        out = np.asarray(np.linalg.norm(x, axis=axis), dtype=np.float64)
        bad = ~np.isfinite(out)
        if bad.any():
            big = np.max(np.abs(x), axis=axis)
            scale = np.ldexp(1.0, np.frexp(np.where(big > 0, big, 1.0))[1] - 1)
            shape = out.shape + (1,) * (x.ndim - out.ndim)
            scaled = np.linalg.norm(x / scale.reshape(shape), axis=axis) * scale
            out = np.where(bad, scaled, out)
    return out


def _path_length(T: FloatArray, name: str) -> tuple[FloatArray, FloatArray]:
    """Return the steps (N − 1,) and the path length (N,); a ValueError if it overflows."""
    with np.errstate(over="ignore", invalid="ignore"):
        steps = _norm(np.diff(T[:, :3, 3], axis=0))
        dist = np.concatenate([[0.0], np.cumsum(steps)])
    if not np.isfinite(dist).all():
        i = int(np.argmax(~np.isfinite(dist)))
        raise ValueError(
            f"{name}: the path length up to pose {i} overflows float64 (steps of up to "
            f"{float(np.max(np.abs(T[:, :3, 3]))):.3g} m); express the positions in a larger "
            "unit"
        )
    return np.asarray(steps, dtype=np.float64), np.asarray(dist, dtype=np.float64)


def _finite_errors(err: FloatArray, what: str) -> FloatArray:
    """``err`` if finite; else a ValueError naming the first pose (or pair) and why."""
    if np.isfinite(err).all():
        return err
    i = int(np.argmax(~np.isfinite(err)))
    raise ValueError(
        f"{what}: the error at index {i} overflows float64 (the poses' translations differ by "
        "more than ≈ 1e308); the result cannot be represented"
    )


def _pair(T_ref: Any, T_est: Any) -> tuple[FloatArray, FloatArray]:
    Tr = validate.pose(T_ref, "T_ref")
    Te = validate.pose(T_est, "T_est")
    if Tr.ndim != 3 or Tr.shape != Te.shape:
        raise ValueError(
            f"T_ref, T_est: expected two (N, 4, 4) arrays of associated poses, got {Tr.shape} "
            f"and {Te.shape}"
        )
    if Tr.shape[0] == 0:
        raise ValueError("T_ref, T_est: no poses")
    return Tr, Te


def _check_relation(pose_relation: str) -> None:
    if pose_relation not in POSE_RELATIONS:
        raise ValueError(
            f"pose_relation: expected one of {', '.join(POSE_RELATIONS)}, got {pose_relation!r}"
        )


def _relation_error(E: FloatArray, pose_relation: str) -> FloatArray:
    """Error of stacked error poses ``E`` ``(K, 4, 4)`` under a pose relation."""
    if pose_relation == "trans_part":
        return _norm(E[:, :3, 3])
    if pose_relation == "rot_part":
        return np.asarray(np.linalg.norm(E[:, :3, :3] - np.eye(3), axis=(-2, -1)), np.float64)
    if pose_relation == "full":
        return _norm(E - np.eye(4), axis=(-2, -1))
    angle = np.linalg.norm(lu.so3_log(np.ascontiguousarray(E[:, :3, :3])), axis=-1)
    return np.asarray(np.degrees(angle) if pose_relation == "angle_deg" else angle, np.float64)


def ape(T_ref: Any, T_est: Any, pose_relation: PoseRelation | str = "trans_part") -> FloatArray:
    """Absolute pose error per pose, shape (N,) (evo's APE; see the module docstring)."""
    _check_relation(pose_relation)
    Tr, Te = _pair(T_ref, T_est)
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported by name
        if pose_relation in ("trans_part", "point_distance"):
            return _finite_errors(_norm(Te[:, :3, 3] - Tr[:, :3, 3]), "ape")
        return _finite_errors(_relation_error(lu.se3_inverse(Te) @ Tr, pose_relation), "ape")


def rpe_pairs(
    T: Any,
    delta: float = 1,
    unit: Literal["frames", "m"] | str = "frames",
    *,
    all_pairs: bool = False,
    rel_tol: float = 0.1,
) -> IntArray:
    """Index pairs ``(i, j)`` of the RPE, shape (K, 2), chosen on the poses ``T`` as evo does.

    Raises
    ------
    ValueError
        For ``delta`` not positive (not an integer for frames), an unknown unit, or no pair.
    """
    Tp = validate.pose(T, "T")
    n = Tp.shape[0]
    if unit == "frames":
        if not (float(delta).is_integer() and delta >= 1):
            raise ValueError(f"delta: expected an integer ≥ 1 for unit 'frames', got {delta!r}")
        d = int(delta)
        if all_pairs:
            i = np.arange(max(n - d, 0))
            pairs = np.stack([i, i + d], axis=-1)
        else:
            ids = np.arange(0, n, d)
            pairs = np.stack([ids[:-1], ids[1:]], axis=-1)
    elif unit == "m":
        if not (np.isfinite(delta) and delta > 0):
            raise ValueError(f"delta: expected a length > 0 in metres, got {delta!r}")
        steps, dist = _path_length(Tp, "T")
        if all_pairs:
            pairs = _path_all_pairs(dist, float(delta), float(delta) * rel_tol)
        else:
            pairs = _path_consecutive(steps, float(delta))
    else:
        raise ValueError(f"unit: expected 'frames' or 'm', got {unit!r}")
    pairs = np.asarray(pairs, dtype=np.intp).reshape(-1, 2)
    if pairs.shape[0] == 0:
        raise ValueError(
            f"delta = {delta} ({unit}) gives no pose pair among {n} poses; use a smaller delta"
        )
    return pairs


def _path_consecutive(steps: FloatArray, delta: float) -> IntArray:
    """Pair as evo's ``filter_pairs_by_path`` without ``all_pairs``: the sum restarts at each pair.

    The running sum from the current start pose is a ``cumsum`` over a window (doubled until
    it reaches ``delta``): the same additions in the same order as evo's loop, so the same
    comparisons; Python iterates over the pairs only.
    """
    ids = [0]
    start, n, w = 0, steps.size, 64
    while start < n:
        run = np.cumsum(steps[start : start + w])
        k = int(np.searchsorted(run, delta, side="left"))  # first k with run[k] >= delta
        if k >= run.size:
            if start + w >= n:
                break
            w *= 2
            continue
        start += k + 1
        ids.append(start)
    idx = np.asarray(ids, dtype=np.intp)
    return np.stack([idx[:-1], idx[1:]], axis=-1)


def _path_all_pairs(dist: FloatArray, delta: float, tol: float) -> IntArray:
    """Pair as evo's ``filter_pairs_by_path`` with ``all_pairs`` (nearest length to delta)."""
    n = dist.size
    i = np.arange(n - 1)
    target = dist[i] + delta
    # the nearest among j > i: the two neighbours of the insertion point (ties: the first, as
    # np.argmin in evo)
    j_hi = np.clip(np.searchsorted(dist, target, side="left"), 1, n - 1)
    j_hi = np.maximum(j_hi, i + 1)
    j_lo = np.maximum(j_hi - 1, i + 1)
    # standing still repeats a path length: argmin takes the first index holding it
    j_lo = np.maximum(np.searchsorted(dist, dist[j_lo], side="left"), i + 1)
    e_lo = np.abs(dist[j_lo] - dist[i] - delta)
    e_hi = np.abs(dist[j_hi] - dist[i] - delta)
    j = np.where(e_lo <= e_hi, j_lo, j_hi)
    err = np.minimum(e_lo, e_hi)
    keep = err <= tol
    return np.stack([i[keep], j[keep]], axis=-1)


def rpe(
    T_ref: Any,
    T_est: Any,
    delta: float = 1,
    unit: Literal["frames", "m"] | str = "frames",
    pose_relation: PoseRelation | str = "trans_part",
    *,
    all_pairs: bool = False,
    rel_tol: float = 0.1,
) -> tuple[FloatArray, IntArray]:
    """Relative pose error (evo's RPE; pairs chosen on the estimate, see the module docstring).

    Returns
    -------
    errors : ndarray, shape (K,)
    pairs : ndarray of int, shape (K, 2)
    """
    _check_relation(pose_relation)
    Q, P = _pair(T_ref, T_est)
    pairs = rpe_pairs(P, delta, unit, all_pairs=all_pairs, rel_tol=rel_tol)
    i, j = pairs[:, 0], pairs[:, 1]
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported by name
        if pose_relation == "point_distance":
            dr = _norm(Q[j, :3, 3] - Q[i, :3, 3])
            de = _norm(P[j, :3, 3] - P[i, :3, 3])
            return _finite_errors(np.asarray(np.abs(dr - de), dtype=np.float64), "rpe"), pairs
        Q_rel = lu.se3_inverse(Q[i]) @ Q[j]
        P_rel = lu.se3_inverse(P[i]) @ P[j]
        err = _relation_error(lu.se3_inverse(Q_rel) @ P_rel, pose_relation)
    return _finite_errors(err, "rpe"), pairs


@dataclass(frozen=True)
class KittiSegments:
    """KITTI odometry errors per segment length.

    Attributes
    ----------
    lengths : ndarray, shape (L,)
        Segment lengths (m) that have at least one segment.
    translation_percent : ndarray, shape (L,)
        Mean ``‖t(E)‖ / length · 100`` over the segments of each length.
    rotation_deg_per_m : ndarray, shape (L,)
        Mean ``angle(E) / length`` in degrees per metre.
    count : ndarray of int, shape (L,)
    translation_percent_mean, rotation_deg_per_m_mean : float
        Means over **all** segments (the devkit's sequence figure).
    """

    lengths: FloatArray
    translation_percent: FloatArray
    rotation_deg_per_m: FloatArray
    count: IntArray
    translation_percent_mean: float
    rotation_deg_per_m_mean: float


def kitti_segment_errors(
    T_ref: Any, T_est: Any, lengths: Any = KITTI_LENGTHS, step: int = 10
) -> KittiSegments:
    """Per-segment relative errors as the KITTI odometry devkit defines them.

    From every ``step``-th frame ``f`` and for each length ``L``, the segment ends at the first
    frame ``l`` whose **reference** path length exceeds ``dist[f] + L``; segments that run past
    the end are skipped. ``E = (P_f⁻¹ P_l)⁻¹ (Q_f⁻¹ Q_l)``; the translation error is ``‖t(E)‖/L``
    and the rotation error ``acos(clip((tr R(E) − 1)/2, −1, 1))/L`` (devkit
    ``evaluate_odometry.cpp`` of ``devkit_odometry.zip``: ``calcSequenceErrors``, ``rotationError``,
    ``translationError``; tested against a loop-for-loop transcription).
    The devkit keeps path lengths in single precision; this uses double.

    Raises
    ------
    ValueError
        When no segment of any length fits in the trajectory.
    """
    Q, P = _pair(T_ref, T_est)
    Ls = validate.as_float_array(lengths, "lengths").reshape(-1)
    if Ls.size == 0 or not (np.isfinite(Ls).all() and (Ls > 0).all()):
        raise ValueError(f"lengths: expected positive segment lengths, got {Ls.tolist()}")
    if isinstance(step, bool) or not isinstance(step, int | np.integer) or step < 1:
        raise ValueError(f"step: expected an integer ≥ 1, got {step!r}")
    _, dist = _path_length(Q, "T_ref")
    first = np.arange(0, Q.shape[0], step)
    f = np.repeat(first, Ls.size)
    L = np.tile(Ls, first.size)
    last = np.searchsorted(dist, dist[f] + L, side="right")  # first index with dist > target
    ok = last < Q.shape[0]
    f, L, last = f[ok], L[ok], last[ok]
    if f.size == 0:
        raise ValueError(
            f"no KITTI segment fits: the reference path is {dist[-1]:.6g} m long, the shortest "
            f"segment length is {Ls.min():g} m"
        )
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported by name
        dQ = lu.se3_inverse(Q[f]) @ Q[last]
        dP = lu.se3_inverse(P[f]) @ P[last]
        E = lu.se3_inverse(dP) @ dQ
        t_err = _finite_errors(_norm(E[:, :3, 3]) / L, "kitti_segment_errors")
    cos = np.clip(0.5 * (np.trace(E[:, :3, :3], axis1=-2, axis2=-1) - 1.0), -1.0, 1.0)
    r_err = np.arccos(cos) / L
    used = np.unique(L)
    which = np.searchsorted(used, L)
    cnt = np.bincount(which, minlength=used.size)
    t_mean = np.bincount(which, weights=t_err, minlength=used.size) / cnt
    r_mean = np.bincount(which, weights=r_err, minlength=used.size) / cnt
    return KittiSegments(
        lengths=used,
        translation_percent=100.0 * t_mean,
        rotation_deg_per_m=np.degrees(r_mean),
        count=cnt.astype(np.intp),
        translation_percent_mean=float(100.0 * t_err.mean()),
        rotation_deg_per_m_mean=float(np.degrees(r_err.mean())),
    )
