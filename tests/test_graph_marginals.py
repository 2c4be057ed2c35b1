"""GTSAM build self-check, marginals in any convention, ConventionGraph (issue acceptance)."""

import gtsam
import numpy as np
import pytest

import liebridge as lb
from liebridge import conventions as C
from liebridge.gtsam import build as gtsam_build
from liebridge.lie import se3


def test_installed_gtsam_is_measured_as_the_gtsam_preset():
    assert lb.gtsam_convention() is C.GTSAM
    assert gtsam_build.measure_pose3_convention(
        lambda X, d: gtsam.Pose3(X).retract(d).matrix()
    ) is (C.GTSAM)


def test_a_cayley_build_would_be_detected():
    """A GTSAM_POSE3_EXPMAP=OFF build's retraction: the glue must switch presets and say so."""
    with pytest.warns(UserWarning, match="Cayley"):
        assert gtsam_build.measure_pose3_convention(C.GTSAM_CAYLEY.retract) is C.GTSAM_CAYLEY


def chain(rng, n=4):
    T = [np.eye(4)]
    for _ in range(n - 1):
        T.append(T[-1] @ se3.exp(np.r_[rng.uniform(-0.5, 0.5, 3), rng.uniform(-2, 2, 3)]))
    return T


def dense_cov(rng, s):
    A = rng.normal(size=(6, 6))
    return s**2 * (A @ A.T / 6 + 0.3 * np.eye(6))


def build(conv, T, covs, loop_cov, prior_cov, measured=None):
    """A 4-pose chain with a loop closure 0→3, everything in ``conv``."""
    g = lb.ConventionGraph(conv)
    for k, Tk in enumerate(T):
        g.insert(k, Tk)
    g.add_prior(0, T[0], prior_cov)
    meas = measured or [se3.inverse(T[k]) @ T[k + 1] for k in range(len(T) - 1)] + [
        se3.inverse(T[0]) @ T[-1]
    ]
    for k in range(len(T) - 1):
        g.add_between(k, k + 1, meas[k], covs[k])
    g.add_between(0, len(T) - 1, meas[-1], loop_cov)
    return g


@pytest.mark.parametrize("conv", ["sophus", "barfoot"])
def test_convention_graph_matches_native_gtsam(conv):
    rng = np.random.default_rng(1)
    T = chain(rng)
    covs_g = [dense_cov(rng, 0.05) for _ in range(3)]
    loop_g, prior_g = dense_cov(rng, 0.1), np.eye(6) * 1e-6
    # perturbed measurements so the optimum is not the initial guess
    meas = [se3.inverse(T[k]) @ T[k + 1] @ se3.exp(rng.normal(0, 0.05, 6)) for k in range(3)]
    meas.append(se3.inverse(T[0]) @ T[3] @ se3.exp(rng.normal(0, 0.05, 6)))
    native = build("gtsam", T, covs_g, loop_g, prior_g, meas)
    native.optimize()
    to = lambda c, Z: lb.convert_covariance(c, Z, "gtsam", conv)  # noqa: E731
    ours = build(
        conv,
        T,
        [to(c, Z) for c, Z in zip(covs_g, meas, strict=False)],
        to(loop_g, meas[3]),
        to(prior_g, T[0]),
        meas,
    )
    ours.optimize()
    keys = [0, 1, 2, 3]
    np.testing.assert_allclose(ours.poses(keys), native.poses(keys), atol=1e-9)
    expected = lb.convert_covariance(
        native.marginal_covariances(keys), native.poses(keys), "gtsam", conv
    )
    np.testing.assert_allclose(ours.marginal_covariances(keys), expected, rtol=1e-6, atol=1e-12)
    # and the custom-factor variant of the same graph
    custom = lb.ConventionGraph(conv)
    for k, Tk in enumerate(T):
        custom.insert(k, Tk)
    custom.add_prior(0, T[0], to(prior_g, T[0]), native=False)
    for k in range(3):
        custom.add_between(k, k + 1, meas[k], to(covs_g[k], meas[k]), native=False)
    custom.add_between(0, 3, meas[3], to(loop_g, meas[3]), native=False)
    custom.optimize()
    np.testing.assert_allclose(custom.poses(keys), native.poses(keys), atol=1e-9)


@pytest.mark.parametrize("conv", ["sophus", "barfoot"])
def test_marginals_agree_with_monte_carlo_in_the_conventions_own_retraction(conv):
    """Sample measurement noise with the convention's retraction, re-solve, and compare the
    spread of the estimates (read with the convention's local map at the truth) with the
    converted GTSAM marginals. 400 solves: sampling error of a covariance ≈ √(2/400) = 7 %."""
    c = C.get(conv)
    rng = np.random.default_rng(2)
    T = chain(rng)
    covs = [dense_cov(rng, 0.02) for _ in range(3)]
    loop, prior_cov = dense_cov(rng, 0.03), dense_cov(rng, 0.01)
    truth_meas = [se3.inverse(T[k]) @ T[k + 1] for k in range(3)] + [se3.inverse(T[0]) @ T[3]]
    ref = build(conv, T, covs, loop, prior_cov)
    keys = [0, 1, 2, 3]
    marg = ref.marginal_covariances(keys)
    all_covs = [*covs, loop]
    samples = []
    for _ in range(400):
        # noisy measurement Z̃ = c.retract(Z, n), n ~ N(0, Σ): the residual c.local(Z̃, ·) then
        # has covariance Σ at the truth, exactly the model the factors state
        meas = [
            c.retract(Z, rng.multivariate_normal(np.zeros(6), S))
            for Z, S in zip(truth_meas, all_covs, strict=True)
        ]
        g = build(conv, T, covs, loop, prior_cov, meas)
        g.graph.add(
            lb.factors.prior(
                0, c.retract(T[0], rng.multivariate_normal(np.zeros(6), prior_cov)), prior_cov, conv
            )
        )
        g.graph.remove(0)  # replace the noiseless prior with the noisy one
        g.optimize(progress=False)
        samples.append([c.local(T[k], g.pose(k)) for k in keys])
    S = np.asarray(samples)
    for k in keys:
        emp = np.cov(S[:, k].T)
        L = np.linalg.cholesky(marg[k])
        Li = np.linalg.inv(L)
        assert np.abs(Li @ emp @ Li.T - np.eye(6)).max() < 0.3, (conv, k)


def test_wrapping_existing_graph_and_values():
    graph = gtsam.NonlinearFactorGraph()
    values = gtsam.Values()
    values.insert(7, gtsam.Pose3())
    graph.add(gtsam.PriorFactorPose3(7, gtsam.Pose3(), gtsam.noiseModel.Unit.Create(6)))
    g = lb.ConventionGraph("ros", graph=graph, values=values)
    assert g.graph is graph and g.values is values
    cov = g.marginal_covariance(7)
    np.testing.assert_allclose(cov, np.eye(6), atol=1e-12)  # ROS at identity: a permutation
    assert "ros" in repr(g)


def test_marginals_function_matches_gtsam_for_gtsam_convention():
    graph = gtsam.NonlinearFactorGraph()
    values = gtsam.Values()
    T = se3.exp(np.array([0.3, -0.2, 0.1, 1, 2, 3]))
    values.insert(1, gtsam.Pose3(T))
    cov = dense_cov(np.random.default_rng(3), 0.1)
    graph.add(gtsam.PriorFactorPose3(1, gtsam.Pose3(T), gtsam.noiseModel.Gaussian.Covariance(cov)))
    np.testing.assert_allclose(lb.marginals(graph, values, [1])[0], cov, rtol=1e-9)
    np.testing.assert_allclose(
        lb.marginals(graph, values, [1], "barfoot")[0],
        lb.convert_covariance(cov, T, "gtsam", "barfoot"),
        rtol=1e-9,
    )
