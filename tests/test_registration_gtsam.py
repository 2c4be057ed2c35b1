"""Registration results as GTSAM factors: direction, order, side and scale, measured in GTSAM.

The reference is the Gauss–Newton Hessian of the registration cost ``½Σ‖X_t⁻¹X_s·p − q‖²/σ²``
with respect to both poses, by central differences through ``gtsam.Pose3.retract``; the factor's
own linearisation (``BetweenFactorPose3.linearize(...).information()``) must equal it.
"""

from __future__ import annotations

import gtsam
import numpy as np
import pytest

from liebridge import registration as reg
from liebridge import uncertain
from liebridge.gtsam import registration_factor
from liebridge.lie import se3

T_TS = se3.exp(np.array([0.4, -0.7, 1.1, 3.0, -2.0, 30.0]))
X_T = se3.exp(np.array([-0.2, 0.3, 0.9, 10.0, 5.0, -1.0]))  # T_world_target


def _scene(n: int = 60, seed: int = 0, noise: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    p = rng.uniform(-5.0, 5.0, size=(n, 3))
    q = p @ T_TS[:3, :3].T + T_TS[:3, 3] + noise * rng.normal(size=(n, 3))
    return p, q


def fd_hessian(p: np.ndarray, q: np.ndarray, sigma: float, h: float = 1e-6) -> np.ndarray:
    """12×12 GN Hessian over (δ_target, δ_source), each through ``Pose3.retract``."""
    Xt, Xs = gtsam.Pose3(X_T), gtsam.Pose3(X_T @ T_TS)

    def resid(dt: np.ndarray, ds: np.ndarray) -> np.ndarray:
        A = Xt.retract(dt).inverse().compose(Xs.retract(ds)).matrix()
        return (p @ A[:3, :3].T + A[:3, 3] - q).reshape(-1)

    cols = []
    for k in range(12):
        d = np.zeros(12)
        d[k] = h
        cols.append((resid(d[:6], d[6:]) - resid(-d[:6], -d[6:])) / (2 * h))
    J = np.stack(cols, axis=1)
    return J.T @ J / sigma**2


def factor_hessian(factor: gtsam.BetweenFactorPose3) -> np.ndarray:
    v = gtsam.Values()
    v.insert(factor.keys()[0], gtsam.Pose3(X_T))
    v.insert(factor.keys()[1], gtsam.Pose3(X_T @ T_TS))
    return np.asarray(factor.linearize(v).information())


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


@pytest.mark.parametrize("conv", ["open3d", "small_gicp", "kiss_icp", "hdl_graph_slam", "ros"])
def test_factor_equals_the_registration_hessian_from_any_convention(conv: str) -> None:
    p, q = _scene()
    est = reg.information(T_TS, p, q, sigma=0.01, convention=conv)
    f = registration_factor(1, 2, est)
    assert isinstance(f, gtsam.BetweenFactorPose3)
    assert _rel(factor_hessian(f), fd_hessian(p, q, 0.01)) < 1e-6


def test_open3d_matrix_copied_as_information_or_keys_swapped_is_wrong() -> None:
    p, q = _scene()
    want = fd_hessian(p, q, 0.01)
    o3d = reg.information(T_TS, p, q, sigma=1.0, convention="open3d").information
    right = registration_factor(1, 2, reg.from_open3d(o3d, T_TS, sigma=0.01))
    assert _rel(factor_hessian(right), want) < 1e-6
    pair = registration_factor(1, 2, (T_TS, o3d), sigma=0.01, convention="open3d")
    assert _rel(factor_hessian(pair), want) < 1e-6
    copied = registration_factor(1, 2, (T_TS, o3d), sigma=0.01, convention="gtsam")
    assert _rel(factor_hessian(copied), want) > 0.1
    swapped = registration_factor(2, 1, reg.from_open3d(o3d, T_TS, sigma=0.01))
    v = gtsam.Values()
    v.insert(1, gtsam.Pose3(X_T))
    v.insert(2, gtsam.Pose3(X_T @ T_TS))
    assert swapped.error(v) > 1e3 and right.error(v) < 1e-9


def test_small_gicp_pair_is_gtsam_information_as_it_is() -> None:
    p, q = _scene()
    H = reg.information(T_TS, p, q, sigma=1.0, convention="small_gicp").information
    f = registration_factor(1, 2, (T_TS, H), sigma=0.01, convention="small_gicp")
    assert _rel(factor_hessian(f), fd_hessian(p, q, 0.01)) < 1e-6


def test_loop_closure_composes_with_odometry_in_the_uncertain_algebra() -> None:
    """T_w_s = T_w_t · T_t_s: liebridge's compose equals GTSAM's marginal of the two factors."""
    p, q = _scene()
    loop = reg.information(T_TS, p, q, sigma=0.01, convention="kiss_icp")
    odo = uncertain.UncertainPose(X_T, np.diag([1e-4] * 3 + [1e-2] * 3), "gtsam")
    composed = uncertain.compose(odo, loop.to("gtsam"))
    g = gtsam.NonlinearFactorGraph()
    g.add(
        gtsam.PriorFactorPose3(1, gtsam.Pose3(X_T), gtsam.noiseModel.Gaussian.Covariance(odo.cov))
    )
    g.add(registration_factor(1, 2, loop))
    v = gtsam.Values()
    v.insert(1, gtsam.Pose3(X_T))
    v.insert(2, gtsam.Pose3(X_T @ T_TS))
    cov = gtsam.Marginals(g, v).marginalCovariance(2)
    np.testing.assert_allclose(composed.T, X_T @ T_TS, atol=1e-9)
    assert _rel(composed.cov, cov) < 1e-6


def test_bad_arguments() -> None:
    p, q = _scene()
    est = reg.information(T_TS, p, q, sigma=0.01)
    with pytest.raises(ValueError, match="key_source: the same key"):
        registration_factor(3, 3, est)
    with pytest.raises(ValueError, match=r"convention: a \(T, H\) pair does not say"):
        registration_factor(1, 2, (T_TS, np.eye(6)))
    with pytest.raises(TypeError, match="from_open3d"):
        registration_factor(1, 2, object())
    with pytest.raises(ValueError, match="sigma: an UncertainPose already"):
        registration_factor(1, 2, est, sigma=0.1)
