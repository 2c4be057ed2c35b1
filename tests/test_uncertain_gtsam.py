"""liebridge.gtsam.uncertain: GTSAM marginals in, relative pose covariance out, checked by
Monte Carlo and against GTSAM's own between-Jacobian propagation of the joint marginal."""

from __future__ import annotations

import gtsam
import numpy as np
import pytest

from liebridge import check
from liebridge import uncertain as u
from liebridge.conventions import convert_covariance
from liebridge.gtsam.uncertain import joint_marginal, marginal, to_gtsam


@pytest.fixture(scope="module")
def chain() -> tuple[gtsam.Marginals, gtsam.Values]:
    """A short synthetic chain with a loop closure (correlated, non-trivial marginals)."""
    rng = np.random.default_rng(5)
    graph = gtsam.NonlinearFactorGraph()
    noise = gtsam.noiseModel.Diagonal.Sigmas(np.r_[0.02, 0.02, 0.05, 0.1, 0.1, 0.05])
    graph.add(gtsam.PriorFactorPose3(0, gtsam.Pose3(), gtsam.noiseModel.Isotropic.Sigma(6, 1e-3)))
    values = gtsam.Values()
    values.insert(0, gtsam.Pose3())
    X = gtsam.Pose3()
    for k in range(1, 8):
        step = gtsam.Pose3(gtsam.Rot3.Rodrigues(*(0.3 * rng.normal(size=3))), gtsam.Point3(1, 0, 0))
        graph.add(gtsam.BetweenFactorPose3(k - 1, k, step, noise))
        X = X.compose(step)
        values.insert(k, X)
    graph.add(gtsam.BetweenFactorPose3(0, 7, values.atPose3(7), noise))
    res = gtsam.LevenbergMarquardtOptimizer(graph, values).optimize()
    return gtsam.Marginals(graph, res), res


@pytest.mark.parametrize("name", ["gtsam", "ros", "sophus", "barfoot", "symforce"])
def test_relative_from_joint_marginal(chain: tuple, name: str) -> None:
    marg, values = chain
    A, B, cross = joint_marginal(marg, values, 2, 6, name)
    ours = u.relative(A, B, cross)
    mc = check.monte_carlo_relative(A, B, cross, n=60000).cov
    assert np.linalg.norm(ours.cov - mc) / np.linalg.norm(mc) < 0.02
    # GTSAM's own between Jacobians on its own joint marginal, converted afterwards
    jm = marg.jointMarginalCovariance(gtsam.KeyVector([2, 6]))
    joint = np.block([[jm.at(2, 2), jm.at(2, 6)], [jm.at(6, 2), jm.at(6, 6)]])
    H1, H2 = np.zeros((6, 6), order="F"), np.zeros((6, 6), order="F")
    C = values.atPose3(2).between(values.atPose3(6), H1, H2).matrix()
    H = np.hstack([H1, H2])
    want = convert_covariance(H @ joint @ H.T, C, "gtsam", name)
    np.testing.assert_allclose(ours.cov, want, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(ours.T, C, atol=1e-12)


def test_marginal_and_to_gtsam(chain: tuple) -> None:
    marg, values = chain
    A = marginal(marg, values, 4, "ros")
    np.testing.assert_allclose(A.gtsam_cov(), marg.marginalCovariance(4), rtol=1e-9, atol=1e-15)
    pose, cov = to_gtsam(A)
    assert isinstance(pose, gtsam.Pose3)
    np.testing.assert_allclose(pose.matrix(), values.atPose3(4).matrix(), atol=1e-12)
    np.testing.assert_allclose(cov, marg.marginalCovariance(4), rtol=1e-9, atol=1e-15)
    gtsam.noiseModel.Gaussian.Covariance(cov)  # accepted by GTSAM
    with pytest.raises(ValueError, match="key_b: the same key"):
        joint_marginal(marg, values, 4, 4)
    with pytest.raises(ValueError, match="no Pose3 at key 99"):
        marginal(marg, values, 99)
