"""Residuals and Jacobians of point-cloud registration, in any convention's tangent of ``T``.

``T = T_target_source`` maps a source point into the target frame; a correspondence is a source
point ``p`` and a target point ``q`` (with the target normal ``n`` or the point covariances
``C_src``, ``C_tgt``). With ``s = T·p``:

* point-to-point: ``r = s − q`` (3-vector);
* point-to-plane: ``r = nᵀ(s − q)`` (scalar);
* GICP: ``r = s − q`` with information ``M = (C_tgt + R·C_src·Rᵀ)⁻¹``.

The Jacobian ``∂r/∂d`` is over the named convention's tangent ``d`` of ``T``: ``r`` evaluated at
``convention.retract(T, d)``. Written once, in the left, rotation-first SE(3) tangent (preset
``open3d``: ``Exp(δ)·T``, ``δ = (ω, v)``), where ``∂s/∂δ = [−[s]ₓ | I]``; any other convention is
that times ``M = tangent_map(T, convention, "open3d")`` (``δ = M·d`` to first order), a 6×6
product. In particular (design note, rows over ``(ω, v)``):

* left (``open3d``, ``g2o_expmap``): point-to-plane ``J = nᵀ[−[T·p]ₓ | I] = [(T·p)×n, n]``;
* right (``gtsam``, ``small_gicp``): ``J = nᵀR[−[p]ₓ | I] = [p×(Rᵀn), Rᵀn]``.

False (and the most common error): using one of these in code whose retraction is the other —
the two agree only at ``T = I``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions import Convention, ConventionLike, get
from ..conventions import unchecked as CU
from ..conventions.registration_presets import OPEN3D

__all__ = ["gicp", "point_to_plane", "point_to_point"]

#: Tolerance on ``‖n‖ − 1`` for the target normals.
NORMAL_TOL = 1e-6


def _points(x: Any, name: str) -> FloatArray:
    arr = validate.as_float_array(x, name)
    if arr.ndim < 2 or arr.shape[-1] != 3:
        raise ValueError(f"{name}: expected points of shape (..., N, 3), got {arr.shape}")
    if not np.isfinite(arr).all():
        idx = validate.batch_index(~np.isfinite(arr))
        raise ValueError(
            f"{name}: NaN or Inf at point index {idx[:-1]} of {arr.shape[-2]} (coordinate "
            f"{idx[-1]}); drop invalid points before registering"
        )
    return arr


def _same_count(a: FloatArray, b: FloatArray, name_a: str, name_b: str) -> None:
    if a.shape[-2] != b.shape[-2]:
        raise ValueError(
            f"{name_b}: {b.shape[-2]} points, but {name_a} has {a.shape[-2]}: correspondences "
            "come in pairs (row i of each is one pair)"
        )


def _normals(x: Any, q: FloatArray) -> FloatArray:
    n = _points(x, "n_tgt")
    _same_count(q, n, "q_tgt", "n_tgt")
    err = np.abs(np.einsum("...i,...i->...", n, n) - 1.0)
    if (err > 2 * NORMAL_TOL).any():
        i = validate.batch_index(err > 2 * NORMAL_TOL)
        norm = float(np.linalg.norm(n[i]))
        raise ValueError(
            f"n_tgt: normal at index {i} has norm {norm:.6g}, not 1 (tolerance {NORMAL_TOL:g}); "
            f"{int((err > 2 * NORMAL_TOL).sum())} of {err.size} normals are not unit: normalise"
        )
    return n


def _point_covs(x: Any, name: str, p: FloatArray) -> FloatArray:
    C = validate.covariance(x, name, 3)
    if C.ndim < 3 or C.shape[-3] != p.shape[-2]:
        got = C.shape[-3] if C.ndim >= 3 else 1
        raise ValueError(
            f"{name}: {got} covariances for {p.shape[-2]} points (expected shape "
            f"(..., {p.shape[-2]}, 3, 3))"
        )
    return C


def _transformed(T: FloatArray, p: FloatArray) -> FloatArray:
    """``s = R·p + t`` for ``T`` ``(..., 4, 4)`` and ``p`` ``(..., N, 3)``."""
    R = T[..., None, :3, :3] if T.ndim > 2 else T[:3, :3]
    t = T[..., None, :3, 3]
    if T.ndim == 2:
        return p @ R.T + t
    return np.einsum("...ij,...j->...i", R, p) + t


def _to_convention(T: FloatArray, conv: Convention) -> FloatArray | None:
    """``M`` with ``δ_open3d = M·d_conv`` at ``T`` (``None`` where it is the identity)."""
    if conv.fields == OPEN3D.fields:
        return None
    return CU.tangent_map(T, conv, OPEN3D)


def _setup(
    T: Any, p_src: Any, q_tgt: Any, convention: ConventionLike
) -> tuple[FloatArray, FloatArray, FloatArray, Convention]:
    conv = get(convention)
    if conv.group != "se3":
        raise ValueError(
            f"convention: registration estimates an SE(3) pose; {conv.name!r} is a "
            f"{conv.group} convention"
        )
    Tm = validate.pose(T, "T")
    p = _points(p_src, "p_src")
    q = _points(q_tgt, "q_tgt")
    _same_count(p, q, "p_src", "q_tgt")
    validate.batch_shape(("T", Tm.shape[:-2]), ("p_src", p.shape[:-2]), ("q_tgt", q.shape[:-2]))
    return Tm, p, q, conv


def _point_jacobian(T: FloatArray, s: FloatArray, conv: Convention) -> FloatArray:
    """``∂(T·p)/∂d`` ``(..., N, 3, 6)`` from the left form ``[−[s]ₓ | I]``."""
    J = np.zeros((*s.shape, 6))
    x, y, z = s[..., 0], s[..., 1], s[..., 2]
    J[..., 0, 1], J[..., 0, 2] = z, -y
    J[..., 1, 0], J[..., 1, 2] = -z, x
    J[..., 2, 0], J[..., 2, 1] = y, -x
    J[..., 0, 3] = J[..., 1, 4] = J[..., 2, 5] = 1.0
    M = _to_convention(T, conv)
    if M is None:
        return J
    if M.ndim == 2:
        return (J.reshape(-1, 6) @ M).reshape(J.shape)
    return np.asarray(J @ M[..., None, :, :], dtype=np.float64)


def point_to_point(
    T: Any, p_src: Any, q_tgt: Any, convention: ConventionLike = "gtsam"
) -> tuple[FloatArray, FloatArray]:
    """Point-to-point residuals ``r = T·p − q`` and their Jacobians in ``convention``'s tangent.

    Parameters
    ----------
    T : array_like, shape (..., 4, 4)
        ``T_target_source`` (rigid; checked).
    p_src, q_tgt : array_like, shape (..., N, 3)
        Corresponding source and target points (row ``i`` of each is one pair).
    convention : Convention or str
        Whose tangent ``d`` of ``T`` the Jacobian is over (``T' = convention.retract(T, d)``),
        in its order: ``"gtsam"``/``"small_gicp"`` ``(ω, v)`` right, ``"open3d"`` ``(ω, v)``
        left, ``"kiss_icp"`` ``(v, ω)`` left, any preset of SE(3) including the decoupled charts.

    Returns
    -------
    r : ndarray, shape (..., N, 3)
    J : ndarray, shape (..., N, 3, 6)
        ``∂r/∂d`` at ``d = 0``. Left (``open3d``): ``[−[T·p]ₓ | I]``; right (``gtsam``):
        ``R·[−[p]ₓ | I]``. False: the one for the other side (they agree only at ``T = I``).

    Raises
    ------
    ValueError
        Mismatched point counts, NaN points (naming the index), a non-rigid ``T``.
    """
    Tm, p, q, conv = _setup(T, p_src, q_tgt, convention)
    s = _transformed(Tm, p)
    return s - q, _point_jacobian(Tm, s, conv)


def point_to_plane(
    T: Any, p_src: Any, q_tgt: Any, n_tgt: Any, convention: ConventionLike = "gtsam"
) -> tuple[FloatArray, FloatArray]:
    """Point-to-plane residuals ``r = nᵀ(T·p − q)`` and their Jacobians in ``convention``.

    Parameters
    ----------
    T : array_like, shape (..., 4, 4)
        ``T_target_source`` (rigid; checked).
    p_src, q_tgt : array_like, shape (..., N, 3)
        Corresponding source and target points.
    n_tgt : array_like, shape (..., N, 3)
        Unit normals at the target points, in the target frame (norm checked to 1e-6).
    convention : Convention or str
        Whose tangent of ``T`` the Jacobian is over (see :func:`point_to_point`).

    Returns
    -------
    r : ndarray, shape (..., N)
    J : ndarray, shape (..., N, 6)
        Left (``open3d``, ``(ω, v)``): ``[(T·p)×n, n]``; right (``gtsam``):
        ``[p×(Rᵀn), Rᵀn]``; the rows in ``convention``'s order. False: small_gicp's
        ``PLANE_ICP`` error ``n∘(q − T·p)`` (a 3-vector, component-wise) is a different residual.
    """
    Tm, p, q, conv = _setup(T, p_src, q_tgt, convention)
    n = _normals(n_tgt, q)
    s = _transformed(Tm, p)
    r = np.einsum("...i,...i->...", n, s - q)
    J = np.concatenate([np.cross(s, n), np.broadcast_to(n, s.shape)], axis=-1)
    M = _to_convention(Tm, conv)
    if M is not None:
        J = np.asarray(J @ M, dtype=np.float64)  # (..., N, 6) @ (..., 6, 6)
    return r, J


def gicp(
    T: Any,
    p_src: Any,
    q_tgt: Any,
    C_src: Any,
    C_tgt: Any,
    convention: ConventionLike = "gtsam",
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """GICP residuals ``r = T·p − q``, Jacobians and per-correspondence information.

    Parameters
    ----------
    T : array_like, shape (..., 4, 4)
        ``T_target_source``.
    p_src, q_tgt : array_like, shape (..., N, 3)
    C_src, C_tgt : array_like, shape (..., N, 3, 3)
        Point covariances in the source and target frames (symmetric PSD; checked).
    convention : Convention or str

    Returns
    -------
    r : ndarray, shape (..., N, 3)
    J : ndarray, shape (..., N, 3, 6)
        As :func:`point_to_point`.
    info : ndarray, shape (..., N, 3, 3)
        ``(C_tgt + R·C_src·Rᵀ)⁻¹``: the information of ``r`` when the point covariances are in
        m² (small_gicp's ``estimate_covariances`` normalises them: then it has no scale).

    Raises
    ------
    ValueError
        As :func:`point_to_point`, and a singular combined covariance (naming the index).
    """
    Tm, p, q, conv = _setup(T, p_src, q_tgt, convention)
    Cs = _point_covs(C_src, "C_src", p)
    Ct = _point_covs(C_tgt, "C_tgt", q)
    s = _transformed(Tm, p)
    R = Tm[..., None, :3, :3]
    C = Ct + R @ Cs @ np.swapaxes(R, -1, -2)
    C = 0.5 * (C + np.swapaxes(C, -1, -2))
    lam = np.linalg.eigvalsh(C)
    bad = lam[..., 0] <= 1e-12 * np.maximum(lam[..., -1], 1e-300)
    if bad.any():
        i = validate.batch_index(bad)
        raise ValueError(
            f"C_src, C_tgt: C_tgt + R·C_src·Rᵀ is singular at correspondence {i} (eigenvalues "
            f"{np.array2string(lam[i], precision=3)}); {int(bad.sum())} of {bad.size} are"
        )
    inv = np.linalg.inv(C)
    W: FloatArray = np.asarray(0.5 * (inv + np.swapaxes(inv, -1, -2)), dtype=np.float64)
    return s - q, _point_jacobian(Tm, s, conv), W
