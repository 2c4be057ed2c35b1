"""Combined IMU factor: GTSAM's ``CombinedImuFactor`` (15-dimensional residual) as a custom factor.

With :class:`~liebridge.imu.combined.PreintegratedCombined` ``pim`` (GTSAM's tangent
preintegration), bias estimate ``b̂`` and ``δb = b_i − b̂`` the bias-corrected tangent vector is
``(θ_c, p_c, v_c) = (θ, p, v) + pim.bias_jacobian δb`` (``TangentPreintegration::
biasCorrectedDelta``), and the prediction (``PreintegrationBase::predict``, ``NavState::
correctPIM`` and ``retract``, no Coriolis)::

    R̂ = R_i Exp(θ_c)    p̂ = p_i + v_i Δt + ½ g Δt² + R_i p_c    v̂ = v_i + g Δt + R_i v_c

The residual, order ``(θ, p, v, b_a, b_g)``, is ``ImuFactorErrorMode.ComponentWise``'s

    e_R = Log(R_jᵀ R̂)    e_p = R_jᵀ (p̂ − p_j)    e_v = R_jᵀ (v̂ − v_j)    e_b = b_i − b_j

(``CombinedImuFactor::evaluateError``: ``traits<ConstantBias>::Between(bias_j, bias_i)``). GTSAM
4.3's default mode is ``Logmap`` (the NavState group logarithm), which differs at second order; set
``params.setImuFactorErrorMode(gtsam.ImuFactorErrorMode.ComponentWise)`` to compare.
The noise model is GTSAM's: ``pim.residual_covariance`` (``residualCovariance()``), not
``pim.covariance`` (``preintMeasCov()``).

Jacobians are analytic, with respect to GTSAM's tangents: ``Pose3`` right ``(ω, v)``, velocities
additive in the world frame, biases additive (acc, gyro).
"""

from __future__ import annotations

from typing import Any

import gtsam
import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..gtsam.custom import make_custom_factor
from ..lie import so3
from .combined import PreintegratedCombined
from .inputs import read_bias

__all__ = ["combined_imu", "combined_imu_residual"]


def _residual(
    R_i: FloatArray,
    p_i: FloatArray,
    v_i: FloatArray,
    R_j: FloatArray,
    p_j: FloatArray,
    v_j: FloatArray,
    b_i: FloatArray,
    b_j: FloatArray,
    pim: PreintegratedCombined,
    want: bool,
) -> tuple[FloatArray, list[FloatArray] | None]:
    db = b_i - pim.bias_hat
    xc = pim.preintegrated + pim.bias_jacobian @ db
    th, dp, dv = xc[0:3], xc[3:6], xc[6:9]
    dR = so3.exp(th)
    t, g = pim.delta_t, pim.gravity
    R_hat = R_i @ dR
    p_hat = p_i + v_i * t + 0.5 * t * t * g + R_i @ dp
    v_hat = v_i + g * t + R_i @ dv
    Rjt = R_j.T
    E = Rjt @ R_hat
    e_R = so3.log(E)
    e_p = Rjt @ (p_hat - p_j)
    e_v = Rjt @ (v_hat - v_j)
    err = np.concatenate([e_R, e_p, e_v, b_i - b_j])
    if not want:
        return err, None
    Jri = so3.jr_inv(e_R)
    RjtRi = Rjt @ R_i
    J_pose_i = np.zeros((15, 6))
    J_pose_i[0:3, 0:3] = Jri @ dR.T
    J_pose_i[3:6, 0:3] = -RjtRi @ so3.hat(dp)
    J_pose_i[3:6, 3:6] = RjtRi
    J_pose_i[6:9, 0:3] = -RjtRi @ so3.hat(dv)
    J_vel_i = np.zeros((15, 3))
    J_vel_i[3:6] = t * Rjt
    J_vel_i[6:9] = Rjt
    J_pose_j = np.zeros((15, 6))
    J_pose_j[0:3, 0:3] = -Jri @ E.T
    J_pose_j[3:6, 0:3] = so3.hat(e_p)
    J_pose_j[3:6, 3:6] = -np.eye(3)
    J_pose_j[6:9, 0:3] = so3.hat(e_v)
    J_vel_j = np.zeros((15, 3))
    J_vel_j[6:9] = -Rjt
    H = pim.bias_jacobian
    J_bias_i = np.zeros((15, 6))
    J_bias_i[0:3] = Jri @ so3.jr(th) @ H[0:3]
    J_bias_i[3:6] = RjtRi @ H[3:6]
    J_bias_i[6:9] = RjtRi @ H[6:9]
    J_bias_i[9:15] = np.eye(6)
    J_bias_j = np.zeros((15, 6))
    J_bias_j[9:15] = -np.eye(6)
    return err, [J_pose_i, J_vel_i, J_pose_j, J_vel_j, J_bias_i, J_bias_j]


def combined_imu_residual(
    pose_i: Any,
    vel_i: Any,
    pose_j: Any,
    vel_j: Any,
    bias_i: Any,
    bias_j: Any,
    pim: PreintegratedCombined,
    *,
    jacobians: bool = True,
) -> tuple[FloatArray, list[FloatArray] | None]:
    """Residual (15,) of :func:`combined_imu` and its Jacobians, for one state.

    Parameters
    ----------
    pose_i, pose_j : array_like (4, 4)
        ``T_world_body``.
    vel_i, vel_j : array_like (3,)
        World-frame velocities.
    bias_i, bias_j : gtsam.imuBias.ConstantBias, (acc, gyro) pair, or array (6,)
    pim : PreintegratedCombined

    Returns
    -------
    error : ndarray (15,)
        ``(e_R, e_p, e_v, b_i − b_j)``, see the module docstring.
    jacobians : list of ndarray or None
        ``[J_pose_i (15, 6), J_vel_i (15, 3), J_pose_j (15, 6), J_vel_j (15, 3),
        J_bias_i (15, 6), J_bias_j (15, 6)]``.
    """
    if not isinstance(pim, PreintegratedCombined):
        raise TypeError(f"pim: expected a PreintegratedCombined, got {type(pim).__name__}")
    T_i = validate.pose(pose_i, "pose_i")
    T_j = validate.pose(pose_j, "pose_j")
    b_i, b_j = read_bias(bias_i, "bias_i"), read_bias(bias_j, "bias_j")
    for name, arr in (("pose_i", T_i), ("pose_j", T_j), ("bias_i", b_i), ("bias_j", b_j)):
        if arr.ndim != (2 if name.startswith("pose") else 1):
            raise ValueError(f"{name}: one state expected (no batch), got shape {arr.shape}")
    return _residual(
        T_i[:3, :3],
        T_i[:3, 3],
        validate.vector(vel_i, "vel_i", 3),
        T_j[:3, :3],
        T_j[:3, 3],
        validate.vector(vel_j, "vel_j", 3),
        b_i,
        b_j,
        pim,
        jacobians,
    )


def combined_imu(
    pose_i: int,
    vel_i: int,
    pose_j: int,
    vel_j: int,
    bias_i: int,
    bias_j: int,
    pim: PreintegratedCombined,
) -> Any:
    """Build the combined IMU factor between two keyframes: a ``gtsam.CustomFactor``.

    The residual of ``gtsam.CombinedImuFactor`` in ``ImuFactorErrorMode.ComponentWise`` (see the
    module docstring) with GTSAM's noise model ``pim.residual_covariance``
    (``residualCovariance()``). Usable with GTSAM's optimizers and
    :func:`liebridge.factors.optimize`.

    Parameters
    ----------
    pose_i, vel_i, pose_j, vel_j, bias_i, bias_j : int
        GTSAM keys of ``Pose3`` (``T_world_body``), world-frame ``Vector3`` velocities and
        ``imuBias.ConstantBias`` at ``i`` and ``j``.
    pim : PreintegratedCombined
        From :func:`liebridge.factors.preintegrate_combined`.
    """
    if not isinstance(pim, PreintegratedCombined):
        raise TypeError(f"pim: expected a PreintegratedCombined, got {type(pim).__name__}")
    names = ("pose_i", "vel_i", "pose_j", "vel_j", "bias_i", "bias_j")
    keys = [
        validate.key(k, n)
        for k, n in zip((pose_i, vel_i, pose_j, vel_j, bias_i, bias_j), names, strict=True)
    ]
    for a in range(6):
        for b in range(a):
            if keys[a] == keys[b]:
                raise ValueError(f"{names[a]}: the same key as {names[b]} ({keys[a]})")
    cov = validate.positive_definite(pim.residual_covariance, "pim.residual_covariance", 15)
    noise = gtsam.noiseModel.Gaussian.Covariance(np.array(cov))
    k_pi, k_vi, k_pj, k_vj, k_bi, k_bj = keys

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
            np.asarray(values.atConstantBias(k_bi).vector(), dtype=np.float64),
            np.asarray(values.atConstantBias(k_bj).vector(), dtype=np.float64),
            pim,
            want,
        )

    return make_custom_factor(noise, keys, [6, 3, 6, 3, 6, 6], evaluate, name="combined_imu")
