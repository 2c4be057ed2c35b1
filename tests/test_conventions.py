"""One harness over every preset × batch shape: round trips, first-order maps, validation.

Also here (folded in from its twin file): Conventions of SO(2), SE(2), Sim(3) and SE₂(3): one
engine, checked per preset and per chart.
"""

from __future__ import annotations

import itertools
import math

import gtsam
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import liebridge as lb
from liebridge import conventions as C
from liebridge import lie
from liebridge.check import monte_carlo_covariance, numerical_jacobian
from liebridge.conventions.convention import Convention
from liebridge.lie import se2, se3, se23, sim3, so2, so3

PRESETS = list(C.PRESETS)
SHAPES = [(), (4,), (2, 3)]


def random_poses(rng, shape, trans=30.0):
    w = rng.normal(size=(*shape, 3))
    w *= (rng.uniform(0, np.pi - 1e-3, size=shape) / np.linalg.norm(w, axis=-1))[..., None]
    return se3.exp(np.concatenate([w, rng.uniform(-trans, trans, size=(*shape, 3))], axis=-1))


def small_tangent(rng, shape, conv, n=6, scale=0.4):
    # inside every chart's domain: ‖r‖ < 1 for quat_vec, rotation angle < π for all
    return rng.uniform(-scale, scale, size=(*shape, n))


@pytest.mark.parametrize("conv", PRESETS, ids=lambda c: c.name)
@pytest.mark.parametrize("shape", SHAPES, ids=str)
def test_local_retract_round_trip(conv, shape):
    rng = np.random.default_rng(1)
    X = random_poses(rng, shape)
    d = small_tangent(rng, shape, conv)
    Y = conv.retract(X, d)
    np.testing.assert_allclose(conv.local(X, Y), d, atol=1e-12 * 30, rtol=0)
    # retract(X, local(X, Y)) == Y for a Y near X
    Y2 = conv.retract(X, small_tangent(rng, shape, conv))
    np.testing.assert_allclose(conv.retract(X, conv.local(X, Y2)), Y2, atol=1e-12 * 30, rtol=0)


@pytest.mark.parametrize("conv", PRESETS, ids=lambda c: c.name)
@pytest.mark.parametrize("shape", SHAPES, ids=str)
def test_rotation_round_trip(conv, shape):
    rng = np.random.default_rng(2)
    R = random_poses(rng, shape)[..., :3, :3]
    d = small_tangent(rng, shape, conv, n=3)
    np.testing.assert_allclose(conv.local(R, conv.retract(R, d)), d, atol=1e-13, rtol=0)


@pytest.mark.parametrize("conv", PRESETS, ids=lambda c: c.name)
def test_batched_equals_elementwise(conv):
    rng = np.random.default_rng(3)
    X = random_poses(rng, (2, 3))
    d = small_tangent(rng, (2, 3), conv)
    Y = conv.retract(X, d)
    for i, j in itertools.product(range(2), range(3)):
        np.testing.assert_array_equal(Y[i, j], conv.retract(X[i, j], d[i, j]))
    np.testing.assert_array_equal(conv.to_canonical(X)[1, 2], conv.to_canonical(X[1, 2]))


@pytest.mark.parametrize("src", PRESETS, ids=lambda c: c.name)
@pytest.mark.parametrize(
    "dst",
    [C.GTSAM, C.SOPHUS, C.BARFOOT, C.SYMFORCE, C.G2O, C.CERES_POSE, C.ROS, C.GTSAM_CAYLEY],
    ids=lambda c: c.name,
)
def test_tangent_map_equals_finite_differences(src, dst):
    rng = np.random.default_rng(4)
    X = random_poses(rng, (), trans=5.0)
    M = lb.tangent_map(X, src, dst)
    M_fd = numerical_jacobian(lambda Y: Y, X, retract=src.retract, local=dst.local)
    np.testing.assert_allclose(M, M_fd, atol=1e-7, rtol=0)  # FD error ~ eps²·|T| + 1e-16/eps
    R = X[:3, :3]
    M3 = lb.tangent_map(R, src, dst)
    M3_fd = numerical_jacobian(lambda Y: Y, R, retract=src.retract, local=dst.local)
    np.testing.assert_allclose(M3, M3_fd, atol=1e-8, rtol=0)


@pytest.mark.parametrize("conv", PRESETS, ids=lambda c: c.name)
def test_to_from_canonical_are_inverse(conv):
    X = random_poses(np.random.default_rng(5), (3,))
    np.testing.assert_allclose(
        conv.from_canonical(X) @ conv.to_canonical(X),
        np.broadcast_to(np.eye(6), (3, 6, 6)),
        atol=1e-12,
    )


@pytest.mark.parametrize("name", ["θ=0", "θ=1e-12", "near π", "exactly π"])
@pytest.mark.parametrize("conv", PRESETS, ids=lambda c: c.name)
def test_edge_case_poses(conv, name):
    angle = {"θ=0": 0.0, "θ=1e-12": 1e-12, "near π": np.pi - 1e-6, "exactly π": np.pi}[name]
    axis = np.array([1.0, 1.0, 1.0]) / np.sqrt(3)
    X = se3.exp(np.r_[angle * axis, 30.0, -30.0, 30.0])
    d = np.array([0.01, -0.02, 0.03, 0.2, -0.1, 0.05])
    Y = conv.retract(X, d)
    assert np.isfinite(Y).all()
    np.testing.assert_allclose(conv.local(X, Y), d, atol=1e-11)


def test_first_order_maps_of_the_reference_table():
    """docs/library-facts.md, "First-order maps from a GTSAM tangent" — all rows."""
    rng = np.random.default_rng(6)
    X = random_poses(rng, ())
    R, t = X[:3, :3], X[:3, 3]
    Id, Z = np.eye(3), np.zeros((3, 3))
    P = np.block([[Z, Id], [Id, Z]])
    Ad = np.block([[R, Z], [so3.hat(t) @ R, R]])
    table = {
        "sophus": P,
        "manif": P,
        "pinocchio": P,
        "jaxlie": P,
        "theseus": P,
        "barfoot": P @ Ad,
        "pypose": P @ Ad,
        "lietorch": P @ Ad,
        "dpvo": -P,
        "pytransform3d_global": Ad,
        "symforce": np.block([[Id, Z], [Z, R]]),
        "ros": np.block([[Z, R], [R, Z]]),
        "g2o": np.block([[Z, Id], [Id / 2, Z]]),
    }
    for name, expected in table.items():
        np.testing.assert_allclose(
            lb.tangent_map(X, "gtsam", name), expected, atol=1e-14, err_msg=name
        )
    # Ceres QuaternionManifold rotation block [R/2, 0]: on a pose, rows of the rotation block
    np.testing.assert_allclose(
        lb.tangent_map(X, "gtsam", "ceres_pose")[:3], np.hstack([R / 2, Z]), atol=1e-14
    )
    np.testing.assert_allclose(lb.tangent_map(R, "gtsam", "ceres_quaternion"), R / 2, atol=1e-14)


def test_ros_is_not_left_se3():
    """The tempting ROS covariance map P·Ad_X is wrong: translation and rotation decouple."""
    X = random_poses(np.random.default_rng(7), ())
    M = lb.tangent_map(X, "gtsam", "ros")
    wrong = lb.tangent_map(X, "gtsam", "barfoot")  # P·Ad_X
    assert np.abs(M - wrong).max() > 1.0


def test_invalid_combination_explains_why():
    with pytest.raises(ValueError, match="needs rotation='exp'"):
        lb.Convention("bad", "right", "rot_first", "se3", "half_exp", "wxyz")
    with pytest.raises(ValueError, match="side"):
        lb.Convention("bad", "middle", "rot_first", "se3", "exp", "wxyz")


def test_unknown_name_suggests_closest():
    with pytest.raises(ValueError, match="did you mean 'sophus'"):
        C.get("sohpus")
    with pytest.raises(TypeError):
        C.get(3)


def test_names_cover_the_required_presets():
    required = """gtsam gtsam_cayley sophus manif pinocchio pinocchio_r3xso3 jaxlie theseus pypose
    barfoot pytransform3d_global pytransform3d_local symforce ceres_quaternion
    ceres_eigen_quaternion ceres_pose g2o g2o_expmap ros mr_body mr_space""".split()
    assert set(required) <= set(C.names())
    for c in C.PRESETS:
        assert c.source and c.notes, c.name


def test_quat_vec_domain_error_names_index():
    X = np.broadcast_to(np.eye(4), (3, 4, 4))
    d = np.zeros((3, 6))
    d[2, 3:] = [0.9, 0.9, 0.0]
    with pytest.raises(ValueError, match=r"index \(2,\)"):
        C.G2O.retract(X, d)


def test_inputs_not_mutated():
    rng = np.random.default_rng(8)
    X = random_poses(rng, (3,))
    d = small_tangent(rng, (3,), None)
    X0, d0 = X.copy(), d.copy()
    for c in C.PRESETS:
        c.local(X, c.retract(X, d))
        c.to_canonical(X)
    np.testing.assert_array_equal(X, X0)
    np.testing.assert_array_equal(d, d0)


@given(
    st.sampled_from(PRESETS),
    st.lists(st.floats(-0.45, 0.45), min_size=6, max_size=6),
    st.lists(st.floats(-3.1, 3.1), min_size=3, max_size=3),
    st.lists(st.floats(-30, 30), min_size=3, max_size=3),
)
def test_property_round_trip(conv, d, w, t):
    X = se3.exp(np.r_[w, t])
    d = np.array(d)
    np.testing.assert_allclose(conv.local(X, conv.retract(X, d)), d, atol=1e-10)


@pytest.mark.parametrize("conv", PRESETS, ids=lambda c: c.name)
def test_every_preset_self_detects(conv):
    assert lb.detect_convention(conv.retract, prefer=conv.name) is conv


def test_detection_tells_apart_first_order_twins():
    """half_exp vs quat_vec and se3 vs so3xr3_body agree to first order; detection must not."""
    for a, b in [
        (C.CERES_POSE, lb.Convention("x", "left", "rot_first", "so3xr3_world", "quat_vec", "wxyz")),
        (C.GTSAM, lb.Convention("y", "right", "rot_first", "so3xr3_body", "exp", "wxyz")),
        (C.SYMFORCE, lb.Convention("z", "right", "rot_first", "so3xr3_body", "exp", "wxyz")),
    ]:
        assert lb.detect_convention(a.retract).fields == a.fields
        assert lb.detect_convention(b.retract).fields == b.fields


def test_detection_rotation_group():
    got = lb.detect_convention(C.CERES_QUATERNION.retract, group="so3", prefer="ceres_quaternion")
    assert got is C.CERES_QUATERNION
    assert lb.detect_convention(C.GTSAM.retract, group="so3").side == "right"


def test_detection_failure_reports_measurement():
    def weird(X, d):
        return C.GTSAM.retract(X, 2.0 * d)  # no convention scales the translation by 2

    with pytest.raises(C.ConventionNotDetected, match="first-order map"):
        lb.detect_convention(weird)


# --------------------------------------------------------------------------- conventions_groups
# Conventions of SO(2), SE(2), Sim(3) and SE₂(3): one engine, checked per preset and per chart.
#
# Every preset of the new groups and every (side, order, chart, rotation) the model allows for
# them: round trips, first-order maps against central differences of the retract/local they
# claim, batching, Monte Carlo agreement of covariance conversions (linear and unscented), the
# GTSAM Pose2 marginal → ROS 6×6 acceptance case, ``detect_convention`` on the libraries' own
# retractions, and bad input.

NEW_GROUPS = ("so2", "se2", "sim3", "se23")
_PROBE = {
    "so2": lambda rng: so2.exp(rng.uniform(-3, 3, 1)),
    "se2": lambda rng: se2.exp(np.r_[rng.uniform(-20, 20, 2), rng.uniform(-3, 3)]),
    "sim3": lambda rng: sim3.exp(
        np.r_[rng.uniform(-1.5, 1.5, 3), rng.uniform(-5, 5, 3), rng.uniform(-1, 1)]
    ),
    "se23": lambda rng: se23.exp(np.r_[rng.uniform(-1.5, 1.5, 3), rng.uniform(-10, 10, 6)]),
}


def _all_conventions() -> list[Convention]:
    out = []
    for g in NEW_GROUPS:
        rots = ("exp",) if g in ("so2", "se2") else ("exp", "half_exp", "quat_vec", "cayley")
        for side, order, chart, rot in itertools.product(
            ("right", "left"), ("rot_first", "trans_first"), lie.group(g).charts, rots
        ):
            if chart == g and rot != "exp":
                continue
            out.append(
                Convention(
                    f"{g}/{side}/{order}/{chart}/{rot}", side, order, chart, rot, "wxyz", group=g
                )
            )  # type: ignore[arg-type]
    return out


ALL = list(C.GROUP_PRESETS) + _all_conventions()
IDS = [c.name for c in ALL]
PRESET_IDS = [c.name for c in C.GROUP_PRESETS]


def _increment(conv: Convention, rng: np.random.Generator, scale: float = 0.3) -> np.ndarray:
    d = rng.uniform(-scale, scale, conv.dim())
    if conv.embed is not None:  # only the group's coordinates move the element
        mask = np.zeros(conv.dim(), dtype=bool)
        mask[list(conv.embed.index)] = True
        d[~mask] = 0.0
    return d


def _canonical(group: str) -> Convention:
    return {"so2": C.GTSAM_ROT2, "se2": C.GTSAM_POSE2, "sim3": C.GTSAM_SIMILARITY3}.get(
        group, Convention("se23_exp", "right", "rot_first", "se23", "exp", "wxyz", group="se23")
    )


@pytest.mark.parametrize("conv", ALL, ids=IDS)
def test_round_trip_and_first_order_maps(conv: Convention) -> None:
    rng = np.random.default_rng(abs(hash(conv.name)) % 2**32)
    X = _PROBE[conv.group](rng)
    for _ in range(3):
        d = _increment(conv, rng)
        Y = conv.retract(X, d)
        np.testing.assert_allclose(conv.local(X, Y), d, atol=1e-10)
    # to_canonical: derivative of the group's canonical local through this convention's retract
    can = _canonical(conv.group)
    M = numerical_jacobian(lambda Z: Z, X, retract=conv.retract, local=can.local, dim=conv.dim())
    np.testing.assert_allclose(conv.to_canonical(X), M, atol=2e-7 * max(1, np.abs(X).max()))
    n = M.shape[0]
    np.testing.assert_allclose(conv.to_canonical(X) @ conv.from_canonical(X), np.eye(n), atol=1e-10)
    # local_jacobian at Y ≠ X in its own chart
    Y = conv.retract(X, _increment(conv, rng, 0.5))
    J = numerical_jacobian(
        lambda Z: Z, Y, retract=conv.retract, local=lambda _y, Z: conv.local(X, Z), dim=conv.dim()
    )
    np.testing.assert_allclose(conv.local_jacobian(X, Y), J, atol=2e-7 * max(1, np.abs(X).max()))


@pytest.mark.parametrize("group", NEW_GROUPS)
def test_tangent_map_between_every_pair_against_finite_differences(group: str) -> None:
    rng = np.random.default_rng(7)
    convs = [c for c in ALL if c.group == group]
    pairs = list(itertools.product(convs, convs))
    idx = rng.choice(len(pairs), size=min(40, len(pairs)), replace=False)
    X = _PROBE[group](rng)
    for k in idx:
        a, b = pairs[k]
        M = numerical_jacobian(lambda Z: Z, X, retract=a.retract, local=b.local, dim=a.dim())
        T = lb.tangent_map(X, a, b)
        np.testing.assert_allclose(
            T, M, atol=2e-7 * max(1, np.abs(X).max()), err_msg=f"{a.name}→{b.name}"
        )
        if C.is_exactly_linear(a, b):
            d = _increment(a, rng)
            np.testing.assert_allclose(
                lb.convert_tangent(d, X, a, b), T @ d, atol=1e-9, err_msg=f"{a.name}→{b.name}"
            )


@pytest.mark.parametrize("conv", C.GROUP_PRESETS, ids=PRESET_IDS)
def test_batched_equals_elementwise_every_group(conv: Convention) -> None:
    rng = np.random.default_rng(3)
    X = np.stack([_PROBE[conv.group](rng) for _ in range(4)]).reshape(
        2, 2, *_PROBE[conv.group](rng).shape
    )
    d = np.stack([_increment(conv, rng) for _ in range(4)]).reshape(2, 2, -1)
    Y = conv.retract(X, d)
    T = lb.tangent_map(X, conv, _canonical(conv.group))
    L = conv.local(X, Y)
    for i in np.ndindex(2, 2):
        np.testing.assert_allclose(Y[i], conv.retract(X[i], d[i]), atol=1e-14)
        np.testing.assert_allclose(L[i], conv.local(X[i], Y[i]), atol=1e-14)
        np.testing.assert_allclose(
            T[i], lb.tangent_map(X[i], conv, _canonical(conv.group)), atol=1e-14
        )


# ----------------------------------------------------------------------------- Monte Carlo
_MC_PAIRS = [
    ("gtsam_pose2", "symforce_pose2"),
    ("gtsam_pose2", "g2o_se2"),
    ("g2o_se2", "ros_pose2"),
    ("gtsam_similarity3", "sophus_sim3"),
    ("gtsam_similarity3", "g2o_sim3"),
    ("pypose_sim3", "gtsam_similarity3"),
    ("gtsam_navstate", "manif_se23"),
    ("manif_se23", "gtsam_navstate"),
    ("gtsam_rot2", "gtsam_rot2"),
]


@pytest.mark.parametrize(("src", "dst"), _MC_PAIRS)
def test_covariance_conversion_matches_monte_carlo(src: str, dst: str) -> None:
    a, b = C.get(src), C.get(dst)
    rng = np.random.default_rng(11)
    X = _PROBE[a.group](rng)
    n = a.dim()
    A = rng.normal(size=(n, n)) * 0.08
    S = A @ A.T + 1e-4 * np.eye(n)
    if a.embed is not None:
        keep = np.zeros(n, dtype=bool)
        keep[list(a.embed.index)] = True
        S[~keep, :] = 0.0
        S[:, ~keep] = 0.0
    mc = monte_carlo_covariance(S, X, a, b, n=200_000, rng=np.random.default_rng(5))
    lin = lb.convert_covariance(S, X, a, b)
    uns = lb.convert_covariance(S, X, a, b, method="unscented")
    scale = np.abs(mc).max()
    # sampling error of 2e5 samples ≈ 0.3 % of the entries; linearisation error is O(σ⁴)
    np.testing.assert_allclose(uns, mc, atol=0.02 * scale)
    np.testing.assert_allclose(lin, mc, atol=0.05 * scale)
    if C.is_exactly_linear(a, b):
        np.testing.assert_allclose(uns, lin, atol=1e-10 * scale)
    info = np.linalg.inv(S) if a.embed is None else None
    if info is not None and b.embed is None:
        np.testing.assert_allclose(
            lb.convert_information(info, X, a, b),
            np.linalg.inv(lin),
            rtol=1e-7,
            atol=1e-7 * np.abs(np.linalg.inv(lin)).max(),
        )


def test_gtsam_pose2_marginal_to_ros_6x6() -> None:
    graph = gtsam.NonlinearFactorGraph()
    noise0 = gtsam.noiseModel.Diagonal.Sigmas(np.array([0.05, 0.05, 0.02]))
    odo = gtsam.noiseModel.Diagonal.Sigmas(np.array([0.2, 0.1, 0.1]))
    graph.add(gtsam.PriorFactorPose2(0, gtsam.Pose2(0, 0, 0), noise0))
    steps = [gtsam.Pose2(2.0, 0.0, math.pi / 2)] * 3
    vals = gtsam.Values()
    pose = gtsam.Pose2(0, 0, 0)
    vals.insert(0, pose)
    for k, s in enumerate(steps):
        graph.add(gtsam.BetweenFactorPose2(k, k + 1, s, odo))
        pose = pose.compose(s)
        vals.insert(k + 1, pose)
    key = 3
    S = gtsam.Marginals(graph, vals).marginalCovariance(key)
    P = vals.atPose2(key)
    X = P.matrix()
    ros = lb.convert_covariance(S, X, "gtsam_pose2", "ros_pose2")
    assert ros.shape == (6, 6)
    for i in (2, 3, 4):  # z, roll, pitch: no cross terms, no variance
        assert not ros[i].any() and not ros[:, i].any()
    # Monte Carlo with GTSAM's own retraction, read as ROS does: parent-frame x, y and yaw
    rng = np.random.default_rng(1)
    d = rng.multivariate_normal(np.zeros(3), S, size=100_000)
    samples = np.array([[Q.x(), Q.y(), Q.theta()] for Q in (P.retract(di) for di in d)])
    samples[:, 2] = np.unwrap(samples[:, 2] - P.theta()) + P.theta()
    mc = np.cov(samples.T)
    sub = ros[np.ix_([0, 1, 5], [0, 1, 5])]
    np.testing.assert_allclose(sub, mc, rtol=0.03, atol=0.02 * np.abs(mc).max())
    assert ros.ravel()[35] == pytest.approx(mc[2, 2], rel=0.03)  # yaw variance at flat index 35
    # the tempting layout is wrong: GTSAM's (x, y, θ) block is body-frame, not parent-frame
    assert np.abs(S[:2, :2] - mc[:2, :2]).max() > 0.1 * np.abs(mc).max()
    # and back: the 6×6 converts to GTSAM's 3×3
    np.testing.assert_allclose(
        lb.convert_covariance(ros, X, "ros_pose2", "gtsam_pose2"), S, atol=1e-12
    )


# ----------------------------------------------------------------------------- detection
def _pose2_of(X: np.ndarray) -> gtsam.Pose2:
    return gtsam.Pose2(X[0, 2], X[1, 2], math.atan2(X[1, 0], X[0, 0]))


def test_detect_gtsam_retractions() -> None:
    assert (
        C.detect_convention(lambda X, d: _pose2_of(X).retract(d).matrix(), group="se2")
        is C.GTSAM_POSE2
    )

    def sim(X: np.ndarray, d: np.ndarray) -> gtsam.Similarity3:
        s = np.cbrt(np.linalg.det(X[:3, :3]))
        return gtsam.Similarity3(gtsam.Rot3(X[:3, :3] / s), X[:3, 3] / s, s).retract(d)

    assert lb.detect_convention(sim, group="sim3") is C.GTSAM_SIMILARITY3
    nav = lambda X, d: gtsam.NavState(gtsam.Rot3(X[:3, :3]), X[:3, 3], X[:3, 4]).retract(d)  # noqa: E731
    assert lb.detect_convention(nav, group="se23") is C.GTSAM_NAVSTATE
    rot2 = lambda X, d: gtsam.Rot2.fromAngle(math.atan2(X[1, 0], X[0, 0])).retract(d).matrix()  # noqa: E731
    assert lb.detect_convention(rot2, group="so2") is C.GTSAM_ROT2


def test_detect_symforce_pose2() -> None:
    sym = pytest.importorskip("sym")

    def retract(X: np.ndarray, d: np.ndarray) -> np.ndarray:
        P = sym.Pose2(R=sym.Rot2.from_angle(math.atan2(X[1, 0], X[0, 0])), t=X[:2, 2].tolist())
        Q = P.retract(np.asarray(d), 1e-12)
        out = np.eye(3)
        out[:2, :2] = Q.R.to_rotation_matrix()
        out[:2, 2] = np.asarray(Q.t).ravel()
        return out

    assert lb.detect_convention(retract, group="se2") is C.SYMFORCE_POSE2


@pytest.mark.parametrize(
    "conv", [c for c in C.GROUP_PRESETS if c.embed is None], ids=lambda c: c.name
)
def test_detect_recognises_each_preset(conv: Convention) -> None:
    found = lb.detect_convention(conv.retract, group=conv.group, prefer=conv.name)  # type: ignore[arg-type]
    assert found is conv


# ----------------------------------------------------------------------------- bad input
def test_bad_input_names_argument_index_and_violation() -> None:
    R3 = se23.exp(np.r_[0.1, 0.2, 0.3, np.zeros(6)])[:3, :3]
    with pytest.raises(ValueError, match=r"X: not a valid SE\(2\) element at batch index \(\)"):
        C.GTSAM_POSE2.retract(R3, np.zeros(3))
    with pytest.raises(
        ValueError, match=r"X: its rotation block is not a rotation at batch index \(1,\)"
    ):
        lb.convert_covariance(
            np.eye(3), np.stack([np.eye(3), np.diag([2.0, 1.0, 1.0])]), "gtsam_pose2", "sophus_se2"
        )
    bad = np.eye(4)
    bad[:3, :3] *= -1.5
    with pytest.raises(ValueError, match=r"scale s = .* ≤ 0"):
        lb.tangent_map(bad, "gtsam_similarity3", "sophus_sim3")
    G = gtsam.Similarity3(gtsam.Rot3(), np.ones(3), 2.0).matrix()
    with pytest.raises(ValueError, match=r"divide by X\[3, 3\]"):
        C.get("g2o_sim3").local(G, G)
    with pytest.raises(ValueError, match="different groups"):
        lb.convert_covariance(np.eye(3), np.eye(3), "gtsam_pose2", "gtsam")
    with pytest.raises(ValueError, match=r"cov: expected shape \(\.\.\., 7, 7\)"):
        lb.convert_covariance(np.eye(6), np.eye(4), "gtsam_similarity3", "sophus_sim3")
    with pytest.raises(ValueError, match=r"d: expected shape \(\.\.\., 9\)"):
        C.GTSAM_NAVSTATE.retract(np.eye(5), np.zeros(6))
    with pytest.raises(ValueError, match=r"rotation must be 'exp'"):
        Convention("x", "right", "rot_first", "split_body", "cayley", "wxyz", group="se2")
    with pytest.raises(ValueError, match=r"Convention.chart"):
        Convention("x", "right", "rot_first", "se3", "exp", "wxyz", group="sim3")


@pytest.mark.parametrize("group", NEW_GROUPS)
@settings(max_examples=30)
@given(data=st.data())
def test_fuzz_either_a_finite_answer_or_one_clear_error(group: str, data: st.DataObject) -> None:
    conv = {"so2": C.GTSAM_ROT2, "se2": C.G2O_SE2, "sim3": C.SOPHUS_SIM3, "se23": C.MANIF_SE23}[
        group
    ]
    k = {"so2": 2, "se2": 3, "sim3": 4, "se23": 5}[group]
    vals = st.one_of(st.floats(-1e6, 1e6), st.sampled_from([0.0, 1.0, -1.0, np.nan, np.inf, 1e308]))
    X = np.array(data.draw(st.lists(vals, min_size=k * k, max_size=k * k))).reshape(k, k)
    if data.draw(st.booleans()):  # a valid element, perturbed a little or not at all
        X = _PROBE[group](np.random.default_rng(data.draw(st.integers(0, 100))))
    d = np.array(data.draw(st.lists(vals, min_size=conv.dim(), max_size=conv.dim())))
    for f in (
        lambda: conv.retract(X, d),
        lambda: conv.local(X, X),
        lambda: lb.tangent_map(
            X,
            conv,
            "gtsam_"
            + {"so2": "rot2", "se2": "pose2", "sim3": "similarity3", "se23": "navstate"}[group],
        ),
    ):
        try:
            out = f()
        except (ValueError, TypeError) as exc:
            assert str(exc).split(":")[0]  # names something
            continue
        assert np.isfinite(out).all()


# ----------------------------------------------------------------------------- SE(3) unchanged
def test_se3_users_see_no_change() -> None:
    assert C.GTSAM.group == "se3" and C.get("ros").group == "se3"
    assert len(C.PRESETS) == 24 and C.names()[:24] == [c.name for c in C.PRESETS]
    c = Convention("mine", "right", "rot_first", "so3xr3_body", "exp", "wxyz")
    assert c.group == "se3" and c.fields == ("right", "rot_first", "so3xr3_body", "exp")
    R = se23.exp(np.r_[0.1, 0.2, 0.3, np.zeros(6)])[:3, :3]
    assert C.GTSAM.retract(R, np.array([0.1, 0.0, 0.0])).shape == (3, 3)  # SO(3) part, as before
    assert Convention("x", "right", "rot_first", "split_body", "exp", "wxyz").chart == "so3xr3_body"


@pytest.mark.parametrize(
    ("src", "dst"),
    [
        ("gtsam_pose2", "g2o_se2"),
        ("symforce_pose2", "ros_pose2"),
        ("gtsam_similarity3", "g2o_sim3"),
        ("sophus_sim3", "pypose_sim3"),
        ("gtsam_navstate", "manif_se23"),
    ],
)
def test_convert_jacobian_matches_finite_differences_in_both_conventions(
    src: str, dst: str
) -> None:
    """J of Y = X⁻¹·A (a group input and output) converted = J measured in the other chart."""
    a, b = C.get(src), C.get(dst)
    rng = np.random.default_rng(21)
    X, A = _PROBE[a.group](rng), _PROBE[a.group](rng)

    def f(Z: np.ndarray) -> np.ndarray:
        return np.linalg.inv(Z) @ A

    Y = f(X)
    J_src = numerical_jacobian(f, X, in_convention=a, out_convention=a)
    J_dst = numerical_jacobian(f, X, in_convention=b, out_convention=b)
    conv = lb.convert_jacobian(J_src, X, a, b, at_output=Y)
    if b.embed is not None:  # the extra ROS coordinates do not move the pose: zero columns/rows
        keep = list(b.embed.index)
        J_dst = J_dst[np.ix_(keep, keep)]
        conv = conv[np.ix_(keep, keep)]
    np.testing.assert_allclose(conv, J_dst, atol=1e-6 * max(1.0, np.abs(J_dst).max()))
