"""Synchronised pose pairs (and the estimate's covariances), as evo's ``associate_trajectories``.

:func:`synchronize` associates the stamps (:func:`~liebridge.traj.association.associate`) and then
either keeps the nearest poses (``interpolate=None``, evo's default ``SyncMethod.nearest_time``)
or — evo's ``SyncMethod.interpolation`` — resamples the trajectory with **more** poses exactly at
the matched stamps of the other (shifted by the offset into its own time frame, and clamped to
its span as evo does), with ``"lerp_slerp"`` (evo's) or ``"geodesic"``
(:mod:`~liebridge.traj.interpolate`). When the estimate is resampled its covariances are
resampled with it (:func:`~liebridge.traj.interpolate.interpolate_covariances`, in the
estimator's convention).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions import ConventionLike, get, pose_convention
from .association import MAX_DIFF, associate, check_timestamps
from .interpolate import METHODS, interpolate_covariances, interpolate_poses

__all__ = ["Synchronized", "synchronize"]


@dataclass(frozen=True)
class Synchronized:
    """Associated poses, one pair per row.

    Attributes
    ----------
    t : ndarray, shape (K,)
        The reference's stamps of the pairs (seconds).
    T_ref, T_est : ndarray, shape (K, 4, 4)
    cov_est : ndarray, shape (K, 6, 6), or None
        In the estimator's convention at ``T_est``, if covariances were given.
    i_ref, i_est : ndarray of int, shape (K,)
        Indices of the associated samples (for a resampled trajectory: the nearest sample).
    resampled : str or None
        ``"ref"`` or ``"est"`` (which trajectory was interpolated), or None.
    """

    t: FloatArray
    T_ref: FloatArray
    T_est: FloatArray
    cov_est: FloatArray | None
    i_ref: npt.NDArray[np.intp]
    i_est: npt.NDArray[np.intp]
    resampled: str | None


def synchronize(
    t_ref: Any,
    T_ref: Any,
    t_est: Any,
    T_est: Any,
    *,
    max_diff: float = MAX_DIFF,
    offset: float = 0.0,
    interpolate: str | None = None,
    cov_est: Any = None,
    convention: ConventionLike | None = None,
) -> Synchronized:
    """Associate two trajectories (see the module docstring).

    Parameters
    ----------
    t_ref, t_est : array_like, shape (N,), (M,)
        Strictly increasing stamps, seconds.
    T_ref, T_est : array_like, shape (N, 4, 4), (M, 4, 4)
    max_diff, offset : float
        As :func:`~liebridge.traj.association.associate`.
    interpolate : {None, "lerp_slerp", "geodesic"}
    cov_est : array_like, shape (M, 6, 6), optional
        One covariance per pose of the estimate, in ``convention``.
    convention : Convention or str, optional
        Required with ``cov_est`` when the estimate is resampled.

    Raises
    ------
    ValueError
        Stamps, shapes or covariances that do not match (naming both lengths), no overlap.
    """
    if convention is not None:  # checked even when the covariances need no interpolation
        pose_convention(get(convention), "convention", np.eye(4))
    a = check_timestamps(t_ref, "t_ref")
    b = check_timestamps(t_est, "t_est")
    Tr = validate.pose(T_ref, "T_ref")
    Te = validate.pose(T_est, "T_est")
    if Tr.shape != (a.size, 4, 4):
        raise ValueError(f"T_ref: expected shape ({a.size}, 4, 4) to match t_ref, got {Tr.shape}")
    if Te.shape != (b.size, 4, 4):
        raise ValueError(f"T_est: expected shape ({b.size}, 4, 4) to match t_est, got {Te.shape}")
    C = None
    if cov_est is not None:
        C = validate.as_float_array(cov_est, "cov_est")
        if C.ndim != 3 or C.shape[1:] != (6, 6):
            raise ValueError(f"cov_est: expected shape (M, 6, 6), got {C.shape}")
        if C.shape[0] != b.size:
            raise ValueError(
                f"cov_est: {C.shape[0]} covariances for {b.size} poses of the estimate"
            )
    if interpolate is not None and interpolate not in METHODS:
        raise ValueError(
            f"interpolate: expected None or one of {', '.join(METHODS)}, got {interpolate!r}"
        )
    i_ref, i_est = associate(a, b, max_diff=max_diff, offset=offset)
    if interpolate is None:
        return Synchronized(
            a[i_ref], Tr[i_ref], Te[i_est], None if C is None else C[i_est], i_ref, i_est, None
        )
    if b.size > a.size:  # the estimate is longer: resample it at the reference's stamps
        if b.size < 2:  # pragma: no cover - b.size > a.size ≥ 1
            raise ValueError("t_est: interpolation needs at least 2 poses")
        tq = np.clip(a[i_ref] - offset, b[0], b[-1])
        if C is not None:
            if convention is None:
                raise ValueError("convention: needed to interpolate the estimate's covariances")
            Tq, Cq = interpolate_covariances(tq, b, Te, C, convention, interpolate)
        else:
            Tq, Cq = interpolate_poses(tq, b, Te, interpolate), None
        return Synchronized(a[i_ref], Tr[i_ref], Tq, Cq, i_ref, i_est, "est")
    if a.size < 2:
        raise ValueError("t_ref: interpolation needs at least 2 poses")
    tq = np.clip(b[i_est] + offset, a[0], a[-1])
    Tq = interpolate_poses(tq, a, Tr, interpolate)
    return Synchronized(tq, Tq, Te[i_est], None if C is None else C[i_est], i_ref, i_est, "ref")
