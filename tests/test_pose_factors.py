"""Between/prior factors in any convention: FD through GTSAM's retraction, GTSAM's own factors."""

import warnings

import gtsam
import numpy as np
import pytest

import liebridge as lb
from liebridge import conventions as C
from liebridge.gtsam.custom import make_custom_factor
from liebridge.gtsam.optimize import _SplitGraph
from liebridge.gtsam.pose_factors import between, prior
from liebridge.lie import se3


def pose(rng, angle=2.0, trans=20.0):
    return se3.exp(np.r_[rng.uniform(-angle, angle, 3), rng.uniform(-trans, trans, 3)])


def spd(rng, scale=0.01):
    A = rng.normal(size=(6, 6))
    return scale * (A @ A.T / 6 + 0.2 * np.eye(6))


def values_of(**poses):
    v = gtsam.Values()
    for k, T in poses.items():
        v.insert(int(k[1:]), gtsam.Pose3(T))
    return v


def fd_linearize(factor, values, keys, eps=1e-6):
    """Whitened Jacobians by central differences of whitenedError through Values.retract."""

    def shifted(k, d):
        dv = gtsam.VectorValues()
        for kk in keys:
            dv.insert(kk, d if kk == k else np.zeros(6))
        return factor.whitenedError(values.retract(dv))

    cols = {k: [] for k in keys}
    for k in keys:
        for c in range(6):
            d = np.zeros(6)
            d[c] = eps
            cols[k].append((shifted(k, d) - shifted(k, -d)) / (2 * eps))
    return [np.stack(cols[k], axis=1) for k in keys]


def analytic(factor, values):
    jf = factor.linearize(values)
    A, b = jf.jacobian()
    return A, b


def setup_between(seed, conv):
    rng = np.random.default_rng(seed)
    Ti, Tj = pose(rng), pose(rng)
    # a measurement near (not at) Ti⁻¹Tj so the residual is non-zero but inside every chart
    Z = conv.retract(se3.inverse(Ti) @ Tj, rng.uniform(-0.3, 0.3, 6))
    return Ti, Tj, Z, spd(rng)


@pytest.mark.parametrize("conv", C.PRESETS, ids=lambda c: c.name)
@pytest.mark.parametrize("seed", [0, 1])
def test_custom_between_jacobians_match_finite_differences(conv, seed):
    Ti, Tj, Z, cov = setup_between(seed, conv)
    f = between(1, 2, Z, cov, conv, native=False)
    vals = values_of(x1=Ti, x2=Tj)
    A, _ = analytic(f, vals)
    J1, J2 = fd_linearize(f, vals, [1, 2])
    # FD error ~ eps² × (third derivative) + rounding 1e-16/eps, scaled by √info ≈ 10–30
    np.testing.assert_allclose(A, np.hstack([J1, J2]), atol=2e-6)


@pytest.mark.parametrize("conv", C.PRESETS, ids=lambda c: c.name)
def test_custom_prior_jacobian_matches_finite_differences(conv):
    rng = np.random.default_rng(3)
    T = pose(rng)
    Z = conv.retract(T, rng.uniform(-0.3, 0.3, 6))
    f = prior(4, Z, spd(rng), conv, native=False)
    vals = values_of(x4=T)
    A, _ = analytic(f, vals)
    np.testing.assert_allclose(A, fd_linearize(f, vals, [4])[0], atol=2e-6)


@pytest.mark.parametrize("conv", C.PRESETS, ids=lambda c: c.name)
def test_custom_residual_is_the_conventions_local(conv):
    Ti, Tj, Z, cov = setup_between(4, conv)
    f = between(1, 2, Z, cov, conv, native=False)
    e = f.unwhitenedError(values_of(x1=Ti, x2=Tj))
    np.testing.assert_allclose(e, conv.local(Z, se3.inverse(Ti) @ Tj), atol=1e-12)


@pytest.mark.parametrize("seed", range(4))
def test_gtsam_convention_equals_gtsams_own_factors(seed):
    rng = np.random.default_rng(seed)
    Ti, Tj = pose(rng, angle=3.0), pose(rng, angle=3.0)
    Z = pose(rng, angle=3.0)  # large residuals on purpose
    cov = spd(rng)
    vals = values_of(x1=Ti, x2=Tj)
    noise = gtsam.noiseModel.Gaussian.Covariance(cov)
    ref = gtsam.BetweenFactorPose3(1, 2, gtsam.Pose3(Z), noise)
    ours = between(1, 2, Z, cov, "gtsam", native=False)
    assert ours.error(vals) == pytest.approx(ref.error(vals), rel=1e-9)
    A_ref, b_ref = ref.linearize(vals).jacobian()
    A, b = ours.linearize(vals).jacobian()
    np.testing.assert_allclose(A, A_ref, rtol=1e-9, atol=1e-9 * np.abs(A_ref).max())
    np.testing.assert_allclose(b, b_ref, rtol=1e-9, atol=1e-12)
    refp = gtsam.PriorFactorPose3(1, gtsam.Pose3(Z), noise)
    oursp = prior(1, Z, cov, "gtsam", native=False)
    assert oursp.error(vals) == pytest.approx(refp.error(vals), rel=1e-9)
    np.testing.assert_allclose(
        oursp.linearize(vals).jacobian()[0],
        refp.linearize(vals).jacobian()[0],
        rtol=1e-9,
        atol=1e-9,
    )


@pytest.mark.parametrize(
    "conv", [c for c in C.PRESETS if lb.is_exactly_linear(c, C.GTSAM)], ids=lambda c: c.name
)
def test_native_equals_custom_objective_when_exactly_linear(conv):
    Ti, Tj, Z, cov = setup_between(5, conv)
    vals = values_of(x1=Ti, x2=Tj)
    nat = between(1, 2, Z, cov, conv, native=True)
    cus = between(1, 2, Z, cov, conv, native=False)
    assert isinstance(nat, gtsam.BetweenFactorPose3)
    assert nat.error(vals) == pytest.approx(cus.error(vals), rel=1e-10)


def test_native_first_order_warns_once_under_the_default_filter():
    Z, cov = np.eye(4), np.eye(6) * 0.01
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("default")  # Python's own: once per message and call site
        for _ in range(3):
            between(1, 2, Z, cov, "g2o", native=True)
        between(1, 2, Z, cov, "sophus", native=True)  # exact: no warning
    assert len([x for x in w if "first-order" in str(x.message)]) == 1


def test_textbook_jacobian_differs_away_from_zero_residual():
    """(−Ad(H⁻¹), I) is what the exact Jacobian reduces to at zero residual only."""
    Ti, Tj, Z, cov = setup_between(6, C.GTSAM)
    vals = values_of(x1=Ti, x2=Tj)
    A, _ = between(1, 2, Z, cov, "gtsam", native=False).linearize(vals).jacobian()
    Rw = np.linalg.cholesky(np.linalg.inv(cov)).T
    H = se3.inverse(Ti) @ Tj
    textbook = Rw @ np.hstack([-se3.adjoint(se3.inverse(H)), np.eye(6)])
    assert np.abs(A - textbook).max() > 1e-2


@pytest.mark.parametrize(
    "conv", [C.GTSAM, C.BARFOOT, C.G2O, C.SYMFORCE, C.GTSAM_CAYLEY], ids=lambda c: c.name
)
def test_batched_linearization_equals_callbacks(conv):
    rng = np.random.default_rng(7)
    T = [pose(rng) for _ in range(5)]
    graph = gtsam.NonlinearFactorGraph()
    vals = gtsam.Values()
    for k, Tk in enumerate(T):
        vals.insert(k, gtsam.Pose3(Tk))
    graph.add(prior(0, conv.retract(T[0], rng.uniform(-0.2, 0.2, 6)), spd(rng), conv, native=False))
    for k in range(4):
        Z = conv.retract(se3.inverse(T[k]) @ T[k + 1], rng.uniform(-0.2, 0.2, 6))
        graph.add(between(k, k + 1, Z, spd(rng), conv, native=False))
    graph.add(gtsam.BetweenFactorPose3(0, 4, gtsam.Pose3(T[4]), gtsam.noiseModel.Unit.Create(6)))
    split = _SplitGraph(graph, vals, batch=True)
    assert split.n_batched == 5 and split.rest.size() == 1
    assert split.error(vals) == pytest.approx(graph.error(vals), rel=1e-12)
    ordering = gtsam.Ordering.ColamdNonlinearFactorGraph(graph)
    H_ref = graph.linearize(vals).hessian(ordering)
    H = split.linearize(vals).hessian(ordering)
    np.testing.assert_allclose(H[0], H_ref[0], rtol=1e-10, atol=1e-8)
    np.testing.assert_allclose(H[1], H_ref[1], rtol=1e-10, atol=1e-8)


def test_glue_reports_python_errors_clearly():
    def bad(values, want):
        raise ZeroDivisionError("boom")

    f = make_custom_factor(gtsam.noiseModel.Unit.Create(6), [1], [6], bad, name="mine")
    vals = values_of(x1=np.eye(4))
    with pytest.raises(Exception, match=r"mine on keys \[1\]: ZeroDivisionError: boom"):
        f.error(vals)


def test_glue_rejects_wrong_jacobian_shape():
    def wrong(values, want):
        return np.zeros(6), ([np.zeros((6, 5))] if want else None)

    f = make_custom_factor(gtsam.noiseModel.Unit.Create(6), [1], [6], wrong, name="shape")
    with pytest.raises(Exception, match=r"block 0 has shape \(6, 5\)"):
        f.linearize(values_of(x1=np.eye(4)))


def test_bad_inputs():
    with pytest.raises(ValueError, match="measured"):
        between(1, 2, np.eye(4) * 2, np.eye(6), "sophus")
    with pytest.raises(ValueError, match="positive semi-definite"):
        prior(1, np.eye(4), -np.eye(6), "sophus")
    with pytest.raises(ValueError, match="did you mean"):
        prior(1, np.eye(4), np.eye(6), "sohpus")
