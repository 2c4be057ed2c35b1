"""Product states: a bundle of blocks (group conventions and plain vectors) is one convention.

A 15-dimensional navigation state (GTSAM's NavState chart + two biases) against the same state
in manif's SE_2(3) chart with the biases first; a pose + velocity + bias bundle in GTSAM's and in
Sophus's chart. Round trips, first-order maps against central differences, Monte Carlo of the
covariance conversions (linear and unscented), information and Jacobians, batching, bad input.
"""

from __future__ import annotations

import numpy as np
import pytest

import liebridge as lb
from liebridge.check import monte_carlo_covariance, numerical_jacobian
from liebridge.conventions import Bundle, Vector, get
from liebridge.lie import se3, se23

NAV_G = Bundle.of(
    "nav15_gtsam", [("nav", get("gtsam_navstate")), ("b_a", Vector(3)), ("b_g", Vector(3))]
)
NAV_M = Bundle.of(
    "nav15_manif_biases_first",
    [("nav", get("manif_se23")), ("b_a", Vector(3)), ("b_g", Vector(3))],
    order=[*range(9, 15), *range(9)],
)
POSE_G = Bundle.of("pose_vel_gtsam", [("T", get("gtsam")), ("v", Vector(3))])
POSE_S = Bundle.of(
    "pose_vel_sophus", [("T", get("sophus")), ("v", Vector(3))], order=[6, 7, 8, 0, 1, 2, 3, 4, 5]
)
PAIRS = [(NAV_G, NAV_M), (NAV_M, NAV_G), (POSE_G, POSE_S)]


def _element(b: Bundle, rng: np.random.Generator) -> np.ndarray:
    if b.blocks[0][0] == "nav":
        nav = se23.exp(np.r_[rng.uniform(-1, 1, 3), rng.uniform(-10, 10, 6)])
        return b.assemble(nav=nav, b_a=rng.normal(size=3) * 0.1, b_g=rng.normal(size=3) * 0.01)
    return b.assemble(
        T=se3.exp(np.r_[rng.uniform(-1, 1, 3), rng.uniform(-10, 10, 3)]), v=rng.normal(size=3)
    )


@pytest.mark.parametrize(("a", "b"), PAIRS, ids=lambda c: c.name)
def test_round_trip_maps_and_finite_differences(a: Bundle, b: Bundle) -> None:
    rng = np.random.default_rng(1)
    X = _element(a, rng)
    d = rng.normal(size=a.dim()) * 0.2
    np.testing.assert_allclose(a.local(X, a.retract(X, d)), d, atol=1e-10)
    M = numerical_jacobian(lambda Z: Z, X, retract=a.retract, local=b.local, dim=a.dim())
    np.testing.assert_allclose(lb.tangent_map(X, a, b), M, atol=1e-6 * max(1, np.abs(X).max()))
    np.testing.assert_allclose(a.to_canonical(X) @ a.from_canonical(X), np.eye(a.dim()), atol=1e-10)
    Y = a.retract(X, rng.normal(size=a.dim()) * 0.3)
    J = numerical_jacobian(
        lambda Z: Z, Y, retract=a.retract, local=lambda _y, Z: a.local(X, Z), dim=a.dim()
    )
    np.testing.assert_allclose(a.local_jacobian(X, Y), J, atol=1e-6 * max(1, np.abs(X).max()))
    split = a.split(X)
    np.testing.assert_allclose(a.assemble(**split), X)


@pytest.mark.parametrize(("a", "b"), PAIRS, ids=lambda c: c.name)
def test_covariance_information_jacobian(a: Bundle, b: Bundle) -> None:
    rng = np.random.default_rng(2)
    X = _element(a, rng)
    Q = rng.normal(size=(a.dim(), a.dim())) * 0.05
    S = Q @ Q.T + 1e-4 * np.eye(a.dim())
    mc = monte_carlo_covariance(S, X, a, b, n=200_000, rng=np.random.default_rng(3))
    lin = lb.convert_covariance(S, X, a, b)
    uns = lb.convert_covariance(S, X, a, b, method="unscented")
    scale = np.abs(mc).max()
    np.testing.assert_allclose(uns, mc, atol=0.02 * scale)
    np.testing.assert_allclose(lin, mc, atol=0.03 * scale)
    if lb.is_exactly_linear(a, b):
        np.testing.assert_allclose(lin, uns, atol=1e-10 * scale)
    info = lb.convert_information(np.linalg.inv(S), X, a, b)
    np.testing.assert_allclose(info @ lin, np.eye(a.dim()), atol=1e-7)
    J = rng.normal(size=(2, a.dim()))
    Jb = lb.convert_jacobian(J, X, a, b)
    np.testing.assert_allclose(Jb @ lb.tangent_map(X, a, b), J, atol=1e-10)


def test_exactly_linear_bundle_and_batching() -> None:
    assert lb.is_exactly_linear(POSE_G, POSE_S)
    assert not lb.is_exactly_linear(NAV_G, NAV_M)
    rng = np.random.default_rng(4)
    X = np.stack([_element(POSE_G, rng) for _ in range(4)])
    d = rng.normal(size=(4, 9)) * 0.3
    exact = lb.convert_tangent(d, X, POSE_G, POSE_S)
    np.testing.assert_allclose(
        exact, lb.convert_tangent(d, X, POSE_G, POSE_S, exact=False), atol=1e-10
    )
    T = lb.tangent_map(X, POSE_G, POSE_S)
    for i in range(4):
        np.testing.assert_allclose(T[i], lb.tangent_map(X[i], POSE_G, POSE_S), atol=1e-14)


def test_bad_input() -> None:
    rng = np.random.default_rng(5)
    X = _element(NAV_G, rng)
    bad = X.copy()
    bad[0, 7] = 1.0
    with pytest.raises(ValueError, match="off its diagonal blocks"):
        NAV_G.retract(bad, np.zeros(15))
    bad = X.copy()
    bad[0, 0] = 2.0
    with pytest.raises(ValueError, match=r"X \(block 'nav'\): not a rotation"):
        lb.convert_covariance(np.eye(15), bad, NAV_G, NAV_M)
    with pytest.raises(ValueError, match="different groups"):
        lb.tangent_map(X, NAV_G, POSE_G)
    with pytest.raises(ValueError, match=r"cov: expected shape \(\.\.\., 15, 15\)"):
        lb.convert_covariance(np.eye(9), X, NAV_G, NAV_M)
    with pytest.raises(ValueError, match="missing"):
        NAV_G.assemble(nav=np.eye(5))
    with pytest.raises(ValueError, match="permutation"):
        Bundle.of("x", [("v", Vector(3))], order=[0, 0, 1])
