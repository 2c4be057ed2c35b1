"""Navigation state (pose + world velocity) exported as nav_msgs/Odometry: Monte Carlo, GTSAM."""

from __future__ import annotations

from pathlib import Path

import gtsam
import numpy as np
import pytest

pytest.importorskip("rosbags")

from liebridge import ros
from liebridge.conventions import convert_covariance
from liebridge.lie import se3, so3


def _state(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    T = se3.exp(np.array([0.7, -0.4, 1.1, 3.0, -1.0, 2.0]))
    v_w = np.array([2.0, -1.0, 0.5])
    A = rng.normal(size=(9, 9))
    S = (A @ A.T + np.eye(9)) * 1e-5  # strongly correlated pose/velocity errors, small
    return T, v_w, S


def test_navstate_odometry_monte_carlo() -> None:
    rng = np.random.default_rng(2)
    T, v_w, S = _state(rng)
    omega, omega_cov = np.array([0.1, -0.2, 0.3]), np.diag([1e-4, 2e-4, 3e-4])
    msgs, dropped = ros.odometry_from_navstate(
        T[None], v_w[None], S[None], omega[None], omega_cov[None], stamps=[1.0]
    )
    assert msgs.twist_linear_angular is not None and msgs.twist_covariance is not None
    assert msgs.pose_covariance is not None
    np.testing.assert_allclose(msgs.twist_linear_angular[0, :3], T[:3, :3].T @ v_w, atol=1e-15)
    np.testing.assert_allclose(msgs.twist_linear_angular[0, 3:], omega, atol=0)

    n = 200_000
    d = rng.multivariate_normal(np.zeros(9), S, size=n)
    Ts = T @ se3.exp(d[:, :6])  # GTSAM's perturbation of the pose
    vs = v_w + d[:, 6:]
    vb = np.einsum("nji,nj->ni", Ts[:, :3, :3], vs)  # Rᵀ v in the child frame
    u = Ts[:, :3, 3] - T[:3, 3]  # ROS pose error: parent-frame position, fixed-axis rotation
    w = so3.log(Ts[:, :3, :3] @ T[:3, :3].T)
    emp = np.cov(np.c_[u, w, vb].T)
    scale = np.abs(emp).max()
    tol = 6 * np.sqrt(2 / n) * scale + 2e-3 * scale  # sampling + second-order terms
    cov_ros = msgs.pose_covariance[0].reshape(6, 6)
    assert np.abs(emp[:6, :6] - cov_ros).max() < tol
    assert np.abs(emp[6:, 6:] - msgs.twist_covariance[0].reshape(6, 6)[:3, :3]).max() < tol
    assert np.abs(emp[:6, 6:] - dropped.cov_pose_twist[0][:, :3]).max() < tol
    assert np.abs(emp[:6, 6:]).max() > 10 * tol  # the dropped part is real
    # the rotation error enters the child-frame velocity: Rᵀ Σ_vv R alone is measurably wrong
    naive = T[:3, :3].T @ S[6:, 6:] @ T[:3, :3]
    assert np.abs(emp[6:, 6:] - naive).max() > 3 * tol
    assert 0.1 < dropped.max_abs_correlation[0] <= 1.0


def test_navstate_from_gtsam_imu_graph(tmp_path: Path) -> None:
    """Two states linked by an ImuFactor: correlated pose/velocity marginals from GTSAM."""
    X = gtsam.symbol_shorthand.X
    V = gtsam.symbol_shorthand.V
    B = gtsam.symbol_shorthand.B
    params = gtsam.PreintegrationParams.MakeSharedU(9.81)
    params.setAccelerometerCovariance(np.eye(3) * 1e-3)
    params.setGyroscopeCovariance(np.eye(3) * 1e-4)
    params.setIntegrationCovariance(np.eye(3) * 1e-8)
    pim = gtsam.PreintegratedImuMeasurements(params, gtsam.imuBias.ConstantBias())
    for _ in range(100):
        pim.integrateMeasurement(np.array([0.5, 0.0, 9.81]), np.array([0.0, 0.0, 0.2]), 0.01)
    graph = gtsam.NonlinearFactorGraph()
    graph.add(
        gtsam.PriorFactorPose3(X(0), gtsam.Pose3(), gtsam.noiseModel.Isotropic.Sigma(6, 0.01))
    )
    graph.add(
        gtsam.PriorFactorVector(
            V(0), np.array([1.0, 0, 0]), gtsam.noiseModel.Isotropic.Sigma(3, 0.1)
        )
    )
    graph.add(
        gtsam.PriorFactorConstantBias(
            B(0), gtsam.imuBias.ConstantBias(), gtsam.noiseModel.Isotropic.Sigma(6, 0.01)
        )
    )
    graph.add(gtsam.ImuFactor(X(0), V(0), X(1), V(1), B(0), pim))
    init = gtsam.Values()
    init.insert(X(0), gtsam.Pose3())
    init.insert(V(0), np.array([1.0, 0, 0]))
    init.insert(B(0), gtsam.imuBias.ConstantBias())
    nav = pim.predict(
        gtsam.NavState(gtsam.Pose3(), np.array([1.0, 0, 0])), gtsam.imuBias.ConstantBias()
    )
    init.insert(X(1), nav.pose())
    init.insert(V(1), nav.velocity())
    result = gtsam.LevenbergMarquardtOptimizer(graph, init).optimize()
    omega, omega_cov = np.array([[0.0, 0.0, 0.2]] * 2), np.tile(np.eye(3) * 1e-4, (2, 1, 1))
    msgs, dropped = ros.odometry_from_gtsam(
        graph,
        result,
        [X(0), X(1)],
        [V(0), V(1)],
        omega,
        omega_cov,
        stamps=[0.0, 1.0],
        frame_id="odom",
    )
    m = gtsam.Marginals(graph, result)
    S1 = m.jointMarginalCovariance([X(1), V(1)]).fullMatrix()
    T1 = result.atPose3(X(1)).matrix()
    assert msgs.cov is not None
    np.testing.assert_allclose(
        msgs.cov[1], convert_covariance(S1[:6, :6], T1, "gtsam", "ros"), atol=1e-12
    )
    assert dropped.max_abs_correlation[1] > 0.05  # the ImuFactor couples them
    p = ros.write_messages(tmp_path / "nav.bag", "/nav", msgs)
    back = ros.read_messages(p, "/nav")
    assert back.twist is not None and msgs.twist is not None
    assert np.array_equal(back.twist, msgs.twist)
