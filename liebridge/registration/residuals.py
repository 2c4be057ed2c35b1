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
product. In particular (rows over ``(ω, v)``; derivation in ``docs/registration.md``):

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
from ..conventions import Convention, ConventionLike, get, single_group
from ..conventions import unchecked as CU
from ..conventions.presets import GTSAM
from ..conventions.registration_presets import OPEN3D
from ..lie import se3

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


def _to_convention(T: FloatArray, conv: Convention, base: Convention = OPEN3D) -> FloatArray | None:
    """``M`` with ``δ_base = M·d_conv`` at ``T`` (``None`` where it is the identity)."""
    if conv.fields == base.fields:
        return None
    return CU.tangent_map(T, conv, base)


def _assemble(rot: FloatArray, trans: FloatArray, M: FloatArray | None) -> FloatArray:
    """``[rot | trans] @ M`` over the last axis (blocks ``(..., 3)`` in the base's ``(ω, v)``).

    A signed, scaled permutation ``M`` (each column one non-zero, up to rounding: an order swap,
    the factor 2 of half-angle coordinates) is written block by block into the result; a dense
    ``M`` goes through one BLAS product laid out as ``(M.T @ J.T).T`` (OpenBLAS is several times
    slower on the tall ``J @ M``); one ``M`` per batch element through ``matmul``.
    """
    if M is None:
        return np.concatenate([rot, trans], axis=-1)
    if M.ndim == 2:
        # entries at rounding level of the largest are the zeros of an exact permutation
        # (a map composed of rotations rounds its zero blocks to ~1e-16): dropped
        nz = np.abs(M) > 1e-12 * np.abs(M).max()
        if (nz.sum(axis=0) == 1).all():
            out = np.empty((*rot.shape[:-1], 6))
            rows = np.argmax(nz, axis=0)
            scale = M[rows, np.arange(6)]
            for lo in (0, 3):  # whole 3-blocks where they move as blocks (order swaps)
                r = rows[lo : lo + 3]
                if r[0] in (0, 3) and (np.diff(r) == 1).all():
                    src = rot if r[0] == 0 else trans
                    sc = scale[lo : lo + 3]
                    if (sc == 1.0).all():
                        out[..., lo : lo + 3] = src
                    else:
                        np.multiply(src, sc, out=out[..., lo : lo + 3])
                    continue
                for j in range(lo, lo + 3):
                    col = rot[..., rows[j]] if rows[j] < 3 else trans[..., rows[j] - 3]
                    np.multiply(col, scale[j], out=out[..., j])
            return out
        J = np.concatenate([rot, trans], axis=-1)
        flat = J.reshape(-1, 6)
        return np.ascontiguousarray((M.T @ flat.T).T).reshape(J.shape)
    return np.asarray(np.concatenate([rot, trans], axis=-1) @ M, dtype=np.float64)


def _setup(
    T: Any, p_src: Any, q_tgt: Any, convention: ConventionLike
) -> tuple[FloatArray, FloatArray, FloatArray, Convention]:
    conv = single_group(get(convention))
    if conv.record is not se3.GROUP:
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
    rot = np.zeros((*s.shape, 3))
    x, y, z = s[..., 0], s[..., 1], s[..., 2]
    rot[..., 0, 1], rot[..., 0, 2] = z, -y
    rot[..., 1, 0], rot[..., 1, 2] = -z, x
    rot[..., 2, 0], rot[..., 2, 1] = y, -x
    trans = np.broadcast_to(np.eye(3), rot.shape)
    M = _to_convention(T, conv)
    if M is not None and M.ndim > 2:
        M = M[..., None, :, :]
    return _assemble(rot, trans, M)


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
    if conv.side == "left":  # the left form [s×n, n] (rows over (ω, v)), then to conv
        return r, _assemble(np.cross(s, n), np.broadcast_to(n, s.shape), _to_convention(Tm, conv))
    # the right form [p×m, m], m = Rᵀn, then to conv (a permutation for most right charts)
    R = Tm[..., :3, :3]
    m = n @ R if Tm.ndim == 2 else np.einsum("...nj,...jk->...nk", n, R)
    rot = np.cross(np.broadcast_to(p, m.shape), m)
    return r, _assemble(rot, m, _to_convention(Tm, conv, GTSAM))


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
