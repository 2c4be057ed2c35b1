"""Body-velocity navigation charts, Umeyama on planar trajectories, no numpy warning leaks.

* A :class:`~liebridge.conventions.NavChart` with ``velocity="body"`` (no shipped preset uses one:
  every VIO preset adds its velocity in the world frame) built on GTSAM's split body pose chart is
  GTSAM's ``NavState`` chart: its retraction is checked against the ``gtsam_navstate`` preset and
  against ``gtsam.NavState.retract`` itself, and every first-order map of body-velocity charts
  against central finite differences through the same retraction.
* Umeyama alignment of planar trajectories (every position in one plane): the cross-covariance
  has rank 2, its determinant is rounding noise, and a reflection fits the positions exactly as
  well as the rotation does — the case where a reflection bug hides. ``R``, ``t``, ``s`` are
  recovered, ``det R = +1``, for SE(3), Sim(3) and the yaw-only 4-DoF alignment, and the
  result agrees with evo's ``umeyama_alignment`` (the field's reference implementation).
* Paths that end in a clear ``ValueError`` raise it before numpy warns: these tests turn every
  warning into an error.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import liebridge as lb
from liebridge import conventions as C
from liebridge import traj
from liebridge.lie import se23, sim3, so3

RNG_SEEDS = range(12)

# ----------------------------------------------------------------------------- NavChart, body v


def _pose(name: str, side: str, order: str, chart: str, rotation: str) -> C.Convention:
    return C.Convention(
        name=name, side=side, order=order, chart=chart, rotation=rotation, quat_order="wxyz"
    )


#: GTSAM's NavState chart rebuilt as a NavChart: right rotation, body-frame position, body v.
NAV_BODY = C.NavChart.of(
    "nav_body_gtsam", _pose("p_body", "right", "rot_first", "so3xr3_body", "exp"), "body"
)
#: Body-velocity charts on other pose charts (none of them a shipped preset).
BODY_CHARTS = {
    "split_body": NAV_BODY,
    "split_world_left": C.NavChart.of(
        "nav_body_left", _pose("p_left", "left", "trans_first", "so3xr3_world", "exp"), "body"
    ),
    "coupled_se3": C.NavChart.of("nav_body_se3", C.get("gtsam"), "body"),
    "cayley_permuted": C.NavChart.of(
        "nav_body_cay",
        _pose("p_cay", "right", "rot_first", "so3xr3_world", "cayley"),
        "body",
        order=[0, 1, 2, 6, 7, 8, 3, 4, 5],
    ),
}


def _state(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return C.nav_state(
        so3.exp(rng.normal(size=3)), rng.normal(size=3) * 20.0, rng.normal(size=3) * 3.0
    )


def _canonical_local(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """GTSAM's SE₂(3) chart, ``Log(X⁻¹ Y)``, written with the group kernels (not the chart)."""
    return se23.log(se23.inverse(X) @ Y)


def _central(f, x0: np.ndarray, h: float = 1e-6) -> np.ndarray:  # type: ignore[no-untyped-def]
    cols = []
    for k in range(x0.size):
        e = np.zeros_like(x0)
        e[k] = h
        cols.append((f(x0 + e) - f(x0 - e)) / (2 * h))
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize("seed", RNG_SEEDS)
def test_navchart_with_body_velocity_is_the_gtsam_navstate_preset(seed):
    X = _state(seed)
    rng = np.random.default_rng(100 + seed)
    d = rng.normal(size=9) * 0.4
    g = C.get("gtsam_navstate")
    np.testing.assert_allclose(NAV_BODY.retract(X, d), g.retract(X, d), atol=1e-12)
    Y = g.retract(X, d)
    np.testing.assert_allclose(NAV_BODY.local(X, Y), g.local(X, Y), atol=1e-10)
    np.testing.assert_allclose(lb.tangent_map(X, NAV_BODY, "gtsam_navstate"), np.eye(9), atol=1e-12)
    cov = np.diag(rng.uniform(0.01, 0.2, 9))
    np.testing.assert_allclose(
        lb.convert_covariance(cov, X, NAV_BODY, "gtsam_navstate"), cov, atol=1e-14
    )
    np.testing.assert_allclose(
        NAV_BODY.local_jacobian(X, Y), g.local_jacobian(X, Y), rtol=1e-9, atol=1e-12
    )


@pytest.mark.parametrize("seed", RNG_SEEDS)
def test_navchart_with_body_velocity_retracts_as_gtsam_navstate_does(seed):
    gtsam = pytest.importorskip("gtsam")
    X = _state(seed)
    d = np.random.default_rng(200 + seed).normal(size=9) * 0.4
    ns = gtsam.NavState(gtsam.Rot3(X[:3, :3]), gtsam.Point3(X[:3, 3]), X[:3, 4])
    Y = ns.retract(d)  # GTSAM: (R·Exp(δθ), p + R·δp, v + R·δv)
    got = NAV_BODY.retract(X, d)
    np.testing.assert_allclose(got[:3, :3], Y.attitude().matrix(), atol=1e-12)
    np.testing.assert_allclose(got[:3, 3], Y.position(), atol=1e-11)
    np.testing.assert_allclose(got[:3, 4], Y.velocity(), atol=1e-11)
    np.testing.assert_allclose(NAV_BODY.local(X, got), ns.localCoordinates(Y), atol=1e-9)


@pytest.mark.parametrize("name", list(BODY_CHARTS))
@pytest.mark.parametrize("seed", range(4))
def test_navchart_with_body_velocity_first_order_maps_against_finite_differences(name, seed):
    nav = BODY_CHARTS[name]
    X = _state(seed)
    rng = np.random.default_rng(300 + seed)
    Y = nav.retract(X, rng.normal(size=9) * 0.3)
    zero = np.zeros(9)
    # to_canonical: d/dd of Log(X⁻¹ · retract(X, d)) at 0
    fd = _central(lambda d: _canonical_local(X, nav.retract(X, d)), zero)
    np.testing.assert_allclose(nav.to_canonical(X), fd, atol=1e-7)
    # from_canonical: d/dξ of local(X, X·Exp(ξ)) at 0
    fd = _central(lambda xi: nav.local(X, X @ se23.exp(xi)), zero)
    np.testing.assert_allclose(nav.from_canonical(X), fd, atol=1e-7)
    # local_jacobian: d/dδ of local(X, retract(Y, δ)) at 0, in the chart's own coordinates
    fd = _central(lambda e: nav.local(X, nav.retract(Y, e)), zero)
    np.testing.assert_allclose(nav.local_jacobian(X, Y), fd, atol=1e-6)
    # and the map to GTSAM's NavState chart: d/dd of navstate.local(X, retract(X, d))
    g = C.get("gtsam_navstate")
    fd = _central(lambda d: g.local(X, nav.retract(X, d)), zero)
    np.testing.assert_allclose(lb.tangent_map(X, nav, g), fd, atol=1e-7)


@pytest.mark.parametrize("seed", range(4))
def test_navchart_body_and_world_velocity_differ_by_the_rotation(seed):
    """The velocity block between the two frames is ``R`` (body → world), not ``I``."""
    X = _state(seed)
    world = C.NavChart.of("nav_world", NAV_BODY.pose, "world")
    M = lb.tangent_map(X, NAV_BODY, world)
    np.testing.assert_allclose(M[6:, 6:], X[:3, :3], atol=1e-12)
    np.testing.assert_allclose(M[:6, :6], np.eye(6), atol=1e-12)
    assert np.abs(M[6:, 6:] - np.eye(3)).max() > 0.1  # the tempting identity is wrong here
    d = np.random.default_rng(seed).normal(size=9) * 0.2
    np.testing.assert_allclose(
        world.retract(X, M @ d), NAV_BODY.retract(X, d), atol=1e-12
    )  # exact: the velocity increment is linear in either frame


def test_navchart_with_body_velocity_covariance_monte_carlo():
    """Σ carried from the body-velocity chart into manif's SE₂(3) matches sampled perturbations."""
    X = _state(7)
    rng = np.random.default_rng(8)
    A = rng.normal(size=(9, 9)) * 0.02
    cov = A @ A.T + 1e-4 * np.eye(9)
    lin = lb.convert_covariance(cov, X, NAV_BODY, "manif_se23")
    d = rng.multivariate_normal(np.zeros(9), cov, size=40_000)
    m = C.get("manif_se23")
    samples = m.local(np.broadcast_to(X, (len(d), 5, 5)), NAV_BODY.retract(X, d))
    mc = np.cov(samples.T)
    assert np.abs(mc - lin).max() < 0.05 * np.abs(lin).max()


# ----------------------------------------------------------------------------- Umeyama, planar


def _planar_positions(seed: int, n: int = 60) -> np.ndarray:
    """A planar figure-eight at 30 m scale in the plane z = 0 (rank-2 cross-covariance)."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    p = np.column_stack([30 * np.sin(s), 12 * np.sin(2 * s), np.zeros(n)])
    return p + np.array([*rng.normal(size=2) * 5, 0.0])


def _poses(p: np.ndarray, seed: int) -> np.ndarray:
    """Poses at positions ``p`` with yaw-only attitudes (a ground robot)."""
    rng = np.random.default_rng(seed)
    T = np.tile(np.eye(4), (len(p), 1, 1))
    T[:, :3, :3] = so3.exp(np.column_stack([np.zeros((len(p), 2)), rng.uniform(-3, 3, len(p))]))
    T[:, :3, 3] = p
    return T


def _known(kind: str, seed: int) -> traj.Alignment:
    rng = np.random.default_rng(1000 + seed)
    if kind == "4dof":
        R = so3.exp([0.0, 0.0, rng.uniform(-np.pi, np.pi)])
    else:
        R = so3.exp(rng.normal(size=3))
    t = rng.normal(size=3) * 50.0
    return traj.Alignment(kind, R, t, float(rng.uniform(0.2, 5.0)) if kind == "sim3" else 1.0)


@pytest.mark.parametrize("kind", ["se3", "sim3", "4dof"])
@pytest.mark.parametrize("seed", RNG_SEEDS)
def test_umeyama_on_planar_trajectory_recovers_the_known_transform(kind, seed):
    T_est = _poses(_planar_positions(seed), seed)
    A = _known(kind, seed)
    T_ref = A.apply(T_est)
    B = traj.align(T_ref, T_est, kind)
    assert np.linalg.det(B.R_ref_est) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(B.R_ref_est, A.R_ref_est, atol=1e-10)
    np.testing.assert_allclose(B.t_ref_est, A.t_ref_est, atol=1e-8)
    assert B.scale == pytest.approx(A.scale, rel=1e-12)
    aligned = B.apply(T_est)  # orientations too: a reflection would turn them into det −1
    np.testing.assert_allclose(aligned, T_ref, atol=1e-8)
    assert np.allclose(np.linalg.det(aligned[:, :3, :3]), 1.0, atol=1e-12)


@pytest.mark.parametrize("seed", RNG_SEEDS)
def test_umeyama_planar_mirror_image_gets_a_rotation_not_a_reflection(seed):
    """Mirroring a planar figure in its own plane is undone by a half turn, never a reflection.

    ``diag(1, −1, 1)`` maps the plane z = 0 onto itself as ``diag(1, −1, −1)`` (a rotation by π
    about x) does: both fit the positions exactly, only the rotation is an answer.
    """
    p = _planar_positions(seed)
    mirrored = p * np.array([1.0, -1.0, 1.0])
    for kind in ("se3", "sim3"):
        B = traj.umeyama(mirrored, p, kind)
        assert np.linalg.det(B.R_ref_est) == pytest.approx(1.0, abs=1e-12)
        np.testing.assert_allclose(B.R_ref_est, np.diag([1.0, -1.0, -1.0]), atol=1e-10)
        np.testing.assert_allclose((B.scale * p) @ B.R_ref_est.T + B.t_ref_est, mirrored, atol=1e-9)


@pytest.mark.parametrize("plane_seed", range(6))
def test_umeyama_on_a_tilted_planar_trajectory_both_null_vector_signs(plane_seed):
    """A plane in any attitude: the SVD's null vectors come with either sign, R stays proper."""
    rng = np.random.default_rng(plane_seed)
    tilt = so3.exp(rng.normal(size=3))
    dets = set()
    for seed in range(8):
        p = _planar_positions(seed) @ tilt.T
        A = _known("sim3", seed)
        q = (A.scale * p) @ A.R_ref_est.T + A.t_ref_est
        u, _, vt = np.linalg.svd((q - q.mean(0)).T @ (p - p.mean(0)))
        dets.add(bool(np.linalg.det(u) * np.linalg.det(vt) < 0))
        B = traj.umeyama(q, p, "sim3")
        assert np.linalg.det(B.R_ref_est) == pytest.approx(1.0, abs=1e-12)
        np.testing.assert_allclose(B.R_ref_est, A.R_ref_est, atol=1e-9)
        assert B.scale == pytest.approx(A.scale, rel=1e-11)
    assert dets  # the branch is exercised; which sign comes out is LAPACK's choice


@pytest.mark.parametrize("with_scale", [False, True])
@pytest.mark.parametrize("seed", range(6))
def test_umeyama_on_planar_trajectory_agrees_with_evo(with_scale, seed):
    geometry = pytest.importorskip("evo.core.geometry")
    rng = np.random.default_rng(seed)
    p = _planar_positions(seed)
    A = _known("sim3" if with_scale else "se3", seed)
    q = (A.scale * p) @ A.R_ref_est.T + A.t_ref_est + rng.normal(size=p.shape) * 0.01
    r, t, c = geometry.umeyama_alignment(p.T, q.T, with_scale)  # evo: estimate first
    B = traj.umeyama(q, p, "sim3" if with_scale else "se3")
    np.testing.assert_allclose(B.R_ref_est, r, atol=1e-10)
    np.testing.assert_allclose(B.t_ref_est, t, atol=1e-8)
    assert B.scale == pytest.approx(c, rel=1e-12)


@pytest.mark.parametrize("kind", ["se3", "sim3", "4dof"])
@pytest.mark.parametrize("unit", [1e-300, 1e-150, 1e150, 1e300])
def test_umeyama_on_planar_trajectory_at_extreme_position_scales(kind, unit):
    """The same planar alignment with positions in any unit float64 holds: R, s unchanged."""
    p = _planar_positions(3)
    A = _known(kind, 3)
    q = (A.scale * p) @ A.R_ref_est.T + A.t_ref_est
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        B = traj.umeyama(q * unit, p * unit, kind)
    np.testing.assert_allclose(B.R_ref_est, A.R_ref_est, atol=1e-10)
    np.testing.assert_allclose(B.t_ref_est / unit, A.t_ref_est, rtol=1e-10, atol=1e-8)
    assert B.scale == pytest.approx(A.scale, rel=1e-12)


@pytest.mark.parametrize("ratio_exp", [-250, -200, 200, 250])
def test_umeyama_sim3_scale_between_spreads_far_apart_is_recovered(ratio_exp):
    """A Sim(3) whose scale is 1e±200 is a float64 number: recovered, not refused as overflow."""
    p = _planar_positions(4)
    R = so3.exp([0.3, -0.2, 1.0])
    s = 10.0**ratio_exp
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        B = traj.umeyama((s * p) @ R.T, p, "sim3")
    assert B.scale == pytest.approx(s, rel=1e-12)
    np.testing.assert_allclose(B.R_ref_est, R, atol=1e-10)


# ----------------------------------------------------------------------------- no warning leaks


def _circle(n: int = 30, unit: float = 1.0) -> np.ndarray:
    s = np.linspace(0.0, 6.0, n)
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, 3] = unit * np.column_stack([np.cos(s), np.sin(s), 0.1 * s])
    return T


#: Finite results from finite inputs, computed without a numpy warning on the way.
QUIET = {
    "rpe_by_path_length": lambda: traj.rpe(_circle(), _circle(unit=1e300), 1.0, "m")[0],
    "rpe_pairs_by_path_length": lambda: traj.rpe_pairs(_circle(unit=1e300), 1.0, "m"),
    "kitti_segments": lambda: (
        traj.kitti_segment_errors(_circle(unit=1e300), _circle(), [1.0]).translation_percent
    ),
    "align_4dof_units_far_apart": lambda: traj.align(_circle(unit=1e150), _circle(), "4dof").matrix,
    "align_sim3_units_far_apart": lambda: traj.align(_circle(unit=1e200), _circle(), "sim3").matrix,
    "align_tiny_positions": lambda: traj.align(_circle(unit=1e-300), _circle(unit=1e-300)).matrix,
}

#: Finite inputs whose result float64 cannot hold: a ValueError, and no numpy warning before it.
LEAKS = {
    "path_length_overflow": lambda: traj.rpe_pairs(_circle(unit=1e308), 1.0, "m"),
    "kitti_path_length_overflow": lambda: traj.kitti_segment_errors(
        _circle(unit=1e308), _circle(), [1.0]
    ),
    "alignment_apply_overflow": lambda: traj.Alignment("sim3", np.eye(3), np.zeros(3), 1e200).apply(
        _circle(unit=1e200)
    ),
    "alignment_transform_covariance_overflow": lambda: traj.Alignment(
        "se3", so3.exp([0.0, 0.0, 1.0]), np.zeros(3)
    ).transform_covariance(_circle(unit=1e200), np.tile(np.eye(6), (30, 1, 1)), "barfoot"),
    "statistics_sse_overflow": lambda: traj.statistics(np.array([1e300, -1e300, 1e300])),
    "nees_overflow": lambda: traj.nees(
        _circle(), _circle(unit=1e300), np.tile(1e-4 * np.eye(6), (30, 1, 1)), "gtsam"
    ),
    "convert_covariance_overflow": lambda: lb.convert_covariance(
        np.eye(6), _circle(unit=1e300), "gtsam", "barfoot"
    ),
    "sim3_exp_underflowing_scale": lambda: sim3.exp(np.array([0, 0, 0, 1, 1, 1, -800.0])),
}


@pytest.mark.parametrize("name", list(QUIET))
def test_no_numpy_warning_from_extreme_but_representable_inputs(name):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = QUIET[name]()
    assert np.isfinite(out).all()


@pytest.mark.parametrize("name", list(LEAKS))
def test_no_numpy_warning_leaks_before_the_clear_error(name):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError) as info:
            LEAKS[name]()
    assert "overflow" in str(info.value) or "underflow" in str(info.value)


def _sim3(scale: float) -> np.ndarray:
    S = np.eye(4)
    S[:3, :3] = scale * so3.exp([0.2, -0.4, 0.9])
    S[:3, 3] = [1.0, -2.0, 3.0]
    return S


@pytest.mark.parametrize("scale", [1e-200, 1e200])
def test_no_numpy_warning_leaks_from_sim3_inverse_of_an_extreme_scale(scale):
    S = _sim3(scale)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Si = sim3.inverse(S)
    np.testing.assert_allclose(sim3.log(Si)[6], -np.log(scale), rtol=1e-12)  # scale 1/s
    np.testing.assert_allclose(Si[:3, :3] * scale, S[:3, :3].T / scale, rtol=1e-12, atol=1e-15)


def test_no_numpy_warning_leaks_from_sim3_exp_of_an_overflowing_scale():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match="overflow"):
            sim3.exp(np.array([0, 0, 0, 1, 1, 1, 710.0]))


# ----------------------------------------------------------------------------- CI coverage

_ROOT = Path(__file__).resolve().parents[1]
#: Libraries whose tests cannot run in the README's test environment, and the marker (``-k``)
#: CI selects their tests by: sophuspy needs numpy < 2 (its own virtual environment),
#: projectaria_tools comes with the ``libs`` extra.
_OWN_ENV_LIBS = {"sophuspy": "sophuspy", "projectaria_tools": "projectaria"}


def _ci_pytest_steps() -> list[str]:
    """The pytest command lines of ``.ci/run``, continuation lines joined."""
    text = (_ROOT / ".ci" / "run").read_text().replace("\\\n", " ")
    return [ln for ln in text.splitlines() if "-m pytest" in ln and not ln.lstrip().startswith("#")]


@pytest.mark.parametrize("lib", list(_OWN_ENV_LIBS))
def test_ci_runs_the_sophus_object_tests_in_their_own_environment(lib):
    """Every test file that uses ``lib``'s objects is named in a CI step that selects them."""
    users = sorted(
        p.name
        for p in (_ROOT / "tests").glob("test_*.py")
        if f'importorskip("{lib}' in p.read_text(encoding="utf-8")
    )
    assert users, f"no test file imports {lib}"
    steps = [s for s in _ci_pytest_steps() if f"-k {_OWN_ENV_LIBS[lib]}" in s]
    assert steps, f".ci/run has no pytest step selecting -k {_OWN_ENV_LIBS[lib]}"
    missing = [f for f in users if not any(f"tests/{f}" in s for s in steps)]
    assert not missing, f"{lib}: {missing} never run in CI (steps: {steps})"
    if lib == "sophuspy":  # numpy < 2: the step must run in the numpy-1 environment
        assert all(".ci-venv-np1/bin/python" in s for s in steps)


@pytest.mark.parametrize("name", ["jr", "jl", "jr_inv", "jl_inv"])
def test_no_numpy_warning_leaks_from_se3_jacobians_of_a_huge_twist(name):
    from liebridge.lie import se3

    xi = np.array([1e8, -1e-12, 30.0, -1e300, -1e-300, 1e-300])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match="overflow"):
            getattr(se3, name)(xi)
