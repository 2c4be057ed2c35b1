"""IMU factor on preintegrated measurements, with GTSAM's ComponentWise residual.

The residual is the one of ``gtsam.ImuFactor`` with ``ImuFactorErrorMode.ComponentWise``
(GTSAM 4.3: ``PreintegrationBase::computeError`` →
``internal::navStateComponentWiseLocalCoordinates(state_j, predict(state_i, bias_i))``, files
``gtsam/navigation/PreintegrationBase.cpp``, ``NavState.cpp``). With the prediction
``X̂_j = (R̂, p̂, v̂)`` of :meth:`PreintegratedImu.predict`::

    e_R = Log(R_jᵀ R̂)          e_p = R_jᵀ (p̂ − p_j)          e_v = R_jᵀ (v̂ − v_j)

in the order (rot, pos, vel). This is Forster et al.'s preintegrated IMU residual (TRO 2017)
written as "predicted ⊖ actual" in frame ``j``: ``e = −blockdiag(I, R_jᵀR_i, R_jᵀR_i) r_Forster``
(``r_ΔR = Log(ΔR(b)ᵀ R_iᵀ R_j)``, ``r_Δp = R_iᵀ(p_j − p_i − v_i Δt − ½gΔt²) − Δp(b)``, …), so
both vanish together and carry the same information. GTSAM's default error mode in 4.3 is
``Logmap`` (the NavState group logarithm), which differs at second order; this factor is not that.

Jacobians are analytic and taken with respect to GTSAM's tangents: ``Pose3`` right perturbation
``(ω, v)`` (``T·Exp(ξ)``), velocities additive in the world frame (GTSAM stores them as
``Vector3``), the bias additive in the order (acc, gyro).
"""

from __future__ import annotations

from typing import Any

import gtsam
import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..gtsam.custom import make_custom_factor
from ..lie import so3
from .inputs import read_bias
from .preintegration import PreintegratedImu

__all__ = ["imu", "imu_residual"]


class _KernelOps:
    """SO(3) maps for batched inputs: liebridge's numpy kernel."""

    exp = staticmethod(so3.exp)
    log = staticmethod(so3.log)
    jr = staticmethod(so3.jr)
    jr_inv = staticmethod(so3.jr_inv)


class _GtsamOps:
    """The same maps for one state, through GTSAM's ``Rot3``.

    C++, ~1 µs per call instead of the kernel's ~50 µs numpy overhead for a single element, which
    is what a factor callback pays per evaluation. ``Rot3.ExpmapDerivative`` is J_r,
    ``LogmapDerivative`` is J_r⁻¹ (the batched path and this one are checked against each other
    in tests/test_imu_factor.py).
    """

    @staticmethod
    def exp(w: FloatArray) -> FloatArray:
        return np.asarray(gtsam.Rot3.Expmap(w).matrix())

    @staticmethod
    def log(R: FloatArray) -> FloatArray:
        return np.asarray(gtsam.Rot3.Logmap(gtsam.Rot3(R)))

    @staticmethod
    def jr(w: FloatArray) -> FloatArray:
        return np.asarray(gtsam.Rot3.ExpmapDerivative(w))

    @staticmethod
    def jr_inv(w: FloatArray) -> FloatArray:
        return np.asarray(gtsam.Rot3.LogmapDerivative(w))


def _residual(
    R_i: FloatArray,
    p_i: FloatArray,
    v_i: FloatArray,
    R_j: FloatArray,
    p_j: FloatArray,
    v_j: FloatArray,
    bias: FloatArray,
    pim: PreintegratedImu,
    want: bool,
) -> tuple[FloatArray, list[FloatArray] | None]:
    """Batched residual on validated arrays: rotations (...,3,3), vectors (...,3), bias (...,6)."""
    single = R_i.ndim == 2 and R_j.ndim == 2 and bias.ndim == 1
    ops: type[_KernelOps] | type[_GtsamOps] = _GtsamOps if single else _KernelOps
    db = bias - pim.bias_hat
    dba, dbg = db[..., :3], db[..., 3:]
    phi = dbg @ pim.dR_dbg.T
    dR = pim.delta_R @ ops.exp(phi)
    dp = pim.delta_p + dba @ pim.dp_dba.T + dbg @ pim.dp_dbg.T
    dv = pim.delta_v + dba @ pim.dv_dba.T + dbg @ pim.dv_dbg.T
    t, g = pim.delta_t, pim.gravity
    R_hat = R_i @ dR
    p_hat = p_i + v_i * t + 0.5 * t * t * g + np.einsum("...ij,...j->...i", R_i, dp)
    v_hat = v_i + g * t + np.einsum("...ij,...j->...i", R_i, dv)
    Rjt = np.swapaxes(R_j, -1, -2)
    E = Rjt @ R_hat
    e_R = ops.log(E)
    e_p = np.einsum("...ij,...j->...i", Rjt, p_hat - p_j)
    e_v = np.einsum("...ij,...j->...i", Rjt, v_hat - v_j)
    err = np.concatenate(np.broadcast_arrays(e_R, e_p, e_v), axis=-1)
    if not want:
        return err, None

    batch = err.shape[:-1]
    Jri = ops.jr_inv(e_R)
    RjtRi = Rjt @ R_i
    J_pose_i = np.zeros((*batch, 9, 6))
    J_pose_i[..., 0:3, 0:3] = Jri @ np.swapaxes(dR, -1, -2)
    J_pose_i[..., 3:6, 0:3] = -RjtRi @ so3.hat(dp)
    J_pose_i[..., 3:6, 3:6] = RjtRi
    J_pose_i[..., 6:9, 0:3] = -RjtRi @ so3.hat(dv)
    J_vel_i = np.zeros((*batch, 9, 3))
    J_vel_i[..., 3:6, :] = t * Rjt
    J_vel_i[..., 6:9, :] = Rjt
    J_pose_j = np.zeros((*batch, 9, 6))
    J_pose_j[..., 0:3, 0:3] = -Jri @ np.swapaxes(E, -1, -2)
    J_pose_j[..., 3:6, 0:3] = so3.hat(e_p)
    J_pose_j[..., 3:6, 3:6] = -np.eye(3)
    J_pose_j[..., 6:9, 0:3] = so3.hat(e_v)
    J_vel_j = np.zeros((*batch, 9, 3))
    J_vel_j[..., 6:9, :] = -Rjt
    J_bias = np.zeros((*batch, 9, 6))
    J_bias[..., 0:3, 3:6] = Jri @ ops.jr(phi) @ pim.dR_dbg
    J_bias[..., 3:6, :] = RjtRi @ np.concatenate([pim.dp_dba, pim.dp_dbg], axis=1)
    J_bias[..., 6:9, :] = RjtRi @ np.concatenate([pim.dv_dba, pim.dv_dbg], axis=1)
    return err, [J_pose_i, J_vel_i, J_pose_j, J_vel_j, J_bias]


def imu_residual(
    pose_i: Any,
    vel_i: Any,
    pose_j: Any,
    vel_j: Any,
    bias: Any,
    preintegrated: PreintegratedImu,
    *,
    jacobians: bool = True,
) -> tuple[FloatArray, list[FloatArray] | None]:
    """Residual of :func:`imu` (GTSAM ``ImuFactor``, ComponentWise) and its Jacobians.

    Parameters
    ----------
    pose_i, pose_j : array_like, shape (..., 4, 4)
        ``T_world_body`` at ``i`` and ``j``.
    vel_i, vel_j : array_like, shape (..., 3)
        Velocities in the world frame.
    bias : gtsam.imuBias.ConstantBias, (acc, gyro) pair, or array (..., 6)
        Bias at ``i``, order (acc, gyro).
    preintegrated : PreintegratedImu
    jacobians : bool
        Also return the Jacobians.

    Returns
    -------
    error : ndarray, shape (..., 9)
        Order (rot, pos, vel); see the module docstring.
    jacobians : list of ndarray or None
        ``[J_pose_i (..., 9, 6), J_vel_i (..., 9, 3), J_pose_j (..., 9, 6), J_vel_j (..., 9, 3),
        J_bias (..., 9, 6)]`` with respect to GTSAM's tangents (Pose3 right ``(ω, v)``,
        velocity additive in the world frame, bias additive (acc, gyro)).
    """
    if not isinstance(preintegrated, PreintegratedImu):
        raise TypeError(
            f"preintegrated: expected a PreintegratedImu, got {type(preintegrated).__name__}"
        )
    T_i = validate.pose(pose_i, "pose_i")
    T_j = validate.pose(pose_j, "pose_j")
    return _residual(
        T_i[..., :3, :3],
        T_i[..., :3, 3],
        validate.vector(vel_i, "vel_i", 3),
        T_j[..., :3, :3],
        T_j[..., :3, 3],
        validate.vector(vel_j, "vel_j", 3),
        read_bias(bias),
        preintegrated,
        jacobians,
    )


def imu(
    pose_i: int,
    vel_i: int,
    pose_j: int,
    vel_j: int,
    bias_key: int,
    preintegrated: PreintegratedImu,
) -> Any:
    """IMU factor between two keyframes, a ``gtsam.CustomFactor`` with analytic Jacobians.

    Same residual, Jacobians and noise model (``preintegrated.covariance``, GTSAM's
    ``residualCovariance()``) as ``gtsam.ImuFactor`` in ``ImuFactorErrorMode.ComponentWise``,
    i.e. Forster et al.'s residual (see the module docstring), but on liebridge's manifold
    preintegration (GTSAM's own ``ImuFactor`` only accepts its tangent preintegration).

    Parameters
    ----------
    pose_i, vel_i, pose_j, vel_j, bias_key : int
        GTSAM keys of ``Pose3`` (``T_world_body``), ``Vector3`` world-frame velocities and an
        ``imuBias.ConstantBias``.
    preintegrated : PreintegratedImu
        From :func:`liebridge.factors.preintegrate`, :class:`ImuPreintegrator` or
        :meth:`PreintegratedImu.from_gtsam`.

    Returns
    -------
    gtsam.CustomFactor
        Usable in GTSAM's optimizers and in ``liebridge.gtsam.optimize``.
    """
    if not isinstance(preintegrated, PreintegratedImu):
        raise TypeError(
            f"preintegrated: expected a PreintegratedImu, got {type(preintegrated).__name__}"
        )
    names = ("pose_i", "vel_i", "pose_j", "vel_j", "bias_key")
    keys = [
        validate.key(k, n)
        for k, n in zip((pose_i, vel_i, pose_j, vel_j, bias_key), names, strict=True)
    ]
    for a in range(5):
        for b in range(a):
            if keys[a] == keys[b]:
                raise ValueError(f"{names[a]}: the same key as {names[b]} ({keys[a]})")
    cov = validate.positive_definite(preintegrated.covariance, "preintegrated.covariance", 9)
    noise = gtsam.noiseModel.Gaussian.Covariance(np.array(cov))
    k_pi, k_vi, k_pj, k_vj, k_b = keys

    def evaluate(values: Any, want: bool) -> tuple[FloatArray, list[FloatArray] | None]:
        T_i = values.atPose3(k_pi).matrix()
        T_j = values.atPose3(k_pj).matrix()
        return _residual(
            T_i[:3, :3],
            T_i[:3, 3],
            np.asarray(values.atVector(k_vi), dtype=np.float64),
            T_j[:3, :3],
            T_j[:3, 3],
            np.asarray(values.atVector(k_vj), dtype=np.float64),
            np.asarray(values.atConstantBias(k_b).vector(), dtype=np.float64),
            preintegrated,
            want,
        )

    return make_custom_factor(noise, keys, [6, 3, 6, 3, 6], evaluate, name="imu")
