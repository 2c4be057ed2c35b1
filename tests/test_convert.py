"""Conversion core: Monte Carlo, round trips, exact linearity, Jacobians, unscented."""

import numpy as np
import pytest

import liebridge as lb
from liebridge import conventions as C
from liebridge.check import numerical_jacobian
from liebridge.lie import se3

PRESETS = list(C.PRESETS)


def pose(seed, trans=5.0):
    rng = np.random.default_rng(seed)
    return se3.exp(np.r_[rng.uniform(-1.5, 1.5, 3), rng.uniform(-trans, trans, 3)])


def random_cov(seed, scale=1e-3, n=6):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    return scale * (A @ A.T / n + 0.1 * np.eye(n))


def sample_cov(cov, X, src, dst, n=40000, seed=0):
    rng = np.random.default_rng(seed)
    d = rng.multivariate_normal(np.zeros(len(cov)), cov, size=n)
    y = dst.local(X, src.retract(X, d))
    return np.cov(y.T)


@pytest.mark.parametrize("src", PRESETS, ids=lambda c: c.name)
@pytest.mark.parametrize(
    "dst", [C.GTSAM, C.BARFOOT, C.SYMFORCE, C.G2O, C.ROS], ids=lambda c: c.name
)
def test_monte_carlo_covariance(src, dst):
    X = pose(1)
    cov = random_cov(2)
    emp = sample_cov(cov, X, src, dst)
    lin = lb.convert_covariance(cov, X, src, dst)
    # 40k samples: relative sampling error of a covariance entry ~ sqrt(2/n) ≈ 0.7 %; first-order
    # (nonlinear-chart) error ~ σ ≈ 3 %·|t| of the scale. Compare in the whitened metric.
    L = np.linalg.cholesky(lin)
    Li = np.linalg.inv(L)
    dev = np.abs(Li @ emp @ Li.T - np.eye(6)).max()
    assert dev < 0.05 if lb.is_exactly_linear(src, dst) else dev < 0.15


def test_unscented_beats_linear_for_large_covariance_across_nonlinear_chart():
    X = pose(3, trans=10.0)
    cov = np.diag([0.3, 0.3, 0.3, 1.0, 1.0, 1.0]) ** 2  # ~17° rotation σ, 1 m translation σ
    # the V(ω)·v coupling is bilinear: the 2n-point UT misses it, the degree-5 rule does not
    src, dst = C.GTSAM, C.SYMFORCE  # se3 → so3xr3_world: not linear
    assert not lb.is_exactly_linear(src, dst)
    emp = sample_cov(cov, X, src, dst, n=200000, seed=4)
    lin = lb.convert_covariance(cov, X, src, dst, method="linear")
    ut = lb.convert_covariance(cov, X, src, dst, method="unscented")
    err_lin = np.linalg.norm(lin - emp) / np.linalg.norm(emp)
    err_ut = np.linalg.norm(ut - emp) / np.linalg.norm(emp)
    assert err_ut < 0.5 * err_lin, (err_ut, err_lin)


def test_unscented_equals_linear_when_exactly_linear():
    X = pose(5)
    cov = random_cov(6, scale=0.05)
    for dst in [C.SOPHUS, C.BARFOOT, C.PYTRANSFORM3D_GLOBAL]:
        np.testing.assert_allclose(
            lb.convert_covariance(cov, X, C.GTSAM, dst, method="unscented"),
            lb.convert_covariance(cov, X, C.GTSAM, dst),
            atol=1e-12,
        )


@pytest.mark.parametrize("src", PRESETS, ids=lambda c: c.name)
def test_round_trips_are_identity(src):
    X = pose(7)
    dst = C.BARFOOT if src is not C.BARFOOT else C.G2O
    cov = random_cov(8)
    back = lb.convert_covariance(lb.convert_covariance(cov, X, src, dst), X, dst, src)
    np.testing.assert_allclose(back, cov, atol=1e-14)
    info = np.linalg.inv(cov)
    back = lb.convert_information(lb.convert_information(info, X, src, dst), X, dst, src)
    np.testing.assert_allclose(back, info, rtol=1e-10, atol=1e-8)
    d = np.array([0.01, -0.02, 0.03, 0.1, 0.2, -0.3])
    back = lb.convert_tangent(lb.convert_tangent(d, X, src, dst), X, dst, src)
    np.testing.assert_allclose(back, d, atol=1e-12)
    J = np.random.default_rng(9).normal(size=(6, 6))
    Jb = lb.convert_jacobian(
        lb.convert_jacobian(J, X, src, dst, at_output=X),
        X,
        dst,
        src,
        at_output=X,
    )
    np.testing.assert_allclose(Jb, J, atol=1e-11)


def test_information_is_inverse_of_covariance():
    X = pose(10)
    cov = random_cov(11)
    for dst in PRESETS:
        np.testing.assert_allclose(
            lb.convert_information(np.linalg.inv(cov), X, "gtsam", dst),
            np.linalg.inv(lb.convert_covariance(cov, X, "gtsam", dst)),
            rtol=1e-8,
            atol=1e-6,
        )


def test_information_rank_deficient_is_fine():
    X = pose(12)
    info = np.diag([0, 0, 0, 1.0, 2.0, 3.0])
    out = lb.convert_information(info, X, "gtsam", "sophus")
    np.testing.assert_allclose(out, np.diag([1.0, 2.0, 3.0, 0, 0, 0]), atol=1e-15)


@pytest.mark.parametrize(
    "src,dst",
    [
        (C.GTSAM, C.BARFOOT),
        (C.SOPHUS, C.SYMFORCE),
        (C.G2O, C.CERES_POSE),
        (C.ROS, C.PYTRANSFORM3D_GLOBAL),
    ],
    ids=lambda c: c.name,
)
def test_exact_tangent_conversion_preserves_the_pose(src, dst):
    X = pose(13)
    d = np.array([0.2, -0.1, 0.3, 0.5, -0.4, 0.3])
    d2 = lb.convert_tangent(d, X, src, dst, exact=True)
    np.testing.assert_allclose(dst.retract(X, d2), src.retract(X, d), atol=1e-12)
    lin = lb.convert_tangent(d, X, src, dst, exact=False)
    if lb.is_exactly_linear(src, dst):
        np.testing.assert_allclose(lin, d2, atol=1e-12)
    else:
        assert np.abs(lin - d2).max() > 1e-6


def test_is_exactly_linear_claims_are_true():
    """Where is_exactly_linear says True, M·d equals the exact conversion for large d."""
    X = pose(14)
    # large but inside every chart's domain in either order (each half: ‖·‖ < 1, angle < π)
    d = np.array([0.5, -0.4, 0.3, 0.6, -0.5, 0.45])
    for src in PRESETS:
        for dst in PRESETS:
            exact = lb.convert_tangent(d, X, src, dst)
            lin = lb.convert_tangent(d, X, src, dst, exact=False)
            if lb.is_exactly_linear(src, dst):
                np.testing.assert_allclose(
                    lin, exact, atol=1e-11, err_msg=f"{src.name}->{dst.name}"
                )
            else:
                assert np.abs(lin - exact).max() > 1e-6, f"{src.name}->{dst.name}"


def test_convert_jacobian_of_composition():
    """J of f(X) = A·X·B (group output) in Barfoot's convention, from GTSAM's, against FD."""
    A, B = pose(15), pose(16)
    X = pose(17)

    def f(T):
        return A @ T @ B

    J_g = numerical_jacobian(f, X, retract=C.GTSAM.retract, local=C.GTSAM.local)
    J_b = numerical_jacobian(f, X, retract=C.BARFOOT.retract, local=C.BARFOOT.local)
    J_conv = lb.convert_jacobian(J_g, X, "gtsam", "barfoot", at_output=f(X))
    np.testing.assert_allclose(J_conv, J_b, atol=1e-7)

    # columns only: output a vector (the translation of f)
    def g(T):
        return f(T)[..., :3, 3]

    Jg = numerical_jacobian(g, X, retract=C.GTSAM.retract, out_local="euclidean")
    Js = numerical_jacobian(g, X, retract=C.SOPHUS.retract, out_local="euclidean")
    np.testing.assert_allclose(lb.convert_jacobian(Jg, X, "gtsam", "sophus"), Js, atol=1e-7)


def test_batched_conversions():
    rng = np.random.default_rng(18)
    X = se3.exp(rng.normal(size=(2, 3, 6)))
    cov = np.broadcast_to(random_cov(19), (2, 3, 6, 6))
    out = lb.convert_covariance(cov, X, "gtsam", "ros")
    for i in range(2):
        for j in range(3):
            np.testing.assert_allclose(
                out[i, j], lb.convert_covariance(cov[i, j], X[i, j], "gtsam", "ros")
            )
    ut = lb.convert_covariance(cov, X, "gtsam", "g2o", method="unscented")
    np.testing.assert_allclose(
        ut[1, 2],
        lb.convert_covariance(cov[1, 2], X[1, 2], "gtsam", "g2o", method="unscented"),
        atol=1e-15,
    )


@pytest.mark.parametrize(
    "call,match",
    [
        (
            lambda X: lb.convert_covariance(
                np.eye(6) + np.triu(np.ones((6, 6)), 1), X, "gtsam", "sophus"
            ),
            "not symmetric",
        ),
        (
            lambda X: lb.convert_covariance(-np.eye(6), X, "gtsam", "sophus"),
            "positive semi-definite",
        ),
        (lambda X: lb.convert_covariance(np.eye(5), X, "gtsam", "sophus"), r"\(\.\.\., 6, 6\)"),
        (lambda X: lb.tangent_map(X * 1.01, "gtsam", "sophus"), "not a rotation"),
        (lambda X: lb.tangent_map(X, "gtsam", "sopus"), "did you mean"),
        (lambda X: lb.convert_tangent(np.full(6, np.nan), X, "gtsam", "sophus"), "NaN"),
        (lambda X: lb.convert_covariance(np.eye(6), X, "gtsam", "sophus", method="mc"), "method"),
    ],
)
def test_bad_input_messages(call, match):
    with pytest.raises((ValueError, TypeError), match=match):
        call(pose(20))


def test_check_monte_carlo_covariance_is_a_reference_for_conversions():
    X = pose(21)
    cov = random_cov(22, scale=1e-4)
    emp = lb.check.monte_carlo_covariance(cov, X, "gtsam", "ros", n=40000)
    lin = lb.convert_covariance(cov, X, "gtsam", "ros")
    Li = np.linalg.inv(np.linalg.cholesky(lin))
    assert np.abs(Li @ emp @ Li.T - np.eye(6)).max() < 0.05  # 40k samples: ~1.5 % per entry
    with pytest.raises(ValueError, match="one pose"):
        lb.check.monte_carlo_covariance(cov, np.stack([X, X]), "gtsam", "ros")


def test_numerical_jacobian_convention_shorthand():
    A, X = pose(23), pose(24)

    def f(T):
        return A @ T

    J1 = lb.check.numerical_jacobian(f, X, in_convention="sophus", out_convention="barfoot")
    J2 = numerical_jacobian(f, X, retract=C.SOPHUS.retract, out_local=C.BARFOOT.local)
    np.testing.assert_array_equal(J1, J2)
    np.testing.assert_allclose(
        lb.convert_jacobian(J1, X, "sophus", "gtsam"),
        numerical_jacobian(f, X, retract=C.GTSAM.retract, out_local=C.BARFOOT.local),
        atol=1e-7,
    )


@pytest.mark.parametrize("n", [3, 6, 9])
def test_cubature_rule_reproduces_gaussian_moments_to_degree_five(n):
    """The unscented rule's own moments: a wrong weight (e.g. the centre's) fails here directly."""
    from liebridge.conventions.cubature import cubature_rule_5

    x, w = cubature_rule_5(n)
    assert x.shape == (2 * n * n + 1, n) and w.shape == (2 * n * n + 1,)
    assert np.sum(w) == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_allclose(np.einsum("k,ki->i", w, x), 0.0, atol=1e-14)
    np.testing.assert_allclose(np.einsum("k,ki,kj->ij", w, x, x), np.eye(n), atol=1e-13)
    # E[x_i x_j x_k] = 0 and the fifth moments vanish by symmetry; the fourth are Isserlis':
    # E[x_i⁴] = 3, E[x_i² x_j²] = 1 (i ≠ j), others 0
    m3 = np.einsum("k,ki,kj,kl->ijl", w, x, x, x)
    np.testing.assert_allclose(m3, 0.0, atol=1e-13)
    m4 = np.einsum("k,ki,kj,kl,km->ijlm", w, x, x, x, x)
    eye = np.eye(n)
    isserlis = (
        np.einsum("ij,lm->ijlm", eye, eye)
        + np.einsum("il,jm->ijlm", eye, eye)
        + np.einsum("im,jl->ijlm", eye, eye)
    )
    np.testing.assert_allclose(m4, isserlis, atol=1e-12)
    m5 = np.einsum("k,ki,kj,kl->ijl", w, x**3, x, x)
    np.testing.assert_allclose(m5, 0.0, atol=1e-12)


def test_monte_carlo_covariance_takes_cov_first_and_names_the_old_order():
    X, cov = pose(1), random_cov(2)
    with pytest.raises(TypeError, match=r"\(cov, X, src, dst\)"):
        lb.check.monte_carlo_covariance(X, cov, "gtsam", "ros")
