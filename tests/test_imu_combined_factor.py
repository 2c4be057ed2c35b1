"""``combined_imu`` against ``gtsam.CombinedImuFactor`` (ComponentWise) and finite differences."""

from __future__ import annotations

import gtsam
import numpy as np
import pytest
from test_imu_combined import combined_params, gtsam_combined
from test_imu_preintegration import ACC, BIAS, DT, GYRO

import liebridge.factors as F
from liebridge.check import numerical_jacobian
from liebridge.lie import se3

N = 200
KEYS = (1, 2, 3, 4, 5, 6)


def _setup():
    p = combined_params()
    p.setImuFactorErrorMode(gtsam.ImuFactorErrorMode.ComponentWise)
    pim = gtsam_combined(p, BIAS, ACC[:N], GYRO[:N], DT[:N])
    ours = F.preintegrate_combined(ACC[:N], GYRO[:N], DT[:N], bias=BIAS, params=p)
    return pim, ours


PIM, OURS = _setup()


def _random_state(seed: int):
    rng = np.random.default_rng(seed)
    T_i = se3.exp(rng.normal(scale=[0.5, 0.5, 0.5, 3, 3, 3]))
    v_i = rng.normal(scale=2.0, size=3)
    # near the prediction (as in an optimizer), with a perturbation
    b_i = BIAS.vector() + rng.normal(scale=[1e-2, 1e-2, 1e-2, 1e-3, 1e-3, 1e-3])
    T_j, v_j = _predict(T_i, v_i, b_i)
    T_j = T_j @ se3.exp(rng.normal(scale=[0.05, 0.05, 0.05, 0.3, 0.3, 0.3]))
    v_j = v_j + rng.normal(scale=0.2, size=3)
    b_j = b_i + rng.normal(scale=1e-3, size=6)
    return T_i, v_i, T_j, v_j, b_i, b_j


def _predict(T_i, v_i, b_i):
    st = PIM.predict(
        gtsam.NavState(gtsam.Pose3(T_i), v_i), gtsam.imuBias.ConstantBias(b_i[:3], b_i[3:])
    )
    return st.pose().matrix(), np.asarray(st.velocity())


def _values(T_i, v_i, T_j, v_j, b_i, b_j) -> gtsam.Values:
    vals = gtsam.Values()
    vals.insert(1, gtsam.Pose3(T_i))
    vals.insert(2, v_i)
    vals.insert(3, gtsam.Pose3(T_j))
    vals.insert(4, v_j)
    vals.insert(5, gtsam.imuBias.ConstantBias(b_i[:3], b_i[3:]))
    vals.insert(6, gtsam.imuBias.ConstantBias(b_j[:3], b_j[3:]))
    return vals


def _gtsam_unwhitened(factor, vals):
    """GTSAM's error and Jacobians, unwhitened from ``linearize`` (A = R·H, b = −R·e)."""
    jf = factor.linearize(vals)
    Ab = jf.augmentedJacobian()
    R = factor.noiseModel().R()
    Rinv = np.linalg.inv(R)
    H = Rinv @ Ab[:, :-1]
    e = -Rinv @ Ab[:, -1]
    return e, np.split(H, np.cumsum([6, 3, 6, 3, 6])[:], axis=1)


@pytest.mark.parametrize("seed", range(6))
def test_error_and_jacobians_equal_gtsam_combined_imu_factor(seed) -> None:
    state = _random_state(seed)
    vals = _values(*state)
    g = gtsam.CombinedImuFactor(*KEYS, PIM)
    ours = F.combined_imu(*KEYS, OURS)
    e_g = g.unwhitenedError(vals)
    e_o, J_o = F.combined_imu_residual(*state, OURS)
    assert np.abs(e_o - e_g).max() <= 1e-6 * np.abs(e_g).max()
    assert np.abs(ours.unwhitenedError(vals) - e_g).max() <= 1e-6 * np.abs(e_g).max()
    assert abs(ours.error(vals) - g.error(vals)) <= 1e-6 * g.error(vals)
    _, J_g = _gtsam_unwhitened(g, vals)
    for k, (a, b) in enumerate(zip(J_o, J_g, strict=True)):
        tol = 1e-5 if k == 4 else 1e-6
        assert np.abs(a - b).max() <= tol * max(np.abs(b).max(), 1.0), k


def test_jacobians_match_finite_differences() -> None:
    T_i, v_i, T_j, v_j, b_i, b_j = _random_state(11)
    _, J = F.combined_imu_residual(T_i, v_i, T_j, v_j, b_i, b_j, OURS)

    def err(**kw):
        args = {"pose_i": T_i, "vel_i": v_i, "pose_j": T_j, "vel_j": v_j, "bias_i": b_i,
                "bias_j": b_j, **kw}  # fmt: skip
        return F.combined_imu_residual(**args, pim=OURS, jacobians=False)[0]

    def pose_retract(T, d):  # GTSAM's Pose3 chart: right perturbation, (ω, v)
        return T @ se3.exp(d)

    cases = [
        (0, T_i, "pose_i", pose_retract),
        (1, v_i, "vel_i", None),
        (2, T_j, "pose_j", pose_retract),
        (3, v_j, "vel_j", None),
        (4, b_i, "bias_i", None),
        (5, b_j, "bias_j", None),
    ]
    for k, x, name, retract in cases:
        num = numerical_jacobian(
            lambda y, name=name: err(**{name: y}), x, retract=retract, out_local="euclidean"
        )
        assert np.abs(J[k] - num).max() <= 1e-6 * max(np.abs(num).max(), 1.0), name


def test_noise_model_is_residual_covariance_and_bad_input() -> None:
    f = F.combined_imu(*KEYS, OURS)
    R = f.noiseModel().R()
    C = np.linalg.inv(R.T @ R)
    G = PIM.residualCovariance()
    assert np.abs(C - G).max() <= 1e-9 * np.abs(G).max()
    with pytest.raises(ValueError, match="bias_j: the same key as pose_i"):
        F.combined_imu(1, 2, 3, 4, 5, 1, OURS)
    with pytest.raises(TypeError, match="PreintegratedCombined"):
        F.combined_imu(*KEYS, F.preintegrate(ACC[:10], GYRO[:10], DT[:10], bias=BIAS,
                                             params=combined_params()))  # fmt: skip
