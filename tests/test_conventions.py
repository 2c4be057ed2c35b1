"""One harness over every preset × batch shape: round trips, first-order maps, validation."""

import itertools

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import liebridge as lb
from liebridge import conventions as C
from liebridge.check import numerical_jacobian
from liebridge.lie import se3, so3

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
