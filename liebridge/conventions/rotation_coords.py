"""The four ways a library turns 3 numbers into a rotation increment, and back.

Each map sends ``r ∈ ℝ³`` to ``ΔR ∈ SO(3)``; all four agree with the rotation vector to first
order up to a scale (``exp``, ``cayley``: 1; ``half_exp``, ``quat_vec``: 1/2, i.e. ``r ≈ ω/2``):

``exp``
    Rotation vector (full angle): ``ΔR = Exp(r)``. GTSAM, Sophus, manif, Pinocchio, ...
``half_exp``
    Ceres ``QuaternionManifold``: ``q(δ) = [cos‖δ‖, sin‖δ‖·δ/‖δ‖]``, rotation angle ``2‖δ‖``,
    so ``ΔR = Exp(2r)`` (``include/ceres/manifold.h``, Ceres 2.2).
``quat_vec``
    g2o ``VertexSE3``: the vector part of a unit quaternion with ``w = sqrt(1 − ‖r‖²) ≥ 0``
    (``types/slam3d/isometry3d_mappings.cpp``, ``fromCompactQuaternion``); ``‖r‖ ≤ 1``.
    ``ΔR = I + 2w·hat(r) + 2·hat(r)²``; equals ``Exp(2 asin‖r‖ · r/‖r‖)``.
``cayley``
    GTSAM's ``Rot3::CayleyChart`` (``gtsam/geometry/Rot3M.cpp``, used by builds with
    ``GTSAM_ROT3_EXPMAP=OFF``): ``ΔR = (I − hat(r)/2)⁻¹(I + hat(r)/2)
    = I + 4/(4 + ‖r‖²)·(hat(r) + hat(r)²/2)``; inverse ``r = 2 vee(R − Rᵀ)/(1 + tr R)``.

``exp`` and ``half_exp`` are linearly related (exactly); the others are not.

Two more coordinates are **absolute** (Euler angles), not increments: they name the rotation
itself, and the chart adds to them, ``retract(R, r) = E(e(R) + r)``, ``local(R₁, R₂) =
e(R₂) − e(R₁)`` (yaw and roll differences wrapped to (−π, π]); ``side`` does not enter.

``euler_zyx``
    ``e = (yaw, pitch, roll)``, ``R = Rz(yaw)·Ry(pitch)·Rx(roll)`` (MRPT ``CPose3D`` /
    ``CPose3DPDFGaussian``: ``(x, y, z, yaw, pitch, roll)``, ``mrpt/poses/CPose3D.h``).
``euler_rpy``
    the same rotation, ``e = (roll, pitch, yaw)`` (ROS ``robot_localization``'s state
    ``(x, y, z, roll, pitch, yaw, ...)``, the iSAM/TORO ``EDGE3`` lines).

Their first-order map is not constant: the Euler rates of a body rate ``ω`` are
``ė = W(e) ω`` with (for ``(roll φ, pitch θ, yaw ψ)``) ``W = [[1, sφ tθ, cφ tθ], [0, cφ, −sφ],
[0, sφ/cθ, cφ/cθ]]``, singular at ``cos θ = 0``: at pitch = ±90° (gimbal lock) the chart is
singular and every function here raises (never NaN). False: "Euler-angle covariances convert by
reordering to (ω)" — only at roll = pitch = 0 is ``W = I``.

Every function takes torch tensors and JAX arrays too and returns the caller's array type
(differentiable: ``where`` with safe discarded branches, no host copy, no in-place write); numpy
keeps its code. The checks (``‖r‖ ≤ 1`` of ``quat_vec``, ``1 + tr R > 0`` of ``cayley``, gimbal
lock) are certified on the device; only where one fails is a host copy made, to word the same
error as numpy's (under tracing values are unknown and not checked). The record-driven engine
reaches the Euler coordinates only through :func:`euler_retract`, :func:`euler_local` and the rate
maps, never as an increment: :func:`to_rotation` and friends refuse them on tensors.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from ..lie import unchecked as U
from ..lie.series import angle, sinc

RotationCoords = Literal["exp", "half_exp", "quat_vec", "cayley", "euler_zyx", "euler_rpy"]
ROTATION_COORDS: tuple[str, ...] = (
    "exp", "half_exp", "quat_vec", "cayley", "euler_zyx", "euler_rpy"
)  # fmt: skip
#: The absolute (Euler-angle) coordinates.
EULER_COORDS: tuple[str, ...] = ("euler_zyx", "euler_rpy")

#: First-order scale ``dω/dr`` at ``r = 0`` of each map (Euler: at roll = pitch = 0).
FIRST_ORDER_SCALE: dict[str, float] = {
    "exp": 1.0, "half_exp": 2.0, "quat_vec": 2.0, "cayley": 1.0, "euler_zyx": 1.0, "euler_rpy": 1.0
}  # fmt: skip

#: Gimbal-lock threshold: ``|cos(pitch)|`` below this is refused.
GIMBAL_TOL = 1e-9


def _xp(x: FloatArray) -> Any:
    return arrays.namespace(x)


def _rpy(e: FloatArray, kind: str) -> FloatArray:
    """Euler coordinates of ``kind`` → ``(roll, pitch, yaw)``."""
    if kind == "euler_rpy":
        return e
    if arrays.is_foreign(e):
        return e[..., [2, 1, 0]]
    return np.asarray(e[..., ::-1], dtype=np.float64)


def _from_rpy(rpy: FloatArray, kind: str) -> FloatArray:
    return _rpy(rpy, kind)  # the reversal is its own inverse


def _check_gimbal(cp: FloatArray, what: str) -> None:
    if arrays.is_foreign(cp):  # certified on the device; the host copy words the error
        if arrays.all_true(_xp(cp).abs(cp) >= GIMBAL_TOL) is False:
            _check_gimbal(arrays.to_numpy(cp), what)
        return
    bad = ~(np.abs(cp) >= GIMBAL_TOL)
    if bad.any():
        i = validate.batch_index(bad)
        raise ValueError(
            f"{what}: pitch = ±90° (|cos pitch| = {float(np.abs(cp[i])):.3g} at batch index {i}): "
            "gimbal lock, where the Euler-angle chart is singular (roll and yaw are not separately "
            "defined and their rates are infinite); use a rotation-vector convention there"
        )


def _trig(rpy: FloatArray, k: int) -> tuple[FloatArray, FloatArray]:
    xp = _xp(rpy)
    return xp.cos(rpy[..., k]), xp.sin(rpy[..., k])


def euler_to_matrix(e: FloatArray, kind: str) -> FloatArray:
    """``Rz(yaw)·Ry(pitch)·Rx(roll)`` from Euler coordinates of ``kind`` ``(..., 3)``."""
    rpy = _rpy(e, kind)
    (cr, sr), (cp, sp), (cy, sy) = _trig(rpy, 0), _trig(rpy, 1), _trig(rpy, 2)
    return arrays.matrix(
        [
            cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr,
            sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr,
            -sp, cp * sr, cp * cr,
        ],
        3,
        3,
    )  # fmt: skip


def matrix_to_euler(R: FloatArray, kind: str, what: str = "R") -> FloatArray:
    """Euler coordinates of ``kind`` of ``R`` (pitch in [−π/2, π/2]); gimbal lock raises."""
    if arrays.is_foreign(R):
        cp = _xp(R).hypot(R[..., 0, 0], R[..., 1, 0])
        _check_gimbal(cp, what)
        pitch = arrays.atan2(-R[..., 2, 0], cp)
        roll = arrays.atan2(R[..., 2, 1], R[..., 2, 2])
        yaw = arrays.atan2(R[..., 1, 0], R[..., 0, 0])
        return _from_rpy(arrays.vector([roll, pitch, yaw]), kind)
    cp = np.hypot(R[..., 0, 0], R[..., 1, 0])
    _check_gimbal(cp, what)
    pitch = np.arctan2(-R[..., 2, 0], cp)
    roll = np.arctan2(R[..., 2, 1], R[..., 2, 2])
    yaw = np.arctan2(R[..., 1, 0], R[..., 0, 0])
    return _from_rpy(np.stack([roll, pitch, yaw], axis=-1), kind)


def euler_rate_map(e: FloatArray, kind: str, what: str = "R") -> FloatArray:
    """``W`` with ``ė = W ω_body`` (rows and columns: ``e`` in ``kind``'s order / ``ω``)."""
    rpy = _rpy(e, kind)
    (cr, sr), (cp, sp) = _trig(rpy, 0), _trig(rpy, 1)
    _check_gimbal(cp, what)
    if arrays.is_foreign(rpy):
        rows = [
            [1.0 + 0.0 * cp, sr * sp / cp, cr * sp / cp],
            [0.0 * cp, cr, -sr],
            [0.0 * cp, sr / cp, cr / cp],
        ]
        if kind != "euler_rpy":
            rows = rows[::-1]
        return arrays.matrix([v for row in rows for v in row], 3, 3)
    W = np.zeros((*rpy.shape[:-1], 3, 3))
    W[..., 0, 0] = 1.0
    W[..., 0, 1] = sr * sp / cp
    W[..., 0, 2] = cr * sp / cp
    W[..., 1, 1] = cr
    W[..., 1, 2] = -sr
    W[..., 2, 1] = sr / cp
    W[..., 2, 2] = cr / cp
    return W if kind == "euler_rpy" else np.asarray(W[..., ::-1, :], dtype=np.float64)


def euler_rate_map_inv(e: FloatArray, kind: str) -> FloatArray:
    """``W⁻¹``: ``ω_body = W⁻¹ ė`` = ``[[1, 0, −sθ], [0, cφ, sφ cθ], [0, −sφ, cφ cθ]]`` (rpy)."""
    rpy = _rpy(e, kind)
    (cr, sr), (cp, sp) = _trig(rpy, 0), _trig(rpy, 1)
    if arrays.is_foreign(rpy):
        zero = 0.0 * cp
        rows = [[1.0 + zero, zero, -sp], [zero, cr, sr * cp], [zero, -sr, cr * cp]]
        if kind != "euler_rpy":
            rows = [row[::-1] for row in rows]
        return arrays.matrix([v for row in rows for v in row], 3, 3)
    Wi = np.zeros((*rpy.shape[:-1], 3, 3))
    Wi[..., 0, 0] = 1.0
    Wi[..., 0, 2] = -sp
    Wi[..., 1, 1] = cr
    Wi[..., 1, 2] = sr * cp
    Wi[..., 2, 1] = -sr
    Wi[..., 2, 2] = cr * cp
    return Wi if kind == "euler_rpy" else np.asarray(Wi[..., :, ::-1], dtype=np.float64)


def _wrap_angles(d: FloatArray, kind: str) -> FloatArray:
    """Wrap the yaw and roll entries (not pitch) of an Euler difference to (−π, π]."""
    if arrays.is_foreign(d):
        w = np.pi - _xp(d).remainder(np.pi - d, 2.0 * np.pi)
        return arrays.concat([w[..., :1], d[..., 1:2], w[..., 2:]], axis=-1)
    w = np.pi - np.mod(np.pi - d, 2.0 * np.pi)
    keep = np.array([False, True, False])  # pitch sits in the middle in both orders
    return np.where(keep, d, w)


def euler_retract(R: FloatArray, r: FloatArray, kind: str) -> FloatArray:
    """``E(e(R) + r)``: the Euler chart's retraction."""
    return euler_to_matrix(matrix_to_euler(R, kind, "X") + r, kind)


def euler_local(RX: FloatArray, RY: FloatArray, kind: str) -> FloatArray:
    """``e(RY) − e(RX)``, yaw and roll differences wrapped to (−π, π]."""
    d = matrix_to_euler(RY, kind, "Y") - matrix_to_euler(RX, kind, "X")
    out = _wrap_angles(d, kind)
    return out if arrays.is_foreign(out) else np.asarray(out, dtype=np.float64)


def _generic_kind(x: FloatArray, kind: str) -> None:
    """Raise unless ``kind`` is an increment on ``x``'s array type (Euler angles are absolute)."""
    if arrays.is_foreign(x) and kind in EULER_COORDS:
        raise TypeError(
            f"rotation coordinates {kind!r} are absolute Euler angles, not an increment: on "
            "torch/JAX arrays a convention with them runs through euler_retract/euler_local "
            "and the rate maps, which its engine does not call there (docs/tensors.md)"
        )


def _sqrt0(x: FloatArray) -> FloatArray:
    """``sqrt(x)`` for ``x ≥ 0`` with a finite gradient at 0 (torch/JAX; 0 there, by ``where``)."""
    xp = _xp(x)
    pos = x > 0.0
    return xp.where(pos, xp.sqrt(xp.where(pos, x, 1.0 + 0.0 * x)), 0.0 * x)


def _raise_quat_vec_norm(n2: FloatArray) -> None:
    if (n2 > 1.0 + 1e-12).any():
        i = tuple(int(k) for k in np.argwhere(n2 > 1.0 + 1e-12)[0])
        raise ValueError(
            f"d: quaternion-vector rotation coordinates need ‖r‖ ≤ 1, got "
            f"‖r‖ = {float(np.sqrt(n2[i])):.6g} at batch index {i}"
        )


def _raise_cayley_pi(den: FloatArray) -> None:
    if (den <= 1e-12).any():
        i = tuple(int(k) for k in np.argwhere(den <= 1e-12)[0])
        raise ValueError(
            f"Cayley coordinates are undefined for a rotation by π (batch index {i}): "
            f"1 + tr R = {float(den[i]):.3g}"
        )


def _to_rotation_generic(r: FloatArray, kind: str) -> FloatArray:
    """:func:`to_rotation` of ``quat_vec``/``cayley`` on torch/JAX (``I + a·W + b·W²``)."""
    W = U.so3_hat(r)
    n2 = arrays.dot(r, r)
    if kind == "quat_vec":
        if arrays.all_true(n2 <= 1.0 + 1e-12) is False:
            _raise_quat_vec_norm(arrays.to_numpy(n2))
        w = _sqrt0(1.0 - n2)  # w = sqrt(1 − ‖r‖²) ≥ 0, clipped at 0 as numpy's
        return arrays.eye(3, r) + 2.0 * w[..., None, None] * W + 2.0 * (W @ W)
    c = (4.0 / (4.0 + n2))[..., None, None]
    return arrays.eye(3, r) + c * (W + 0.5 * (W @ W))


def to_rotation(r: FloatArray, kind: str) -> FloatArray:
    """Map coordinates ``r`` ``(..., 3)`` to the rotation increment ``(..., 3, 3)``.

    For the Euler kinds: the rotation with those Euler angles (numpy only: on tensors the Euler
    chart is :func:`euler_retract`'s, not an increment).
    """
    _generic_kind(r, kind)
    if kind in EULER_COORDS:
        return euler_to_matrix(r, kind)
    if kind == "exp":
        return U.so3_exp(r)
    if kind == "half_exp":
        return U.so3_exp(2.0 * r)
    if kind in ("quat_vec", "cayley") and arrays.is_foreign(r):
        return _to_rotation_generic(r, kind)
    W = U.so3_hat(r)
    n2 = np.einsum("...i,...i->...", r, r)
    if kind == "quat_vec":
        _raise_quat_vec_norm(n2)
        w = np.sqrt(np.clip(1.0 - n2, 0.0, None))
        return np.eye(3) + 2.0 * w[..., None, None] * W + 2.0 * (W @ W)
    if kind == "cayley":
        c = (4.0 / (4.0 + n2))[..., None, None]
        return np.eye(3) + c * (W + 0.5 * (W @ W))
    raise ValueError(f"rotation: unknown rotation coordinates {kind!r}")


def _quat_vec_of_log(w: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``(u, θ)``: the quaternion's vector part ``sin(θ/2)·ω/θ = ½·sinc(θ/2)·ω`` and ``θ``."""
    if arrays.is_foreign(w):
        th, t2 = angle(w)  # ‖ω‖ with a finite gradient at 0
        return 0.5 * sinc(0.5 * th, 0.25 * t2)[..., None] * w, th
    th = np.linalg.norm(w, axis=-1)
    return 0.5 * sinc(0.5 * th)[..., None] * w, th


def _cayley(R: FloatArray) -> FloatArray:
    """``r = 2 vee(R − Rᵀ)/(1 + tr R)``; a rotation by π (``1 + tr R ≤ 1e-12``) raises."""
    if arrays.is_foreign(R):
        s = arrays.vector(
            [R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]]
        )
        den = 1.0 + (R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2])
        if arrays.all_true(den > 1e-12) is False:
            _raise_cayley_pi(arrays.to_numpy(den))
        return 2.0 * s / den[..., None]
    s = np.stack(
        [R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]],
        axis=-1,
    )
    den = 1.0 + np.trace(R, axis1=-2, axis2=-1)
    _raise_cayley_pi(den)
    return np.asarray(2.0 * s / den[..., None], dtype=np.float64)


def from_rotation(R: FloatArray, kind: str) -> FloatArray:
    """Inverse of :func:`to_rotation` (principal branch: ``θ ≤ π``, quaternion ``w ≥ 0``)."""
    _generic_kind(R, kind)
    if kind in EULER_COORDS:
        return matrix_to_euler(R, kind)
    if kind == "exp":
        return U.so3_log(R)
    if kind == "half_exp":
        return 0.5 * U.so3_log(R)
    if kind == "quat_vec":
        # vector part sin(θ/2)·ω/θ = ½·sinc(θ/2)·ω, w-component cos(θ/2) ≥ 0 for θ ≤ π
        return _quat_vec_of_log(U.so3_log(R))[0]
    if kind == "cayley":
        return _cayley(R)
    raise ValueError(f"rotation: unknown rotation coordinates {kind!r}")


def d_from_rotation(R: FloatArray, kind: str, side: str) -> FloatArray:
    """Differentiate :func:`from_rotation` under a rotation-vector perturbation of ``R``.

    Returns ``∂ from_rotation(R·Exp(δ)) / ∂δ`` (``side="right"``) or
    ``∂ from_rotation(Exp(δ)·R) / ∂δ`` (``side="left"``) at ``δ = 0``, shape ``(..., 3, 3)``:

    * ``exp``: ``Jr⁻¹(ω)`` / ``Jl⁻¹(ω)``; ``half_exp``: half of those;
    * ``quat_vec``: with ``(w, u)`` the quaternion of ``R`` (``w ≥ 0``),
      ``q ⊗ (1, δ/2)`` gives ``½(w I + hat(u))``; ``(1, δ/2) ⊗ q`` gives ``½(w I − hat(u))``;
    * ``cayley``: with ``s = vee(R − Rᵀ)`` and ``r = 2s/(1 + tr R)``, right:
      ``2/(1 + tr R)·(tr R·I − Rᵀ) + ½ r rᵀ`` (from ``[δ]A + Aᵀ[δ] = [(tr A·I − A)δ]``);
      left: the right one times ``Rᵀ``.

    Verified against finite differences in ``tests/test_local_jacobian.py``.
    """
    _generic_kind(R, kind)
    if kind in ("exp", "half_exp"):
        w = U.so3_log(R)
        J = U.so3_jr_inv(w) if side == "right" else U.so3_jl_inv(w)
        return J if kind == "exp" else 0.5 * J
    foreign = arrays.is_foreign(R)
    if kind == "quat_vec":
        u, th = _quat_vec_of_log(U.so3_log(R))
        qw = _xp(R).cos(0.5 * th)[..., None, None]
        H = U.so3_hat(u)
        eye = arrays.eye(3, R) if foreign else np.eye(3)
        return 0.5 * (qw * eye + (H if side == "right" else -H))
    if kind == "cayley":
        r = from_rotation(R, "cayley")
        if foreign:
            tr = (R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2])[..., None, None]
            Rt = arrays.mT(R)
            D = 2.0 / (1.0 + tr) * (tr * arrays.eye(3, R) - Rt)
            D = D + 0.5 * r[..., :, None] * r[..., None, :]
            return D if side == "right" else D @ Rt
        tr = np.trace(R, axis1=-2, axis2=-1)[..., None, None]
        D = 2.0 / (1.0 + tr) * (tr * np.eye(3) - np.swapaxes(R, -1, -2))
        D = D + 0.5 * r[..., :, None] * r[..., None, :]
        return D if side == "right" else np.asarray(D @ np.swapaxes(R, -1, -2), dtype=np.float64)
    raise ValueError(f"rotation: unknown rotation coordinates {kind!r}")
