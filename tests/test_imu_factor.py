"""liebridge.factors.imu against gtsam.ImuFactor (ImuFactorErrorMode.ComponentWise)."""

from __future__ import annotations

import gtsam
import numpy as np
import pytest

import liebridge.factors as F
from liebridge.lie import se3

ACC_SIGMA, GYRO_SIGMA = 0.01, 1.75e-4  # KittiEquivBiasedImu_metadata.txt


def _kitti(n: int):
    data = np.loadtxt(gtsam.findExampleDataFile("KittiEquivBiasedImu.txt"), skiprows=1)[2:]
    return data[:n, 2:5], data[:n, 5:8], data[:n, 1]


ACC, GYRO, DT = _kitti(300)
BIAS_HAT = gtsam.imuBias.ConstantBias(np.array([0.05, -0.03, 0.1]), np.array([2e-3, -1e-3, 3e-3]))


def make_params() -> gtsam.PreintegrationParams:
    p = gtsam.PreintegrationParams.MakeSharedU(9.8)
    p.setAccelerometerCovariance(ACC_SIGMA**2 * np.eye(3))
    p.setGyroscopeCovariance(GYRO_SIGMA**2 * np.eye(3))
    p.setIntegrationCovariance(1e-8 * np.eye(3))
    p.setImuFactorErrorMode(gtsam.ImuFactorErrorMode.ComponentWise)
    return p


PARAMS = make_params()


def integrate(cls):
    pim = cls(PARAMS, BIAS_HAT)
    for a, w, d in zip(ACC, GYRO, DT, strict=True):
        pim.integrateMeasurement(a, w, d)
    return pim


PIM_TANGENT = integrate(gtsam.PreintegratedImuMeasurements)  # the only one ImuFactor accepts
PIM_MANIFOLD = integrate(gtsam.PreintegratedImuMeasurementsManifold)
OURS = F.preintegrate(ACC, GYRO, DT, bias=BIAS_HAT, params=PARAMS)


def random_state(rng: np.random.Generator):
    pose_i = gtsam.Pose3(gtsam.Rot3.Expmap(rng.normal(size=3)), rng.normal(size=3) * 5)
    pose_j = gtsam.Pose3(gtsam.Rot3.Expmap(rng.normal(size=3)), rng.normal(size=3) * 5)
    return pose_i, rng.normal(size=3) * 3, pose_j, rng.normal(size=3) * 3


def random_bias(rng: np.random.Generator) -> gtsam.imuBias.ConstantBias:
    d = rng.normal(size=6) * [0.05, 0.05, 0.05, 0.01, 0.01, 0.01]
    return gtsam.imuBias.ConstantBias(
        BIAS_HAT.accelerometer() + d[:3], BIAS_HAT.gyroscope() + d[3:]
    )


def gtsam_factor_error(pim, pose_i, vel_i, pose_j, vel_j, bias):
    """GTSAM's ComponentWise ImuFactor error and Jacobians, composed from GTSAM calls only.

    PreintegrationBase::computeErrorAndJacobians: predict, then the component-wise local
    coordinates of the actual state j at the prediction; velocity columns map NavState's
    body-frame velocity tangent to the world-frame Vector3 tangent with Rᵀ.
    """
    si, sj = gtsam.NavState(pose_i, vel_i), gtsam.NavState(pose_j, vel_j)
    H1 = np.zeros((9, 9), order="F")
    H2 = np.zeros((9, 6), order="F")
    predicted = pim.predict(si, bias, H1, H2)
    Hj = np.zeros((9, 9), order="F")
    Hp = np.zeros((9, 9), order="F")
    e = sj.localCoordinates(predicted, Hj, Hp)
    Ri, Rj = pose_i.rotation().matrix(), pose_j.rotation().matrix()
    D = Hp @ H1
    return e, [D[:, :6], D[:, 6:] @ Ri.T, Hj[:, :6], Hj[:, 6:] @ Rj.T, Hp @ H2]


def native_error(factor, pose_i, vel_i, pose_j, vel_j, bias):
    H = [np.zeros((9, d), order="F") for d in (6, 3, 6, 3, 6)]
    e = factor.evaluateError(pose_i, vel_i, pose_j, vel_j, bias, *H)
    return e, H


def rel(a, b) -> float:
    a, b = np.asarray(a), np.asarray(b)
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


def test_wheel_navstate_chart_is_component_wise() -> None:
    """The GTSAM oracle below relies on NavState.localCoordinates being the ComponentWise chart."""
    s = gtsam.NavState(gtsam.Rot3.Expmap([0.3, 0.2, 0.1]), np.array([1.0, 2, 3]), np.ones(3))
    xi = np.array([0.1, 0.2, 0.3, 1, 2, 3, 4, 5, 6.0])
    R = s.attitude().matrix()
    r = s.retract(xi)
    assert np.allclose(r.position(), s.position() + R @ xi[3:6])
    assert np.allclose(r.velocity(), s.velocity() + R @ xi[6:9])


def test_oracle_reproduces_gtsam_imu_factor() -> None:
    factor = gtsam.ImuFactor(1, 2, 3, 4, 5, PIM_TANGENT)
    rng = np.random.default_rng(0)
    for _ in range(5):
        state = random_state(rng)
        bias = random_bias(rng)
        e_native, H_native = native_error(factor, *state, bias)
        e_oracle, H_oracle = gtsam_factor_error(PIM_TANGENT, *state, bias)
        assert rel(e_oracle, e_native) < 1e-12
        for a, b in zip(H_oracle, H_native, strict=True):
            assert rel(a, b) < 1e-12


def test_error_and_jacobians_equal_gtsam_component_wise_at_random_states() -> None:
    """Manifold preintegration (ours) vs GTSAM's ComponentWise ImuFactor math on GTSAM's manifold
    preintegration, at random poses, velocities and biases (bias ≠ bias_hat)."""
    rng = np.random.default_rng(1)
    worst = 0.0
    for _ in range(20):
        pose_i, vel_i, pose_j, vel_j = random_state(rng)
        bias = random_bias(rng)
        e_ref, H_ref = gtsam_factor_error(PIM_MANIFOLD, pose_i, vel_i, pose_j, vel_j, bias)
        e, H = F.imu_residual(pose_i.matrix(), vel_i, pose_j.matrix(), vel_j, bias, OURS)
        worst = max(worst, rel(e, e_ref))
        for a, b in zip(H, H_ref, strict=True):
            worst = max(worst, rel(a, b))
    assert worst < 1e-6
    assert worst < 1e-9  # what is actually achieved (rounding of 300 samples)


def test_equals_native_imu_factor_on_the_same_preintegration() -> None:
    """From GTSAM's own (tangent) preintegration, the custom factor equals gtsam.ImuFactor exactly
    where the two bias-correction rules coincide, at bias = bias_hat."""
    ours = F.PreintegratedImu.from_gtsam(PIM_TANGENT, PARAMS)
    native = gtsam.ImuFactor(1, 2, 3, 4, 5, PIM_TANGENT)
    custom = F.imu(1, 2, 3, 4, 5, ours)
    assert np.allclose(custom.noiseModel().covariance(), native.noiseModel().covariance())
    rng = np.random.default_rng(2)
    for _ in range(10):
        state = random_state(rng)
        e_native, H_native = native_error(native, *state, BIAS_HAT)
        e, H = F.imu_residual(
            state[0].matrix(), state[1], state[2].matrix(), state[3], BIAS_HAT, ours
        )
        assert rel(e, e_native) < 1e-12
        for a, b in zip(H, H_native, strict=True):
            assert rel(a, b) < 1e-10
        values = gtsam.Values()
        for key, value in zip((1, 2, 3, 4, 5), (*state, BIAS_HAT), strict=True):
            values.insert(key, value)
        assert abs(custom.error(values) - native.error(values)) <= 1e-9 * native.error(values)
        Ac, bc = custom.linearize(values).jacobian()
        An, bn = native.linearize(values).jacobian()
        assert rel(Ac, An) < 1e-9
        assert rel(bc, bn) < 1e-9


def _pose_retract(T: np.ndarray, d: np.ndarray) -> np.ndarray:
    return T @ se3.exp(d)  # GTSAM's Pose3 tangent: right, (ω, v)


def test_jacobians_equal_finite_differences_of_own_error() -> None:
    rng = np.random.default_rng(3)
    eps = 1e-6
    for _ in range(5):
        pose_i, vel_i, pose_j, vel_j = random_state(rng)
        args = [pose_i.matrix(), vel_i, pose_j.matrix(), vel_j, random_bias(rng).vector()]
        _, H = F.imu_residual(*args, OURS)
        for slot, dim in enumerate((6, 3, 6, 3, 6)):
            J = np.zeros((9, dim))
            for c in range(dim):
                d = np.zeros(dim)
                d[c] = eps
                plus, minus = list(args), list(args)
                if slot in (0, 2):
                    plus[slot] = _pose_retract(args[slot], d)
                    minus[slot] = _pose_retract(args[slot], -d)
                else:
                    plus[slot] = args[slot] + d
                    minus[slot] = args[slot] - d
                e_p, _ = F.imu_residual(*plus, OURS, jacobians=False)
                e_m, _ = F.imu_residual(*minus, OURS, jacobians=False)
                J[:, c] = (e_p - e_m) / (2 * eps)
            assert rel(H[slot], J) < 1e-6, slot
        # Pose3.retract on the GTSAM side is the same chart
        T = gtsam.Pose3(args[0]).retract(np.full(6, 0.1)).matrix()
        assert np.allclose(T, _pose_retract(args[0], np.full(6, 0.1)), atol=1e-12)


def test_predict_is_batched() -> None:
    rng = np.random.default_rng(8)
    states = [random_state(rng) for _ in range(3)]
    biases = np.array([random_bias(rng).vector() for _ in range(3)])
    Ti = np.array([s[0].matrix() for s in states])
    vi = np.array([s[1] for s in states])
    Tj, vj = OURS.predict(Ti, vi, biases)
    assert Tj.shape == (3, 4, 4) and vj.shape == (3, 3)
    for k in range(3):
        T1, v1 = OURS.predict(Ti[k], vi[k], biases[k])
        assert np.allclose(Tj[k], T1, atol=1e-12) and np.allclose(vj[k], v1, atol=1e-12)


def test_residual_is_batched() -> None:
    rng = np.random.default_rng(4)
    states = [random_state(rng) for _ in range(4)]
    biases = np.array([random_bias(rng).vector() for _ in range(4)])
    Ti = np.array([s[0].matrix() for s in states])
    Tj = np.array([s[2].matrix() for s in states])
    vi = np.array([s[1] for s in states])
    vj = np.array([s[3] for s in states])
    e, H = F.imu_residual(Ti, vi, Tj, vj, biases, OURS)
    assert e.shape == (4, 9)
    assert [h.shape for h in H] == [(4, 9, 6), (4, 9, 3), (4, 9, 6), (4, 9, 3), (4, 9, 6)]
    for k in range(4):
        e1, H1 = F.imu_residual(Ti[k], vi[k], Tj[k], vj[k], biases[k], OURS)
        assert np.allclose(e[k], e1, rtol=0, atol=1e-14)
        for a, b in zip(H, H1, strict=True):
            assert np.allclose(a[k], b, rtol=0, atol=1e-13)


def test_relation_to_forster_residual() -> None:
    """e = −blockdiag(I, R_jᵀR_i, R_jᵀR_i) r_Forster, as the module docstring says."""
    rng = np.random.default_rng(6)
    pose_i, vel_i, pose_j, vel_j = random_state(rng)
    bias = random_bias(rng)
    Ri, Rj = pose_i.rotation().matrix(), pose_j.rotation().matrix()
    pi, pj = pose_i.translation(), pose_j.translation()
    dR, dp, dv = OURS.bias_corrected(bias)
    T, g = OURS.delta_t, PARAMS.n_gravity
    r_R = gtsam.Rot3.Logmap(gtsam.Rot3(dR.T @ Ri.T @ Rj))
    r_v = Ri.T @ (vel_j - vel_i - g * T) - dv
    r_p = Ri.T @ (pj - pi - vel_i * T - 0.5 * g * T * T) - dp
    e, _ = F.imu_residual(pose_i.matrix(), vel_i, pose_j.matrix(), vel_j, bias, OURS)
    M = Rj.T @ Ri
    assert np.allclose(e[0:3], -r_R, atol=1e-12)
    assert np.allclose(e[3:6], -M @ r_p, atol=1e-9)
    assert np.allclose(e[6:9], -M @ r_v, atol=1e-12)


def test_zero_error_at_the_prediction() -> None:
    rng = np.random.default_rng(5)
    pose_i, vel_i, _, _ = random_state(rng)
    bias = random_bias(rng)
    T_j, v_j = OURS.predict(pose_i.matrix(), vel_i, bias)
    e, _ = F.imu_residual(pose_i.matrix(), vel_i, T_j, v_j, bias, OURS)
    assert np.abs(e).max() < 1e-12


def test_custom_factor_in_a_gtsam_optimizer() -> None:
    """Two keyframes, priors on i and on the bias: LM recovers the predicted state j."""
    key_pi, key_vi, key_pj, key_vj, key_b = 10, 11, 12, 13, 14
    pose_i = gtsam.Pose3(gtsam.Rot3.Ypr(0.3, -0.1, 0.2), np.array([1.0, 2.0, 3.0]))
    vel_i = np.array([2.0, -1.0, 0.5])
    T_j, v_j = OURS.predict(pose_i.matrix(), vel_i, BIAS_HAT)
    graph = gtsam.NonlinearFactorGraph()
    graph.add(F.imu(key_pi, key_vi, key_pj, key_vj, key_b, OURS))
    graph.add(gtsam.PriorFactorPose3(key_pi, pose_i, gtsam.noiseModel.Isotropic.Sigma(6, 1e-3)))
    graph.add(gtsam.PriorFactorVector(key_vi, vel_i, gtsam.noiseModel.Isotropic.Sigma(3, 1e-3)))
    graph.add(
        gtsam.PriorFactorConstantBias(key_b, BIAS_HAT, gtsam.noiseModel.Isotropic.Sigma(6, 1e-3))
    )
    initial = gtsam.Values()
    initial.insert(key_pi, pose_i.retract(np.full(6, 0.05)))
    initial.insert(key_vi, vel_i + 0.3)
    initial.insert(key_pj, gtsam.Pose3(T_j).retract(np.full(6, -0.1)))
    initial.insert(key_vj, v_j - 0.5)
    initial.insert(key_b, gtsam.imuBias.ConstantBias())
    result = gtsam.LevenbergMarquardtOptimizer(graph, initial).optimize()
    assert np.abs(result.atPose3(key_pj).matrix() - T_j).max() < 1e-6
    assert np.abs(result.atVector(key_vj) - v_j).max() < 1e-6
    assert graph.error(result) < 1e-8


def test_custom_factor_with_liebridge_optimize() -> None:
    """The same two-keyframe problem through liebridge.gtsam.optimize (no Values copies)."""
    key_pi, key_vi, key_pj, key_vj, key_b = 20, 21, 22, 23, 24
    pose_i = gtsam.Pose3(gtsam.Rot3.Ypr(-0.2, 0.1, 0.3), np.array([-1.0, 0.5, 2.0]))
    vel_i = np.array([1.0, 0.5, -0.2])
    T_j, v_j = OURS.predict(pose_i.matrix(), vel_i, BIAS_HAT)
    graph = gtsam.NonlinearFactorGraph()
    graph.add(F.imu(key_pi, key_vi, key_pj, key_vj, key_b, OURS))
    graph.add(gtsam.PriorFactorPose3(key_pi, pose_i, gtsam.noiseModel.Isotropic.Sigma(6, 1e-3)))
    graph.add(gtsam.PriorFactorVector(key_vi, vel_i, gtsam.noiseModel.Isotropic.Sigma(3, 1e-3)))
    graph.add(
        gtsam.PriorFactorConstantBias(key_b, BIAS_HAT, gtsam.noiseModel.Isotropic.Sigma(6, 1e-3))
    )
    initial = gtsam.Values()
    initial.insert(key_pi, pose_i)
    initial.insert(key_vi, vel_i)
    initial.insert(key_pj, gtsam.Pose3(T_j).retract(np.full(6, 0.1)))
    initial.insert(key_vj, v_j + 0.4)
    initial.insert(key_b, gtsam.imuBias.ConstantBias())
    result = F.optimize(graph, initial, progress=False)
    assert result.converged
    assert np.abs(result.values.atPose3(key_pj).matrix() - T_j).max() < 1e-6
    assert np.abs(result.values.atVector(key_vj) - v_j).max() < 1e-6
    reference = gtsam.LevenbergMarquardtOptimizer(graph, initial).optimize()
    assert abs(graph.error(result.values) - graph.error(reference)) < 1e-9


def test_bad_inputs() -> None:
    with pytest.raises(TypeError, match="preintegrated: expected a PreintegratedImu"):
        F.imu(1, 2, 3, 4, 5, PIM_MANIFOLD)
    with pytest.raises(TypeError, match="preintegrated: expected a PreintegratedImu"):
        F.imu_residual(np.eye(4), np.zeros(3), np.eye(4), np.zeros(3), np.zeros(6), PIM_TANGENT)
    bad = np.eye(4)
    bad[0, 0] = 2.0
    with pytest.raises(ValueError, match="pose_j: not a rotation"):
        F.imu_residual(np.eye(4), np.zeros(3), bad, np.zeros(3), np.zeros(6), OURS)
    with pytest.raises(ValueError, match=r"vel_i: expected shape \(\.\.\., 3\)"):
        F.imu_residual(np.eye(4), np.zeros(4), np.eye(4), np.zeros(3), np.zeros(6), OURS)
    with pytest.raises(ValueError, match=r"bias \(acc, gyro\): contains NaN or Inf at .*\(2,\)"):
        F.imu_residual(
            np.eye(4), np.zeros(3), np.eye(4), np.zeros(3), [0, 0, np.nan, 0, 0, 0], OURS
        )
