"""Poses (and their covariances) at query times, between timestamped poses.

Two named methods, both exact at the samples and both along the short way:

* ``"geodesic"`` — the SE(3) geodesic ``T(τ) = T₀·Exp(τ·Log(T₀⁻¹ T₁))`` (a screw motion:
  rotation and translation coupled), :func:`liebridge.lie.se3.interpolate`;
* ``"lerp_slerp"`` — translation linear, rotation by SLERP, ``R(τ) = R₀·Exp(τ·Log(R₀ᵀ R₁))``
  (what evo's ``PoseTrajectory3D.interpolate`` and most VIO tools do). The two differ whenever
  the rotation turns: ``"geodesic"`` moves along a helix, ``"lerp_slerp"`` along the chord.

with ``τ = (t − t₀)/(t₁ − t₀)`` on the bracketing samples.

Covariances (:func:`interpolate_covariances`) are carried *consistently*: each endpoint's
covariance is moved rigidly to the interpolated pose (in GTSAM's right, body-frame tangent a
perturbation of ``T₀`` seen at ``T(τ) = T₀ D`` is ``Ad(D⁻¹) ξ``), blended linearly
``Σ(τ) = (1 − τ) Σ₀' + τ Σ₁'`` and expressed back in the caller's convention. It returns ``Σ₀``
and ``Σ₁`` at the samples, stays symmetric positive semi-definite and does not depend on the
convention the covariances were given in. It is a model (errors of neighbouring samples taken as
fully correlated in their common frame), not the exact covariance of an interpolated estimate,
which needs the cross-covariance of the samples. Tempting and false: interpolating the 6×6
matrices entry by entry in a left (world-frame) or mixed convention gives the same result — it
does not, because the frames of the two endpoints differ.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions import ConventionLike, get, pose_convention
from ..conventions import unchecked as cu
from ..lie import unchecked as lu
from .association import check_timestamps

__all__ = ["METHODS", "interpolate_covariances", "interpolate_poses"]

#: The interpolation methods, by name.
METHODS: tuple[str, ...] = ("geodesic", "lerp_slerp")
Method = Literal["geodesic", "lerp_slerp"]


def _bracket(
    t_query: Any, t: Any
) -> tuple[FloatArray, np.ndarray[Any, np.dtype[np.intp]], FloatArray]:
    tq = validate.as_float_array(t_query, "t_query")
    if tq.ndim != 1:
        raise ValueError(f"t_query: expected shape (M,), got {tq.shape}")
    validate.check_finite(tq, "t_query", core_ndim=0)
    ts = check_timestamps(t, "t")
    if ts.size < 2:
        raise ValueError(f"t: interpolation needs at least 2 poses, got {ts.size}")
    out = (tq < ts[0]) | (tq > ts[-1])
    if out.any():
        k = int(np.flatnonzero(out)[0])
        raise ValueError(
            f"t_query: query {k} ({float(tq[k])!r} s) is outside the samples' span "
            f"[{float(ts[0])!r}, {float(ts[-1])!r}] s ({int(out.sum())} such queries); "
            f"no extrapolation"
        )
    i = np.clip(np.searchsorted(ts, tq, side="right") - 1, 0, ts.size - 2)
    # halves first: stamps ±1e308 apart overflow a difference (exact otherwise: powers of two)
    tau = (0.5 * tq - 0.5 * ts[i]) / (0.5 * ts[i + 1] - 0.5 * ts[i])
    return tq, i, tau


def _interp(T0: FloatArray, T1: FloatArray, tau: FloatArray, method: str) -> FloatArray:
    if method == "geodesic":
        xi = lu.se3_log(lu.se3_inverse(T0) @ T1)
        return np.asarray(T0 @ lu.se3_exp(tau[:, None] * xi), dtype=np.float64)
    if method == "lerp_slerp":
        R0, R1 = T0[:, :3, :3], T1[:, :3, :3]
        w = lu.so3_log(np.swapaxes(R0, -1, -2) @ R1)
        R = R0 @ lu.so3_exp(tau[:, None] * w)
        p = T0[:, :3, 3] + tau[:, None] * (T1[:, :3, 3] - T0[:, :3, 3])
        return np.asarray(lu.se3_assemble(R, p), dtype=np.float64)
    raise ValueError(f"method: expected one of {', '.join(METHODS)}, got {method!r}")


def interpolate_poses(
    t_query: Any, t: Any, T: Any, method: Method | str = "geodesic"
) -> FloatArray:
    """Poses at ``t_query`` (inside the samples' span) from samples ``(t, T)``.

    Parameters
    ----------
    t_query : array_like, shape (M,)
    t : array_like, shape (N,)
        Strictly increasing, N ≥ 2.
    T : array_like, shape (N, 4, 4)
        ``T_world_body``.
    method : {"geodesic", "lerp_slerp"}

    Returns
    -------
    ndarray, shape (M, 4, 4)
    """
    if method not in METHODS:
        raise ValueError(f"method: expected one of {', '.join(METHODS)}, got {method!r}")
    _, i, tau = _bracket(t_query, t)
    Tp = validate.pose(T, "T")
    if Tp.ndim != 3 or Tp.shape[0] != np.asarray(t).shape[0]:
        raise ValueError(f"T: expected shape ({np.asarray(t).shape[0]}, 4, 4), got {Tp.shape}")
    return _interp(Tp[i], Tp[i + 1], tau, method)


def interpolate_covariances(
    t_query: Any,
    t: Any,
    T: Any,
    cov: Any,
    convention: ConventionLike,
    method: Method | str = "geodesic",
) -> tuple[FloatArray, FloatArray]:
    """Poses and covariances at ``t_query`` (see the module docstring for the model).

    Parameters
    ----------
    t_query, t, T, method
        As :func:`interpolate_poses`.
    cov : array_like, shape (N, 6, 6)
        Covariances in ``convention``'s tangent at the samples.
    convention : Convention or str

    Returns
    -------
    T_query : ndarray, shape (M, 4, 4)
    cov_query : ndarray, shape (M, 6, 6)
        In ``convention``'s tangent at ``T_query``.
    """
    conv = get(convention)
    pose_convention(conv, "convention", np.eye(4))
    Tq = interpolate_poses(t_query, t, T, method)
    _, i, tau = _bracket(t_query, t)
    Tp = validate.pose(T, "T")
    C = validate.covariance(cov, "cov", 6)
    if C.ndim != 3 or C.shape[0] != Tp.shape[0]:
        raise ValueError(
            f"cov: {C.shape[0] if C.ndim == 3 else C.shape} covariances for {Tp.shape[0]} poses"
        )
    Cg = _to_gtsam(conv, Tp, C)  # right, body-frame (ω, v)

    def moved(k: np.ndarray[Any, np.dtype[np.intp]]) -> FloatArray:
        A = lu.se3_adjoint(lu.se3_inverse(Tq) @ Tp[k])  # Ad(D⁻¹), D = T_k⁻¹ T(τ)
        return np.asarray(A @ Cg[k] @ np.swapaxes(A, -1, -2), dtype=np.float64)

    w = tau[:, None, None]
    Cq = (1.0 - w) * moved(i) + w * moved(i + 1)
    M = cu.from_canonical(conv, Tq)
    out = M @ Cq @ np.swapaxes(M, -1, -2)
    return Tq, np.asarray(0.5 * (out + np.swapaxes(out, -1, -2)), dtype=np.float64)


def _to_gtsam(conv: Any, T: FloatArray, C: FloatArray) -> FloatArray:
    M = cu.to_canonical(conv, T)
    return np.asarray(M @ C @ np.swapaxes(M, -1, -2), dtype=np.float64)
