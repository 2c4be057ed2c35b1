"""Between/prior factors in any convention: FD through GTSAM's retraction, GTSAM's own factors.

Also here (folded in from its twin file): Between/prior factors, marginals and ConventionGraph on
Pose2, Similarity3 and NavState.
"""

from __future__ import annotations

import warnings
from typing import Any

import gtsam
import hypothesis.strategies as st
import numpy as np
import pytest
from hypothesis import given, settings

import liebridge as lb
from liebridge import conventions as C
from liebridge.check import numerical_jacobian
from liebridge.conventions import GROUP_PRESETS, get
from liebridge.gtsam import ConventionGraph, between, marginals, prior
from liebridge.gtsam.custom import make_custom_factor
from liebridge.gtsam.glue import from_gtsam, to_gtsam, to_values
from liebridge.gtsam.optimize import _SplitGraph
from liebridge.lie import se2, se3, se23, sim3


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


# --------------------------------------------------------------------------- gtsam_factors_groups
# Between/prior factors, marginals and ConventionGraph on Pose2, Similarity3 and NavState.
#
# Measured against GTSAM itself: native factors against GTSAM's factors built by hand, custom
# factors in GTSAM's preset against GTSAM's factors (error and linearization), every custom
# Jacobian against central differences through **GTSAM's own** ``retract`` of the class, marginals
# against Monte Carlo of GTSAM's ``retract``, and optima on GTSAM's shipped 2-D datasets.

EXP = {"se2": se2.exp, "sim3": sim3.exp, "se23": se23.exp}
DIM = {"se2": 3, "sim3": 7, "se23": 9}
HUB = {"se2": "gtsam_pose2", "sim3": "gtsam_similarity3", "se23": "gtsam_navstate"}
NATIVE = {
    "se2": (gtsam.BetweenFactorPose2, gtsam.PriorFactorPose2),
    "sim3": (gtsam.BetweenFactorSimilarity3, gtsam.PriorFactorSimilarity3),
    "se23": (gtsam.BetweenFactorNavState, gtsam.PriorFactorNavState),
}
CONVS = [(c.group, c.name) for c in GROUP_PRESETS if c.group in EXP]
SE2_CONVS = [name for group, name in CONVS if group == "se2"]


def _rand(group: str, rng: np.random.Generator, scale: float = 1.0) -> Any:
    d = rng.normal(size=DIM[group]) * scale
    if group == "sim3":
        d[6] *= 0.3  # scales around e^±0.3
    return EXP[group](d)


def _gtsam_retract(group: str) -> Any:
    def retract(X: Any, d: Any) -> Any:
        X, d = np.asarray(X), np.asarray(d)
        if X.ndim == 2 and d.ndim == 1:
            return from_gtsam(to_gtsam(X, group).retract(d), group)
        shape = np.broadcast_shapes(X.shape[:-2], d.shape[:-1])
        Xb = np.broadcast_to(X, (*shape, *X.shape[-2:])).reshape(-1, *X.shape[-2:])
        db = np.broadcast_to(d, (*shape, d.shape[-1])).reshape(-1, d.shape[-1])
        pairs = zip(Xb, db, strict=True)
        out = [from_gtsam(to_gtsam(x, group).retract(e), group) for x, e in pairs]
        return np.stack(out).reshape(*shape, *X.shape[-2:])

    return retract


def _values(group: str, T: dict[int, Any]) -> Any:
    return to_values(np.stack(list(T.values())), list(T.keys()), group=group)


def _spd(n: int, rng: np.random.Generator) -> Any:
    A = rng.normal(size=(n, n)) * 0.2
    return A @ A.T + 0.05 * np.eye(n)


def _cov_for(conv: Any, cov: Any) -> Any:
    """Embed a group-size covariance into the convention's tangent (ros_pose2: 6×6)."""
    if conv.embed is None:
        return cov
    idx = list(conv.embed.index)
    out = np.zeros((conv.embed.size, conv.embed.size))
    out[np.ix_(idx, idx)] = cov
    return out


def _linear(factor: Any, values: Any) -> tuple[Any, Any]:
    """``(A, b)`` of the whitened linearization, columns in the factor's key order."""
    A, b = factor.linearize(values).jacobian()
    return np.asarray(A), np.asarray(b)


def _case(group: str, seed: int) -> tuple[Any, Any, Any, Any]:
    """Ti, Tj and a measurement Z close to Ti⁻¹Tj (residual ~0.3, not 0), and a covariance."""
    rng = np.random.default_rng(seed)
    Ti = _rand(group, rng)
    Z = _rand(group, rng)
    Tj = Ti @ Z @ _rand(group, rng, 0.3)
    return Ti, Tj, Z, _spd(DIM[group], rng)


# --------------------------------------------------------------------- native = GTSAM's own
@pytest.mark.parametrize("group", ["se2", "se23"])
@pytest.mark.parametrize("seed", [0, 1])
def test_factors_in_gtsams_preset_equal_gtsams_factors(group: str, seed: int) -> None:
    """Error and whitened linearization (Jacobians) to 1e-9, custom and native."""
    Ti, Tj, Z, cov = _case(group, seed)
    v = _values(group, {1: Ti, 2: Tj})
    B, P = NATIVE[group]
    noise = gtsam.noiseModel.Gaussian.Covariance(cov)
    pairs = [
        (B(1, 2, to_gtsam(Z, group), noise), between(1, 2, Z, cov, HUB[group], native=False)),
        (B(1, 2, to_gtsam(Z, group), noise), between(1, 2, Z, cov, HUB[group])),
        (P(1, to_gtsam(Z, group), noise), prior(1, Z, cov, HUB[group])),
    ]
    if group == "se2":  # GTSAM's prior is −Local(X, Z) = Log(Z⁻¹X) on a Lie group chart
        pairs.append((P(1, to_gtsam(Z, group), noise), prior(1, Z, cov, HUB[group], native=False)))
    else:  # NavState's split chart: −Local(X, Z) ≠ Local(Z, X) (equal to first order)
        theirs = P(1, to_gtsam(Z, group), noise)
        minus_local = -get(HUB[group]).local(Ti, Z)
        np.testing.assert_allclose(theirs.unwhitenedError(v), minus_local, atol=1e-12)
        ours = prior(1, Z, cov, HUB[group], native=False)
        np.testing.assert_allclose(ours.unwhitenedError(v), get(HUB[group]).local(Z, Ti))
        assert np.abs(minus_local - get(HUB[group]).local(Z, Ti)).max() > 0.1
    for theirs, ours in pairs:
        np.testing.assert_allclose(ours.unwhitenedError(v), theirs.unwhitenedError(v), atol=1e-9)
        A1, b1 = _linear(theirs, v)
        A2, b2 = _linear(ours, v)
        np.testing.assert_allclose(A2, A1, atol=1e-9 * max(1.0, np.abs(A1).max()))
        np.testing.assert_allclose(b2, b1, atol=1e-9)


@pytest.mark.parametrize("seed", [0, 1])
def test_similarity3_errors_equal_gtsams_but_its_jacobians_are_the_zero_residual_ones(
    seed: int,
) -> None:
    """GTSAM 4.3.0 linearizes Similarity3 factors with (−Ad(H⁻¹), I) / I at any residual.

    Ours match GTSAM's error to 1e-9 and central differences through GTSAM's own retract (see
    the Jacobian tests); GTSAM's are the zero-residual ones. If this fails, GTSAM implemented
    Similarity3::Logmap's derivative: revisit ConventionGraph's custom-factor choice for Sim(3).
    """
    Ti, Tj, Z, _ = _case("sim3", seed)
    v = _values("sim3", {1: Ti, 2: Tj})
    unit = gtsam.noiseModel.Unit.Create(7)
    theirs = gtsam.BetweenFactorSimilarity3(1, 2, to_gtsam(Z, "sim3"), unit)
    for native in (True, False):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ours = between(1, 2, Z, np.eye(7), "gtsam_similarity3", native=native)
        np.testing.assert_allclose(ours.unwhitenedError(v), theirs.unwhitenedError(v), atol=1e-9)
    A, _ = _linear(theirs, v)
    H = np.linalg.inv(Ti) @ Tj
    Ad_H_inv = np.asarray(to_gtsam(np.linalg.inv(H), "sim3").AdjointMap())
    Hg = to_gtsam(H, "sim3")  # GTSAM's AdjointMap is over its own (ω, u, λ): the same tangent
    assert np.allclose(np.asarray(Hg.inverse().AdjointMap()), Ad_H_inv)
    np.testing.assert_allclose(A[:, 7:], np.eye(7), atol=1e-12)
    np.testing.assert_allclose(A[:, :7], -Ad_H_inv, atol=1e-9)
    ours_A, _ = _linear(between(1, 2, Z, np.eye(7), "gtsam_similarity3", native=False), v)
    assert np.abs(ours_A - A).max() > 0.05  # the residual is ~0.3: exact ≠ zero-residual


def test_native_similarity3_warns_and_convention_graph_uses_exact_factors() -> None:
    with pytest.warns(UserWarning, match="zero-residual Jacobians"):
        between(0, 1, np.eye(4), np.eye(7), "sophus_sim3", native=True)
    g = ConventionGraph("sophus_sim3")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        g.add_prior(0, np.eye(4), np.eye(7))
        g.add_between(0, 1, np.eye(4), np.eye(7))
    assert all(isinstance(g.graph.at(k), gtsam.CustomFactor) for k in range(g.graph.size()))


def _perm(order: list[int]) -> Any:
    return np.eye(len(order))[order]


@pytest.mark.parametrize("seed", [0, 1])
def test_native_factor_in_another_convention_equals_gtsams(seed: int) -> None:
    """Sophus Sim(3) (u, ω, λ) is a permutation of GTSAM's; g2o's Sim(3) is left: Ad_Z (GTSAM's)."""
    Ti, Tj, Z, cov = _case("sim3", seed)
    v = _values("sim3", {1: Ti, 2: Tj})
    Zg = to_gtsam(Z, "sim3")
    theirs = gtsam.BetweenFactorSimilarity3(1, 2, Zg, gtsam.noiseModel.Gaussian.Covariance(cov))
    P = _perm([3, 4, 5, 0, 1, 2, 6])  # (u, ω, λ) ← (ω, u, λ)
    Ad = np.asarray(Zg.AdjointMap())  # local_left(Z, H) = Log(H Z⁻¹) = Ad_Z Log(Z⁻¹H)
    for name, cov_c in (("sophus_sim3", P @ cov @ P.T), ("g2o_sim3", Ad @ cov @ Ad.T)):
        with pytest.warns(UserWarning, match="zero-residual"):
            ours = between(1, 2, Z, cov_c, name, native=True)
        assert isinstance(ours, gtsam.BetweenFactorSimilarity3)
        assert ours.error(v) == pytest.approx(theirs.error(v), rel=1e-9)
        custom = between(1, 2, Z, cov_c, name, native=False)  # exact: the same objective
        assert custom.error(v) == pytest.approx(theirs.error(v), rel=1e-9)
    # SE(2): Sophus/manif/jaxlie/Theseus are GTSAM's (vx, vy, ω) exactly
    Ti, Tj, Z, cov = _case("se2", seed)
    v = _values("se2", {1: Ti, 2: Tj})
    ref = gtsam.BetweenFactorPose2(
        1, 2, to_gtsam(Z, "se2"), gtsam.noiseModel.Gaussian.Covariance(cov)
    )
    for name in ("sophus_se2", "manif_se2", "jaxlie_se2", "theseus_se2"):
        for native in (True, False):
            f = between(1, 2, Z, cov, name, native=native)
            assert f.error(v) == pytest.approx(ref.error(v), rel=1e-9)


# --------------------------------------------------------------------- Jacobians: differences
@pytest.mark.parametrize("group, name", CONVS)
@pytest.mark.parametrize("seed", [3, 4])
def test_custom_jacobians_match_central_differences_through_gtsams_retract(
    group: str, name: str, seed: int
) -> None:
    conv = get(name)
    Ti, Tj, Z, _ = _case(group, seed)
    n = DIM[group]
    retract = _gtsam_retract(group)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a custom factor never warns
        fb = between(7, 9, Z, _cov_for(conv, np.eye(n)), name, native=False)
        fp = prior(7, Z, _cov_for(conv, np.eye(n)), name, native=False)

    def err(f: Any, T: dict[int, Any]) -> Any:
        return np.asarray(f.unwhitenedError(_values(group, T)))

    A, b = _linear(fb, _values(group, {7: Ti, 9: Tj}))
    np.testing.assert_allclose(-b, err(fb, {7: Ti, 9: Tj}), atol=1e-12)
    J_i = numerical_jacobian(lambda T: err(fb, {7: T, 9: Tj}), Ti, retract=retract, dim=n)
    J_j = numerical_jacobian(lambda T: err(fb, {7: Ti, 9: T}), Tj, retract=retract, dim=n)
    np.testing.assert_allclose(A[:, :n], J_i, atol=1e-6)
    np.testing.assert_allclose(A[:, n:], J_j, atol=1e-6)
    A, _ = _linear(fp, _values(group, {7: Ti}))
    J = numerical_jacobian(lambda T: err(fp, {7: T}), Ti, retract=retract, dim=n)
    np.testing.assert_allclose(A, J, atol=1e-6)


@pytest.mark.parametrize("theta", [0.0, 1e-12, np.pi - 1e-6, 3.0])
@pytest.mark.parametrize("name", SE2_CONVS)
def test_se2_jacobians_at_edge_angles(theta: float, name: str) -> None:
    """Residual angle 0, 1e-12, near π (steps stay on the principal branch); 30 m translations."""
    conv = get(name)
    Z = se2.exp(np.array([30.0, -12.0, 0.4]))
    Ti = se2.exp(np.array([-30.0, 5.0, 2.0]))
    Tj = Ti @ Z @ se2.exp(np.array([0.2, -0.1, theta]))
    retract = _gtsam_retract("se2")
    f = between(1, 2, Z, _cov_for(conv, np.eye(3)), name, native=False)
    A, _ = _linear(f, _values("se2", {1: Ti, 2: Tj}))

    def err(T: Any) -> Any:
        return np.asarray(f.unwhitenedError(_values("se2", {1: Ti, 2: T})))

    eps = 1e-7 if theta > 3.1 else 1e-6
    J = numerical_jacobian(err, Tj, retract=retract, dim=3, eps=eps)
    np.testing.assert_allclose(A[:, 3:], J, atol=2e-5)


# --------------------------------------------------------------------- marginals: Monte Carlo
MARGINAL_CONVS = [(g, n) for g, n in CONVS]


@pytest.mark.parametrize("group, name", MARGINAL_CONVS)
def test_marginals_match_monte_carlo_of_gtsams_retract(group: str, name: str) -> None:
    rng = np.random.default_rng(11)
    n = DIM[group]
    conv = get(name)
    T0 = _rand(group, rng)
    Z1, Z2 = _rand(group, rng), _rand(group, rng)
    T = {0: T0, 1: T0 @ Z1, 2: T0 @ Z1 @ Z2}
    graph = gtsam.NonlinearFactorGraph()
    B, P = NATIVE[group]
    graph.add(P(0, to_gtsam(T0, group), gtsam.noiseModel.Isotropic.Sigma(n, 0.02)))
    for i, Z in ((0, Z1), (1, Z2)):
        graph.add(B(i, i + 1, to_gtsam(Z, group), gtsam.noiseModel.Isotropic.Sigma(n, 0.04)))
    values = _values(group, T)
    ours = marginals(graph, values, [2], name)[0]
    cov_g = np.asarray(gtsam.Marginals(graph, values).marginalCovariance(2))
    # Monte Carlo: X = GTSAM's retract(X̂, δ), δ ~ N(0, Σ_gtsam); read in the convention
    N = 4000
    delta = rng.multivariate_normal(np.zeros(n), cov_g, size=N)
    X = _gtsam_retract(group)(T[2], delta)
    d = conv.local(T[2], X)
    mc = np.cov(d.T)
    if conv.embed is not None:
        idx = list(conv.embed.index)
        others = [k for k in range(conv.embed.size) if k not in idx]
        assert np.all(ours[others] == 0) and np.all(ours[:, others] == 0)
        ours, mc = ours[np.ix_(idx, idx)], mc[np.ix_(idx, idx)]
    s = np.sqrt(np.diag(mc))
    assert np.abs((ours - mc) / np.outer(s, s)).max() < 0.1  # correlation units; MC ±0.05
    np.testing.assert_allclose(np.sqrt(np.diag(ours)), s, rtol=0.07)


def test_marginals_of_another_group_are_refused_clearly() -> None:
    graph = gtsam.NonlinearFactorGraph()
    graph.add(gtsam.PriorFactorPose2(0, gtsam.Pose2(), gtsam.noiseModel.Isotropic.Sigma(3, 1.0)))
    v = gtsam.Values()
    v.insert(0, gtsam.Pose2())
    with pytest.raises(TypeError, match=r"keys\[0\]: the value under key 0 is not a Similarity3"):
        marginals(graph, v, [0], "sophus_sim3")


# --------------------------------------------------------------------- ConventionGraph
@pytest.mark.parametrize("group, name", CONVS)
def test_convention_graph_in_every_convention(group: str, name: str) -> None:
    rng = np.random.default_rng(5)
    conv = get(name)
    n = DIM[group]
    T0, Z = _rand(group, rng), _rand(group, rng)
    g = ConventionGraph(name)
    g.insert(0, T0)
    g.insert(1, T0 @ _rand(group, rng))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # native=None: native only where exact, never warns
        g.add_prior(0, T0, _cov_for(conv, np.eye(n) * 1e-6))
        g.add_between(0, 1, Z, _cov_for(conv, np.eye(n) * 1e-2))
    g.optimize()
    np.testing.assert_allclose(g.pose(1), T0 @ Z, atol=1e-7)
    cov = g.marginal_covariance(1)
    assert cov.shape == (conv.embed.size,) * 2 if conv.embed else (n, n)
    assert g.poses([0, 1]).shape == (2, *T0.shape)


# --------------------------------------------------------------------- a shipped 2-D dataset
def _gtsam_optimum(name: str) -> tuple[Any, Any, Any]:
    g = lb.io.g2o2d.read(gtsam.findExampleDataFile(name))
    graph, values = g.to_gtsam(prior=None)
    first = int(g.vertex_ids[0])
    graph.add(
        gtsam.PriorFactorPose2(
            first, values.atPose2(first), gtsam.noiseModel.Isotropic.Sigma(3, 1e-4)
        )
    )
    return g, graph, gtsam.LevenbergMarquardtOptimizer(graph, values).optimize()


@pytest.mark.parametrize("dataset", ["pose2example.txt", "w100_30.g2o"])
def test_custom_factors_in_every_se2_convention_reach_gtsams_optimum(dataset: str) -> None:
    """Exact conventions: GTSAM's objective (1e-7); the others differ at second order only."""
    g, ref_graph, ref = _gtsam_optimum(dataset)
    keys = g.vertex_ids.tolist()
    X_ref = lb.gtsam.from_values(ref, keys, group="se2")
    cov_g = np.linalg.inv(g.information)
    for name in SE2_CONVS:
        conv = get(name)
        cov = lb.convert_covariance(cov_g, g.measured, "gtsam_pose2", conv)
        cg = ConventionGraph(name, values=to_values(g.poses, keys, group="se2"))
        for (i, j), Z, c in zip(g.edges.tolist(), g.measured, cov, strict=True):
            cg.add_between(i, j, Z, c, native=False)
        cg.add_prior(keys[0], g.poses[0], _cov_for(conv, np.eye(3) * 1e-8))
        result = cg.optimize()
        assert result.converged
        X = cg.poses(keys)
        exact = lb.is_exactly_linear(conv, get("gtsam_pose2"))
        tol = 1e-7 if exact else 1e-4  # measured: 1.0e-5 (pose2example), 2.2e-5 (w100_30)
        np.testing.assert_allclose(X, X_ref, atol=tol, err_msg=name)
        assert cg.error() == pytest.approx(ref_graph.error(ref), rel=1e-6 if exact else 1e-3)


# --------------------------------------------------------------------- bad input
def test_a_3x3_rotation_is_not_an_se2_measurement() -> None:
    c, s = np.cos(0.3), np.sin(0.3)
    R_x = np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])
    with pytest.raises(ValueError, match="measured") as info:
        between(0, 1, R_x, np.eye(3), "g2o_se2")
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("native", [True, False])
def test_a_nonpositive_sim3_scale_is_one_clear_error(native: bool) -> None:
    with pytest.raises(ValueError, match=r"measured: Sim\(3\) scale .*≤ 0"):
        between(0, 1, np.diag([-0.5, -0.5, -0.5, 1.0]), np.eye(7), "sophus_sim3", native=native)
    with pytest.raises(ValueError, match=r"pose: Sim\(3\) scale"):
        prior(0, np.diag([0.0, 0.0, 0.0, 1.0]), np.eye(7), "gtsam_similarity3", native=native)


def test_wrong_covariance_size_and_group_size_are_named() -> None:
    with pytest.raises(ValueError, match="cov"):
        between(0, 1, np.eye(3), np.eye(6), "gtsam_pose2")
    with pytest.raises(ValueError, match="measured: expected one se2 element"):
        between(0, 1, np.stack([np.eye(3)] * 2), np.eye(3), "gtsam_pose2")
    with pytest.raises(ValueError, match="measured"):
        between(0, 1, np.eye(4), np.eye(3), "gtsam_pose2")  # an SE(3) pose for an SE(2) factor


def test_se3_path_is_unchanged() -> None:
    """The default convention still builds Pose3 factors."""
    f = between(0, 1, np.eye(4), np.eye(6))
    assert isinstance(f, gtsam.BetweenFactorPose3)
    assert isinstance(prior(0, np.eye(4), np.eye(6), native=False), gtsam.CustomFactor)


# --------------------------------------------------------------------- batched Pose2 evaluation
def test_pose2_custom_factors_are_batched_and_equal_the_callbacks() -> None:
    from liebridge.cli.optimize_2d import build_2d
    from liebridge.gtsam.optimize import _SplitGraph

    g = lb.io.g2o2d.read(gtsam.findExampleDataFile("w100_30.g2o"))
    graph, values = build_2d(g, get("g2o_se2_edge"))
    split = _SplitGraph(graph, values, batch=True)
    assert split.n_batched == g.edges.shape[0]  # every custom Pose2 factor, none left to GTSAM
    assert split.error(values) == pytest.approx(graph.error(values), rel=1e-12)
    lin_b = split.linearize(values).hessian()
    lin_g = graph.linearize(values).hessian()
    np.testing.assert_allclose(lin_b[0], lin_g[0], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(lin_b[1], lin_g[1], rtol=1e-9, atol=1e-9)
    fast = lb.gtsam.optimize(graph, values, batch=True)
    slow = lb.gtsam.optimize(graph, values, batch=False)
    keys = g.vertex_ids.tolist()
    np.testing.assert_allclose(
        lb.gtsam.from_values(fast.values, keys, group="se2"),
        lb.gtsam.from_values(slow.values, keys, group="se2"),
        atol=1e-9,
    )
    assert fast.final_error == pytest.approx(slow.final_error, rel=1e-9)


def test_isam2_takes_pose2_custom_factors_through_gtsam() -> None:
    rng = np.random.default_rng(2)
    steps = [_rand("se2", rng, 0.5) for _ in range(4)]
    T = [np.eye(3)]
    for Z in steps:
        T.append(T[-1] @ Z)
    graph = gtsam.NonlinearFactorGraph()
    graph.add(prior(0, np.eye(3), np.eye(3) * 1e-6, "g2o_se2_edge", native=False))
    for k, Z in enumerate(steps):
        graph.add(between(k, k + 1, Z, np.eye(3) * 1e-2, "g2o_se2_edge", native=False))
    params = gtsam.ISAM2Params()
    params.relinearizeSkip = 1
    params.setRelinearizeThreshold(1e-9)  # relinearize every step: GN to convergence
    isam = lb.gtsam.ISAM2(params)
    isam.update(graph, _values("se2", {k: X @ se2.exp(np.full(3, 0.01)) for k, X in enumerate(T)}))
    for _ in range(4):
        isam.update()
    est = lb.gtsam.from_values(isam.calculate_estimate(), range(5), group="se2")
    np.testing.assert_allclose(est, np.stack(T), atol=1e-6)


def test_sim3_custom_factors_reach_the_minimum_gtsams_native_ones_stop_short_of() -> None:
    """An inconsistent Sim(3) loop: exact Jacobians reach ∇ = 0 of the objective, GTSAM's don't."""
    rng = np.random.default_rng(0)
    steps = [sim3.exp(np.r_[rng.normal(size=6) * 0.5, 0.1]) for _ in range(4)]
    T = [np.eye(4)]
    for Z in steps:
        T.append(T[-1] @ Z)
    loop = np.linalg.inv(T[-1]) @ sim3.exp(np.r_[rng.normal(size=6) * 0.2, 0.05])

    def build(native: bool) -> Any:
        g = gtsam.NonlinearFactorGraph()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            g.add(prior(0, np.eye(4), np.eye(7) * 1e-6, "gtsam_similarity3", native=native))
            for k, Z in enumerate(steps):
                g.add(between(k, k + 1, Z, np.eye(7) * 1e-2, "gtsam_similarity3", native=native))
            g.add(between(4, 0, loop, np.eye(7) * 1e-2, "gtsam_similarity3", native=native))
        return g

    v = to_values(np.stack(T), range(5), group="sim3")
    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(1e-12)
    params.setAbsoluteErrorTol(1e-12)
    exact, native = build(False), build(True)
    r_exact = gtsam.LevenbergMarquardtOptimizer(exact, v, params).optimize()
    r_native = gtsam.LevenbergMarquardtOptimizer(native, v, params).optimize()
    # both graphs have the same objective (same errors, same noise) ...
    assert native.error(v) == pytest.approx(exact.error(v), rel=1e-12)

    def gradient(r: Any) -> float:
        """Max |∂ objective/∂δ| over the free keys, central differences through GTSAM's retract."""
        g = []
        for k in range(1, 5):
            for d in range(7):
                e = np.zeros(7)
                e[d] = 1e-6
                vp, vm = gtsam.Values(r), gtsam.Values(r)
                vp.update(k, r.atSimilarity3(k).retract(e))
                vm.update(k, r.atSimilarity3(k).retract(-e))
                g.append((exact.error(vp) - exact.error(vm)) / 2e-6)
        return float(np.abs(g).max())

    # ... but only the exact Jacobians stop at its minimum (measured: 0.126 for GTSAM's)
    assert gradient(r_exact) < 1e-3
    assert gradient(r_native) > 0.05
    assert exact.error(r_exact) < exact.error(r_native)


_coord = st.floats(-3.0, 3.0, allow_nan=False)


@settings(max_examples=25, deadline=None)
@given(
    name=st.sampled_from(SE2_CONVS),
    xi=st.lists(_coord, min_size=9, max_size=9),
    translation=st.floats(-30.0, 30.0, allow_nan=False),
)
def test_se2_custom_jacobians_hypothesis(name: str, xi: list[float], translation: float) -> None:
    """Random poses (up to 30 m apart) and residual angles within (−3, 3) rad."""
    conv = get(name)
    a = np.asarray(xi)
    Ti = se2.exp(a[:3] + np.array([translation, 0.0, 0.0]))
    Z = se2.exp(a[3:6])
    Tj = Ti @ Z @ se2.exp(a[6:] * np.array([1.0, 1.0, 0.99]))
    f = between(1, 2, Z, _cov_for(conv, np.eye(3)), name, native=False)
    A, _ = _linear(f, _values("se2", {1: Ti, 2: Tj}))

    def err(T: Any, k: int) -> Any:
        return np.asarray(f.unwhitenedError(_values("se2", {1: Ti, 2: Tj, k: T})))

    retract = _gtsam_retract("se2")
    J_i = numerical_jacobian(lambda T: err(T, 1), Ti, retract=retract, dim=3)
    J_j = numerical_jacobian(lambda T: err(T, 2), Tj, retract=retract, dim=3)
    scale = max(1.0, float(np.abs(J_i).max()))
    np.testing.assert_allclose(A[:, :3], J_i, atol=1e-5 * scale)
    np.testing.assert_allclose(A[:, 3:], J_j, atol=1e-5 * scale)
