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
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from ..lie import unchecked as U
from ..lie.series import sinc

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


def _rpy(e: FloatArray, kind: str) -> FloatArray:
    """Euler coordinates of ``kind`` → ``(roll, pitch, yaw)``."""
    return e if kind == "euler_rpy" else np.asarray(e[..., ::-1], dtype=np.float64)


def _from_rpy(rpy: FloatArray, kind: str) -> FloatArray:
    return rpy if kind == "euler_rpy" else np.asarray(rpy[..., ::-1], dtype=np.float64)


def _check_gimbal(cp: FloatArray, what: str) -> None:
    bad = ~(np.abs(cp) >= GIMBAL_TOL)
    if bad.any():
        i = validate.batch_index(bad)
        raise ValueError(
            f"{what}: pitch = ±90° (|cos pitch| = {float(np.abs(cp[i])):.3g} at batch index {i}): "
            "gimbal lock, where the Euler-angle chart is singular (roll and yaw are not separately "
            "defined and their rates are infinite); use a rotation-vector convention there"
        )


def euler_to_matrix(e: FloatArray, kind: str) -> FloatArray:
    """``Rz(yaw)·Ry(pitch)·Rx(roll)`` from Euler coordinates of ``kind`` ``(..., 3)``."""
    rpy = _rpy(e, kind)
    cr, sr = np.cos(rpy[..., 0]), np.sin(rpy[..., 0])
    cp, sp = np.cos(rpy[..., 1]), np.sin(rpy[..., 1])
    cy, sy = np.cos(rpy[..., 2]), np.sin(rpy[..., 2])
    R = np.empty((*rpy.shape[:-1], 3, 3))
    R[..., 0, 0] = cy * cp
    R[..., 0, 1] = cy * sp * sr - sy * cr
    R[..., 0, 2] = cy * sp * cr + sy * sr
    R[..., 1, 0] = sy * cp
    R[..., 1, 1] = sy * sp * sr + cy * cr
    R[..., 1, 2] = sy * sp * cr - cy * sr
    R[..., 2, 0] = -sp
    R[..., 2, 1] = cp * sr
    R[..., 2, 2] = cp * cr
    return R


def matrix_to_euler(R: FloatArray, kind: str, what: str = "R") -> FloatArray:
    """Euler coordinates of ``kind`` of ``R`` (pitch in [−π/2, π/2]); gimbal lock raises."""
    cp = np.hypot(R[..., 0, 0], R[..., 1, 0])
    _check_gimbal(cp, what)
    pitch = np.arctan2(-R[..., 2, 0], cp)
    roll = np.arctan2(R[..., 2, 1], R[..., 2, 2])
    yaw = np.arctan2(R[..., 1, 0], R[..., 0, 0])
    return _from_rpy(np.stack([roll, pitch, yaw], axis=-1), kind)


def euler_rate_map(e: FloatArray, kind: str, what: str = "R") -> FloatArray:
    """``W`` with ``ė = W ω_body`` (rows and columns: ``e`` in ``kind``'s order / ``ω``)."""
    rpy = _rpy(e, kind)
    cr, sr = np.cos(rpy[..., 0]), np.sin(rpy[..., 0])
    cp, sp = np.cos(rpy[..., 1]), np.sin(rpy[..., 1])
    _check_gimbal(cp, what)
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
    cr, sr = np.cos(rpy[..., 0]), np.sin(rpy[..., 0])
    cp, sp = np.cos(rpy[..., 1]), np.sin(rpy[..., 1])
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
    w = np.pi - np.mod(np.pi - d, 2.0 * np.pi)
    keep = np.array([False, True, False])  # pitch sits in the middle in both orders
    return np.where(keep, d, w)


def euler_retract(R: FloatArray, r: FloatArray, kind: str) -> FloatArray:
    """``E(e(R) + r)``: the Euler chart's retraction."""
    return euler_to_matrix(matrix_to_euler(R, kind, "X") + r, kind)


def euler_local(RX: FloatArray, RY: FloatArray, kind: str) -> FloatArray:
    """``e(RY) − e(RX)``, yaw and roll differences wrapped to (−π, π]."""
    d = matrix_to_euler(RY, kind, "Y") - matrix_to_euler(RX, kind, "X")
    return np.asarray(_wrap_angles(d, kind), dtype=np.float64)


def _generic_kind(x: FloatArray, kind: str) -> None:
    """Raise unless ``kind`` runs on ``x``'s array type (torch/JAX: ``exp`` and ``half_exp``)."""
    if arrays.is_foreign(x) and kind not in ("exp", "half_exp"):
        raise TypeError(
            f"rotation coordinates {kind!r} run on numpy arrays only; on torch/JAX arrays the "
            "rotation-vector coordinates 'exp' and 'half_exp' do (docs/tensors.md)"
        )


def to_rotation(r: FloatArray, kind: str) -> FloatArray:
    """Map coordinates ``r`` ``(..., 3)`` to the rotation increment ``(..., 3, 3)``.

    For the Euler kinds: the rotation with those Euler angles.
    """
    _generic_kind(r, kind)
    if kind in EULER_COORDS:
        return euler_to_matrix(r, kind)
    if kind == "exp":
        return U.so3_exp(r)
    if kind == "half_exp":
        return U.so3_exp(2.0 * r)
    W = U.so3_hat(r)
    n2 = np.einsum("...i,...i->...", r, r)
    if kind == "quat_vec":
        if (n2 > 1.0 + 1e-12).any():
            i = tuple(int(k) for k in np.argwhere(n2 > 1.0 + 1e-12)[0])
            raise ValueError(
                f"d: quaternion-vector rotation coordinates need ‖r‖ ≤ 1, got "
                f"‖r‖ = {float(np.sqrt(n2[i])):.6g} at batch index {i}"
            )
        w = np.sqrt(np.clip(1.0 - n2, 0.0, None))
        return np.eye(3) + 2.0 * w[..., None, None] * W + 2.0 * (W @ W)
    if kind == "cayley":
        c = (4.0 / (4.0 + n2))[..., None, None]
        return np.eye(3) + c * (W + 0.5 * (W @ W))
    raise ValueError(f"rotation: unknown rotation coordinates {kind!r}")


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
        w = U.so3_log(R)
        th = np.linalg.norm(w, axis=-1)
        # vector part sin(θ/2)·ω/θ = ½·sinc(θ/2)·ω, w-component cos(θ/2) ≥ 0 for θ ≤ π
        return 0.5 * sinc(0.5 * th)[..., None] * w
    if kind == "cayley":
        s = np.stack(
            [R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]],
            axis=-1,
        )
        den = 1.0 + np.trace(R, axis1=-2, axis2=-1)
        if (den <= 1e-12).any():
            i = tuple(int(k) for k in np.argwhere(den <= 1e-12)[0])
            raise ValueError(
                f"Cayley coordinates are undefined for a rotation by π (batch index {i}): "
                f"1 + tr R = {float(den[i]):.3g}"
            )
        return np.asarray(2.0 * s / den[..., None], dtype=np.float64)
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
    if kind == "quat_vec":
        w = U.so3_log(R)
        th = np.linalg.norm(w, axis=-1)
        u = 0.5 * sinc(0.5 * th)[..., None] * w
        qw = np.cos(0.5 * th)[..., None, None]
        H = U.so3_hat(u)
        return 0.5 * (qw * np.eye(3) + (H if side == "right" else -H))
    if kind == "cayley":
        r = from_rotation(R, "cayley")
        tr = np.trace(R, axis1=-2, axis2=-1)[..., None, None]
        D = 2.0 / (1.0 + tr) * (tr * np.eye(3) - np.swapaxes(R, -1, -2))
        D = D + 0.5 * r[..., :, None] * r[..., None, :]
        return D if side == "right" else np.asarray(D @ np.swapaxes(R, -1, -2), dtype=np.float64)
    raise ValueError(f"rotation: unknown rotation coordinates {kind!r}")
