"""Cumulative B-splines: GTSAM as oracle, knot Jacobians, velocity frames, presets, fit, errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from liebridge.check import numerical_jacobian
from liebridge.continuous import (
    SPLINE_PRESETS,
    Spline,
    convert_knot_covariance,
    convert_velocity,
    interpolate,
)
from liebridge.conventions import PRESETS, convert_covariance, get
from liebridge.lie import se3

SE3_PRESETS = [c.name for c in PRESETS if c.group == "se3"]
KINDS = [("coupled", "product"), ("split", "product"), ("coupled", "sum")]


def _knots(n: int = 7, scale: float = 0.8, seed: int = 11) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return se3.exp(rng.normal(size=(n, 6)) * scale)


def _spline(kind: str, form: str, knots: np.ndarray | None = None) -> Spline:
    K = _knots() if knots is None else knots
    return Spline(K, 0.5, 0.2, 4, kind, form=form)


# ------------------------------------------------------------------------------------- GTSAM
gtsam = pytest.importorskip("gtsam")


def _gtsam_spline(K: np.ndarray, density: float, pad: bool):  # type: ignore[no-untyped-def]
    S = gtsam.CumulativeSplineTrajectoryPose3(density, pad)
    for k in K:
        S.addControlPoint(gtsam.Pose3(k))
    return S


@pytest.mark.parametrize("density,pad", [(1.0, False), (2.5, False), (1.7, True)])
def test_gtsam_cumulative_equals_gtsam(density: float, pad: bool) -> None:
    K = _knots(8, 0.9)
    S = _gtsam_spline(K, density, pad)
    ours = Spline.from_preset("gtsam_cumulative", K, density=density, pad_front=pad)
    ts = np.linspace(-1.0, 7.0, 31)  # GTSAM extrapolates; so does the preset
    theirs = np.stack([S.sampleTrajectory(t).matrix() for t in ts])
    np.testing.assert_allclose(ours.evaluate(ts), theirs, atol=1e-12)
    for d in (0, 1, 2):
        g = np.stack([S.sampleTrajectoryDerivative(t, 0.0, -1.0, d) for t in ts])
        np.testing.assert_allclose(ours.tangent_rate(ts, d), g, atol=1e-11)


def test_gtsam_body_twist_is_expmap_derivative_times_u_dot() -> None:
    K = _knots(7, 0.9)
    S = _gtsam_spline(K, 1.0, False)
    ours = Spline.from_preset("gtsam_cumulative", K)
    for t in (3.2, 4.75, 6.1):
        u = S.sampleTrajectoryDerivative(t, 0.0, -1.0, 0)
        du = S.sampleTrajectoryDerivative(t, 0.0, -1.0, 1)
        twist = gtsam.Pose3.ExpmapDerivative(u) @ du
        v = ours.velocity(t)
        np.testing.assert_allclose(np.concatenate([v.omega_body, v.v_body]), twist, atol=1e-11)
        # u̇ alone is not it (the increments turn)
        assert np.abs(du - twist).max() > 1e-3


def test_sum_form_differs_from_product_form_when_increments_turn() -> None:
    K = _knots(7, 0.9)
    ts = np.linspace(3.0, 7.0, 41)
    gt = Spline.from_preset("gtsam_cumulative", K)  # t0 = 3, dt = 1
    prod = Spline(K, 3.0, 1.0, 4, "coupled")
    diff = np.abs(gt.evaluate(ts) - prod.evaluate(ts)).max()
    assert diff > 0.1
    # with commuting increments (pure translations) they agree
    Kt = np.tile(np.eye(4), (7, 1, 1))
    Kt[:, :3, 3] = np.random.default_rng(1).normal(size=(7, 3))
    gt_t = Spline.from_preset("gtsam_cumulative", Kt)
    np.testing.assert_allclose(gt_t.evaluate(ts), Spline(Kt, 3.0, 1.0).evaluate(ts), atol=1e-12)


# ----------------------------------------------------------------------------- definitions
def test_order_two_is_the_piecewise_geodesic() -> None:
    K = _knots(5)
    sp = Spline(K, 0.0, 1.0, order=2)
    ts = np.array([0.0, 0.3, 1.5, 2.99, 4.0])
    s = np.minimum(np.floor(ts).astype(int), 3)
    expected = interpolate(K[s], K[s + 1], ts - s, jacobians=False).T
    np.testing.assert_allclose(sp.evaluate(ts), expected, atol=1e-12)
    split = Spline(K, 0.0, 1.0, order=2, kind="split")
    np.testing.assert_allclose(
        split.evaluate(ts),
        interpolate(K[s], K[s + 1], ts - s, "split", jacobians=False).T,
        atol=1e-12,
    )


def test_cubic_basis_is_the_textbook_one() -> None:
    from liebridge.continuous._common import cumulative_basis

    u = np.linspace(0, 1, 7)
    expected = np.stack(
        [
            np.ones_like(u),
            (5 + 3 * u - 3 * u**2 + u**3) / 6,
            (1 + 3 * u + 3 * u**2 - 2 * u**3) / 6,
            u**3 / 6,
        ],
        axis=-1,
    )
    np.testing.assert_allclose(cumulative_basis(4, u), expected, atol=1e-15)


@pytest.mark.parametrize("kind,form", KINDS)
def test_velocity_and_acceleration_match_differences_in_time(kind: str, form: str) -> None:
    sp = _spline(kind, form)
    ts = np.array([0.55, 0.71, 0.93])
    h = 1e-5
    T = sp.evaluate(ts)
    body = (
        se3.log(np.linalg.inv(T) @ sp.evaluate(ts + h))
        - se3.log(np.linalg.inv(T) @ sp.evaluate(ts - h))
    ) / (2 * h)
    v = sp.velocity(ts)
    np.testing.assert_allclose(v.omega_body, body[:, :3], atol=1e-6)
    np.testing.assert_allclose(v.v_body, body[:, 3:], atol=1e-6)
    pdot = (sp.evaluate(ts + h)[:, :3, 3] - sp.evaluate(ts - h)[:, :3, 3]) / (2 * h)
    np.testing.assert_allclose(v.v_world, pdot, atol=1e-6)
    R = T[:, :3, :3]
    Rdot = (sp.evaluate(ts + h)[:, :3, :3] - sp.evaluate(ts - h)[:, :3, :3]) / (2 * h)
    W = Rdot @ np.swapaxes(R, -1, -2)  # ω̂_world = Ṙ Rᵀ (kontiki's definition)
    np.testing.assert_allclose(
        v.omega_world, np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], -1), atol=1e-6
    )
    a = sp.acceleration(ts)
    vp, vm = sp.velocity(ts + h), sp.velocity(ts - h)
    np.testing.assert_allclose(a.alpha_body, (vp.omega_body - vm.omega_body) / (2 * h), atol=1e-5)
    np.testing.assert_allclose(
        a.alpha_world, (vp.omega_world - vm.omega_world) / (2 * h), atol=1e-5
    )
    np.testing.assert_allclose(a.a_world, (vp.v_world - vm.v_world) / (2 * h), atol=1e-5)
    np.testing.assert_allclose(
        a.a_body, (np.swapaxes(R, -1, -2) @ a.a_world[..., None])[..., 0], atol=1e-12
    )
    # the tempting d/dt v_body is not a_body
    assert np.abs((vp.v_body - vm.v_body) / (2 * h) - a.a_body).max() > 1e-3


def test_nanosecond_spline_matches_the_seconds_one() -> None:
    K = _knots()
    s = Spline(K, 1.5, 0.25, 4, "split")
    ns = Spline(K, 1_500_000_000, 250_000_000, 4, "split", time_unit="ns")
    t_ns = np.array([1_500_000_000, 1_712_345_678, 2_499_999_999])
    np.testing.assert_allclose(ns.evaluate(t_ns), s.evaluate(t_ns * 1e-9), atol=1e-9)
    np.testing.assert_allclose(
        ns.velocity(t_ns).omega_body, s.velocity(t_ns * 1e-9).omega_body, atol=1e-7
    )  # per second in both


# ------------------------------------------------------------------------------- Jacobians
@pytest.mark.parametrize("conv", SE3_PRESETS)
@pytest.mark.parametrize("kind,form", KINDS)
def test_knot_jacobians_match_central_differences(conv: str, kind: str, form: str) -> None:
    c = get(conv)
    K = _knots(6, 0.6)
    sp = Spline(K, 0.0, 1.0, 4, kind, form=form, extrapolate=True)
    t = np.array([0.0, 1.37, 3.0])  # segment starts, inside, the end
    jac = sp.jacobians(t, convention=c)
    for i, ti in enumerate(t):
        for m in range(jac.J_T_knots.shape[1]):
            idx = int(jac.first_knot[i]) + m

            def f(X: np.ndarray, idx: int = idx, ti: float = ti) -> np.ndarray:
                Kp = K.copy()
                Kp[idx] = X
                return Spline(Kp, 0.0, 1.0, 4, kind, form=form, extrapolate=True).evaluate(ti)

            N = numerical_jacobian(f, K[idx], in_convention=c, out_convention=c, eps=1e-7)
            np.testing.assert_allclose(
                jac.J_T_knots[i, m], N, atol=3e-6, err_msg=f"t={ti} knot {idx}"
            )


@pytest.mark.parametrize("conv", SE3_PRESETS)
@pytest.mark.parametrize("kind", ["coupled", "split"])
def test_knot_jacobians_near_pi_increments(conv: str, kind: str) -> None:
    axis = np.array([0.0, 0.6, 0.8])
    K = np.stack(
        [se3.exp(np.concatenate([k * (math.pi - 1e-3) * axis, [k, 0.0, 0.0]])) for k in range(5)]
    )
    sp = Spline(K, 0.0, 1.0, 4, kind)
    jac = sp.jacobians(0.4, convention=conv)
    for m in range(4):

        def f(X: np.ndarray, m: int = m) -> np.ndarray:
            Kp = K.copy()
            Kp[m] = X
            return Spline(Kp, 0.0, 1.0, 4, kind).evaluate(0.4)

        N = numerical_jacobian(f, K[m], in_convention=conv, out_convention=conv, eps=1e-8)
        np.testing.assert_allclose(jac.J_T_knots[m], N, atol=5e-5)


# --------------------------------------------------------------------------------- presets
def test_presets_state_their_conventions() -> None:
    b, k, g = (SPLINE_PRESETS[n] for n in ("basalt", "kontiki", "gtsam_cumulative"))
    assert (b.kind, b.form, b.time_unit, b.omega_frame, b.v_frame) == (
        "split",
        "product",
        "ns",
        "body",
        "world",
    )
    assert (k.kind, k.form, k.time_unit, k.omega_frame) == ("coupled", "product", "s", "world")
    assert (g.kind, g.form, g.extrapolates) == ("coupled", "sum", True)
    assert "source-read" in b.source and "source-read" in k.source


def test_outside_the_knots_basalt_and_kontiki_raise() -> None:
    K = _knots(6)
    basalt = Spline.from_preset("basalt", K, 1_000, 100)
    assert basalt.t_max == 1_000 + 3 * 100
    with pytest.raises(ValueError, match=r"outside the spline.s knots.*basalt does not extrapol"):
        basalt.evaluate(np.array([1_100, 999]))
    kontiki = Spline.from_preset("kontiki", K, 0.0, 0.5)
    kontiki.evaluate(1.4999999)
    with pytest.raises(ValueError, match=r"end excluded.*kontiki does not extrapolate"):
        kontiki.velocity(1.5)  # kontiki's MaxTime() itself throws there
    with pytest.raises(ValueError, match="end excluded"):
        basalt.evaluate(1_300)  # basalt's maxTimeNs is 1_299
    basalt.evaluate(1_299)
    Spline(K, 0.0, 0.5).evaluate(1.5)  # a plain spline includes its end (u = 1)
    with pytest.raises(ValueError, match="mixed time units"):
        basalt.evaluate(1.05e-6)
    with pytest.raises(ValueError, match="mixed time units"):
        kontiki.evaluate(np.array([1], dtype=np.int64))
    with pytest.raises(ValueError, match="mixed time units"):
        Spline(K, 0, 0.1)


def test_convert_velocity_between_presets() -> None:
    sp = Spline.from_preset("kontiki", _knots(), 0.0, 0.5)
    v = sp.velocity(0.8)
    R = sp.evaluate(0.8)[:3, :3]
    w, vv = convert_velocity(v.omega_world, v.v_world, R, "kontiki", "basalt")
    np.testing.assert_allclose(w, v.omega_body, atol=1e-12)
    np.testing.assert_allclose(vv, v.v_world, atol=1e-12)
    _w2, v2 = convert_velocity(w, vv, R, "basalt", ("body", "body"))
    np.testing.assert_allclose(v2, v.v_body, atol=1e-12)
    with pytest.raises(ValueError, match=r"u̇"):
        convert_velocity(w, vv, R, "gtsam_cumulative", "basalt")


def test_convert_knot_covariance_between_presets() -> None:
    rng = np.random.default_rng(5)
    A = rng.normal(size=(6, 6))
    cov = A @ A.T
    X = _knots(1)[0]
    out = convert_knot_covariance(cov, X, "kontiki", "basalt")
    ref = convert_covariance(cov, X, get("sophus"), SPLINE_PRESETS["basalt"].knot_convention)
    np.testing.assert_allclose(out, ref, atol=1e-12)
    back = convert_knot_covariance(out, X, "basalt", "kontiki")
    np.testing.assert_allclose(back, cov, atol=1e-9)


# -------------------------------------------------------------------------------------- fit
@pytest.mark.parametrize("kind", ["coupled", "split"])
def test_fit_recovers_a_spline_from_its_samples(kind: str) -> None:
    truth = Spline(_knots(8, 0.4), 0.0, 0.5, 4, kind)
    stamps = np.linspace(0.0, truth.t_max, 120)
    fitted = Spline.fit(stamps, truth.evaluate(stamps), 0.5, kind=kind)
    ts = np.linspace(0.0, truth.t_max, 57)
    np.testing.assert_allclose(fitted.evaluate(ts), truth.evaluate(ts), atol=1e-6)


def test_fit_with_integer_nanoseconds() -> None:
    truth = Spline(_knots(6, 0.3), 0, 200_000_000, 4, time_unit="ns")
    stamps = np.linspace(0, 600_000_000, 40).astype(np.int64)
    fitted = Spline.fit(stamps, truth.evaluate(stamps), 200_000_000)
    assert fitted.time_unit == "ns"
    np.testing.assert_allclose(fitted.evaluate(stamps), truth.evaluate(stamps), atol=1e-6)


def test_fit_rejects_unsorted_stamps_and_mixed_units() -> None:
    K = _knots(6)
    sp = Spline(K, 0.0, 0.5)
    stamps = np.array([0.0, 0.3, 0.2, 0.9])
    with pytest.raises(ValueError, match="strictly increasing; index 2"):
        Spline.fit(stamps, sp.evaluate(np.sort(stamps)), 0.5)
    with pytest.raises(ValueError, match="mixed time units"):
        Spline.fit(np.array([0, 1, 2]), sp.evaluate(np.array([0.0, 0.1, 0.2])), 0.5)


def test_constructor_errors_are_named() -> None:
    K = _knots(3)
    with pytest.raises(ValueError, match="at least 4 knots"):
        Spline(K, 0.0, 1.0)
    with pytest.raises(ValueError, match="dt"):
        Spline(_knots(), 0.0, -1.0)
    with pytest.raises(ValueError, match="kind"):
        Spline(_knots(), 0.0, 1.0, kind="helix")
    with pytest.raises(ValueError, match=r"kind=.coupled. only"):
        Spline(_knots(), 0.0, 1.0, kind="split", form="sum")
    with pytest.raises(ValueError, match="name"):
        Spline.from_preset("ceres", _knots(), 0.0, 1.0)


def test_split_spline_matches_basalts_definition_written_with_scipy() -> None:
    """basalt's Se3Spline, written independently with scipy rotations: SO(3) cumulative product
    of ``Exp(b̃_j·Log(R_{j−1}ᵀR_j))`` and the translation a plain cubic B-spline."""
    from scipy.spatial.transform import Rotation

    K = _knots(6, 0.7)
    sp = Spline(K, 0.0, 1.0, 4, "split")
    for t in (0.0, 0.4, 1.7, 2.999):
        s, u = int(t), t - int(t)
        b = [
            1.0,
            (5 + 3 * u - 3 * u**2 + u**3) / 6,
            (1 + 3 * u + 3 * u**2 - 2 * u**3) / 6,
            u**3 / 6,
        ]
        R = Rotation.from_matrix(K[s, :3, :3])
        for j in range(1, 4):
            inc = Rotation.from_matrix(K[s + j - 1, :3, :3]).inv() * Rotation.from_matrix(
                K[s + j, :3, :3]
            )
            R = R * Rotation.from_rotvec(b[j] * inc.as_rotvec())
        w = [b[j] - (b[j + 1] if j < 3 else 0.0) for j in range(4)]
        p = sum(w[j] * K[s + j, :3, 3] for j in range(4))
        T = sp.evaluate(t)
        np.testing.assert_allclose(T[:3, :3], R.as_matrix(), atol=1e-12)
        np.testing.assert_allclose(T[:3, 3], p, atol=1e-12)


@pytest.mark.parametrize("kind,form", KINDS)
def test_zero_motion_spline(kind: str, form: str) -> None:
    K = np.tile(_knots(1)[0], (5, 1, 1))
    sp = Spline(K, 0.0, 1.0, 4, kind, form=form)
    ts = np.array([0.0, 0.5, 2.0])
    np.testing.assert_allclose(sp.evaluate(ts), np.broadcast_to(K[0], (3, 4, 4)), atol=1e-14)
    v, a = sp.velocity(ts), sp.acceleration(ts)
    for x in (*v, *a):
        np.testing.assert_allclose(x, 0.0, atol=1e-14)
    J = sp.jacobians(ts).J_T_knots
    assert np.isfinite(J).all()
    np.testing.assert_allclose(J.sum(axis=1), np.broadcast_to(np.eye(6), (3, 6, 6)), atol=1e-12)


def test_knot_covariance_conversion_matches_monte_carlo() -> None:
    """Samples drawn in kontiki's knot perturbation (Sophus ``T·exp(δ)``, (υ, ω)), read back in
    basalt's (``R·Exp(δ_R)``, ``t + δ_t``, translation first): their covariance is the
    converted one."""
    rng = np.random.default_rng(8)
    X = _knots(1, 0.9)[0]
    L = np.diag([0.02, 0.03, 0.01, 0.004, 0.002, 0.003]) @ np.linalg.qr(rng.normal(size=(6, 6)))[0]
    cov = L @ L.T
    src, dst = get("sophus"), SPLINE_PRESETS["basalt"].knot_convention
    d = rng.multivariate_normal(np.zeros(6), cov, size=200_000)
    e = dst.local(X, src.retract(X, d))
    emp = np.cov(e.T)
    conv = convert_knot_covariance(cov, X, "kontiki", "basalt")
    scale = np.sqrt(np.outer(np.diag(conv), np.diag(conv)))
    assert np.abs((emp - conv) / scale).max() < 0.02
    assert np.abs((cov - conv) / scale).max() > 0.1  # the naive copy is wrong


@pytest.mark.parametrize("pad", [False, True])
@pytest.mark.parametrize("window", [(3.0, -1.0), (5.0, -1.0), (6.5, 8.2), (0.0, 3.0), (7.0, 7.5)])
def test_gtsam_cumulative_sample_windows(pad: bool, window: tuple[float, float]) -> None:
    """A sample window makes its first control point the base (far from the default curve)."""
    K = _knots(12, 0.7)
    S = _gtsam_spline(K, 1.3, pad)
    ours = Spline.from_preset("gtsam_cumulative", K, density=1.3, pad_front=pad, window=window)
    for t in (4.1, 5.3, 6.9):
        theirs = S.sampleTrajectory(t, *window).matrix()
        np.testing.assert_allclose(ours.evaluate(t), theirs, atol=1e-12)
        u = S.sampleTrajectoryDerivative(t, window[0], window[1], 1)
        np.testing.assert_allclose(ours.tangent_rate(t, 1), u, atol=1e-11)
    jac = ours.jacobians(5.3)
    assert int(jac.first_knot) == ours.knot_offset
    with pytest.raises(ValueError, match="holds no control point"):
        Spline.from_preset("gtsam_cumulative", K, window=(30.0, -1.0))
    with pytest.raises(Exception, match="contains no control points"):
        _gtsam_spline(K, 1.0, False).sampleTrajectory(5.0, 30.0, -1.0)
