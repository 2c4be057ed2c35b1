"""Pose layouts, checked against pytransform3d, Pinocchio, scipy and hand-built element orders."""

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given
from hypothesis import strategies as st
from pytransform3d.trajectories import pqs_from_transforms, transforms_from_pqs
from pytransform3d.transformations import pq_from_transform, transform_from_pq
from scipy.spatial.transform import Rotation

from liebridge.io import poses

QUAT_LAYOUTS = ["xyz_qxyzw", "xyz_qwxyz", "qxyzw_xyz", "qwxyz_xyz"]


def random_poses(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """Poses built with scipy only (independent of liebridge)."""
    n = int(np.prod(shape)) if shape else 1
    T = np.zeros((n, 4, 4))
    T[:, :3, :3] = Rotation.random(n, random_state=rng).as_matrix()
    T[:, :3, 3] = rng.normal(scale=3.0, size=(n, 3))
    T[:, 3, 3] = 1.0
    return T.reshape((*shape, 4, 4))


def hand_layout(T: np.ndarray, layout: str) -> np.ndarray:
    """Element order written out by hand from the layout's definition (scipy gives xyzw)."""
    flat = T.reshape(-1, 4, 4)
    qx, qy, qz, qw = Rotation.from_matrix(flat[:, :3, :3]).as_quat().T
    x, y, z = flat[:, :3, 3].T
    cols = {
        "xyz_qxyzw": [x, y, z, qx, qy, qz, qw],
        "xyz_qwxyz": [x, y, z, qw, qx, qy, qz],
        "qxyzw_xyz": [qx, qy, qz, qw, x, y, z],
        "qwxyz_xyz": [qw, qx, qy, qz, x, y, z],
    }[layout]
    return np.stack(cols, axis=-1).reshape((*T.shape[:-2], 7))


def w_of(x: np.ndarray, layout: str) -> np.ndarray:
    return x[..., {"xyz_qxyzw": 6, "xyz_qwxyz": 3, "qxyzw_xyz": 3, "qwxyz_xyz": 0}[layout]]


def same_up_to_quaternion_sign(a: np.ndarray, b: np.ndarray, layout: str) -> bool:
    qs = {"xyz_qxyzw": slice(3, 7), "xyz_qwxyz": slice(3, 7)}.get(layout, slice(0, 4))
    flip = np.sign(np.sum(a[..., qs] * b[..., qs], axis=-1))[..., None]
    b2 = b.copy()
    b2[..., qs] = b[..., qs] * flip
    return bool(np.allclose(a, b2, atol=1e-14, rtol=0))


def test_layouts_listed_and_described() -> None:
    assert poses.layouts() == (
        "xyz_qxyzw",
        "xyz_qwxyz",
        "qxyzw_xyz",
        "qwxyz_xyz",
        "kitti",
        "matrix",
    )
    assert "pytransform3d" in poses.describe("xyz_qwxyz")
    assert "jaxlie" in poses.describe("qwxyz_xyz")
    assert "Sophus" in poses.describe("qxyzw_xyz")
    assert "TUM" in poses.describe("xyz_qxyzw") and "Pinocchio" in poses.describe("xyz_qxyzw")
    assert "KITTI" in poses.describe("kitti")


@pytest.mark.parametrize("layout", QUAT_LAYOUTS)
@pytest.mark.parametrize("shape", [(), (5,), (2, 3)])
def test_quaternion_layouts_match_hand_built_order(layout: str, shape: tuple[int, ...]) -> None:
    T = random_poses(np.random.default_rng(1), shape)
    x = hand_layout(T, layout)
    assert np.allclose(poses.to_matrix(x, layout=layout), T, atol=1e-14, rtol=0)
    out = poses.from_matrix(T, layout=layout)
    assert out.shape == (*shape, 7)
    assert same_up_to_quaternion_sign(out, x, layout)
    assert (w_of(out, layout) >= 0).all()


def test_pytransform3d_pq_is_xyz_qwxyz() -> None:
    rng = np.random.default_rng(2)
    T = random_poses(rng, (20,))
    for Ti in T:
        pq = pq_from_transform(Ti)
        assert np.allclose(poses.to_matrix(pq, layout="xyz_qwxyz"), Ti, atol=1e-14, rtol=0)
        assert np.allclose(
            transform_from_pq(poses.from_matrix(Ti, layout="xyz_qwxyz")), Ti, atol=1e-14, rtol=0
        )
        ours = poses.from_matrix(Ti, layout="xyz_qwxyz")
        assert same_up_to_quaternion_sign(ours, pq, "xyz_qwxyz")
    # batched API
    pqs = pqs_from_transforms(T)
    assert np.allclose(poses.to_matrix(pqs, layout="xyz_qwxyz"), transforms_from_pqs(pqs))


def test_pinocchio_xyzquat_is_xyz_qxyzw() -> None:
    for Ti in random_poses(np.random.default_rng(3), (20,)):
        M = pin.SE3(Ti[:3, :3], Ti[:3, 3])
        xyzquat = np.asarray(pin.SE3ToXYZQUAT(M))
        assert np.allclose(poses.to_matrix(xyzquat, layout="xyz_qxyzw"), Ti, atol=1e-14, rtol=0)
        ours = poses.from_matrix(Ti, layout="xyz_qxyzw")
        assert np.allclose(pin.XYZQUATToSE3(ours).homogeneous, Ti, atol=1e-14, rtol=0)
        assert same_up_to_quaternion_sign(ours, xyzquat, "xyz_qxyzw")


def test_quaternion_sign_is_w_nonnegative_near_pi() -> None:
    # rotations by nearly π, where w ≈ 0 and its sign is easy to get wrong
    axes = np.random.default_rng(4).normal(size=(50, 3))
    axes /= np.linalg.norm(axes, axis=-1, keepdims=True)
    ang = np.pi - np.geomspace(1e-12, 1e-2, 50)
    T = np.tile(np.eye(4), (50, 1, 1))
    T[:, :3, :3] = Rotation.from_rotvec(axes * ang[:, None]).as_matrix()
    for layout in QUAT_LAYOUTS:
        x = poses.from_matrix(T, layout=layout)
        assert (w_of(x, layout) >= 0).all()
        assert np.allclose(poses.to_matrix(x, layout=layout), T, atol=1e-14, rtol=0)


def test_kitti_is_row_major_top_block() -> None:
    T = random_poses(np.random.default_rng(5), (4,))
    flat = np.array([[*Ti[0, :4], *Ti[1, :4], *Ti[2, :4]] for Ti in T])
    assert np.array_equal(poses.from_matrix(T, layout="kitti"), flat)
    assert np.array_equal(poses.to_matrix(flat, layout="kitti"), T)


def test_matrix_passthrough_copies_and_validates() -> None:
    T = random_poses(np.random.default_rng(6), (3,))
    out = poses.to_matrix(T, layout="matrix")
    assert np.array_equal(out, T) and out is not T
    out[0, 0, 0] = 7.0
    assert T[0, 0, 0] != 7.0
    bad = T.copy()
    bad[1, :3, :3] *= 1.001
    with pytest.raises(ValueError, match=r"batch index \(1,\)"):
        poses.to_matrix(bad, layout="matrix")
    bad = T.copy()
    bad[2, 3, 0] = 0.5
    with pytest.raises(ValueError, match="bottom row"):
        poses.from_matrix(bad, layout="xyz_qxyzw")


def test_kitti_rejects_non_rotation() -> None:
    flat = np.array([1.0, 0, 0, 1, 0, 1, 0, 2, 0, 0, 1.01, 3])
    with pytest.raises(ValueError, match="not a rotation"):
        poses.to_matrix(flat, layout="kitti")
    # a reflection
    with pytest.raises(ValueError, match="det"):
        poses.to_matrix(np.array([1.0, 0, 0, 0, 0, 1, 0, 0, 0, 0, -1, 0]), layout="kitti")


@pytest.mark.parametrize("layout", QUAT_LAYOUTS)
def test_quaternion_normalised_within_tolerance_only(layout: str) -> None:
    T = random_poses(np.random.default_rng(7), (3,))
    x = poses.from_matrix(T, layout=layout)
    q = {"xyz_qxyzw": slice(3, 7), "xyz_qwxyz": slice(3, 7)}.get(layout, slice(0, 4))
    scaled = x.copy()
    scaled[:, q] *= 1 + 0.9 * poses.QUATERNION_TOL
    R = poses.to_matrix(scaled, layout=layout)[:, :3, :3]
    # normalised: the result is a rotation to machine precision, equal to the unscaled one
    assert np.allclose(np.swapaxes(R, 1, 2) @ R, np.eye(3), atol=1e-15, rtol=0)
    assert np.allclose(R, T[:, :3, :3], atol=1e-15, rtol=0)
    off = x.copy()
    off[1, q] *= 1 + 3e-6
    with pytest.raises(ValueError, match=r"off by 3e-06 at batch index \(1,\)") as exc:
        poses.to_matrix(off, layout=layout)
    assert "tolerance 1e-06" in str(exc.value)
    # an explicit looser tolerance accepts it
    assert poses.to_matrix(off, layout=layout, tol=1e-5).shape == (3, 4, 4)


def test_unknown_layout_suggests_closest() -> None:
    with pytest.raises(ValueError, match="did you mean 'xyz_qwxyz'"):
        poses.to_matrix(np.zeros(7), layout="xyz_qwxzy")
    with pytest.raises(ValueError, match="did you mean 'qxyzw_xyz'"):
        poses.from_matrix(np.eye(4), layout="sophus")  # library name → its layout
    with pytest.raises(ValueError, match="did you mean 'xyz_qxyzw'"):
        poses.to_matrix(np.zeros(7), layout="tum")
    with pytest.raises(ValueError, match="known: xyz_qxyzw"):
        poses.to_matrix(np.zeros(7), layout="nonsense")
    with pytest.raises(TypeError, match="layout"):
        poses.to_matrix(np.zeros(7), layout=3)  # type: ignore[arg-type]


def test_shape_and_finiteness_errors() -> None:
    with pytest.raises(ValueError, match=r"expects shape \(\.\.\., 7\)"):
        poses.to_matrix(np.zeros(6), layout="xyz_qxyzw")
    with pytest.raises(ValueError, match=r"expects shape \(\.\.\., 12\)"):
        poses.to_matrix(np.zeros((3, 4)), layout="kitti")
    x = np.array([[0, 0, 0, 0, 0, 0, 1.0], [np.nan, 0, 0, 0, 0, 0, 1]])
    with pytest.raises(ValueError, match="NaN"):
        poses.to_matrix(x, layout="xyz_qxyzw")
    with pytest.raises(TypeError):
        poses.to_matrix("abc", layout="xyz_qxyzw")


def test_inputs_not_mutated() -> None:
    x = np.array([1.0, 2, 3, 0, 0, 0, 1 + 5e-7])
    x0 = x.copy()
    poses.to_matrix(x, layout="xyz_qxyzw")
    assert np.array_equal(x, x0)
    T = random_poses(np.random.default_rng(8), (2,))
    T0 = T.copy()
    poses.from_matrix(T, layout="qwxyz_xyz")
    assert np.array_equal(T, T0)


unit = st.floats(-1, 1, allow_nan=False)


@given(
    st.tuples(unit, unit, unit, unit).filter(lambda q: 0.1 < np.linalg.norm(q)),
    st.tuples(*[st.floats(-1e3, 1e3, allow_nan=False)] * 3),
    st.sampled_from(QUAT_LAYOUTS),
)
def test_round_trip_property(q: tuple, t: tuple, layout: str) -> None:
    qa = np.array(q) / np.linalg.norm(q)
    T = np.eye(4)
    T[:3, :3] = Rotation.from_quat(qa).as_matrix()
    T[:3, 3] = t
    x = poses.from_matrix(T, layout=layout)
    assert np.allclose(poses.to_matrix(x, layout=layout), T, atol=1e-12, rtol=0)
    assert w_of(x, layout) >= 0


def test_text_tolerances_follow_printed_precision() -> None:
    tum = ["0.6574", "0.6126", "-0.2949", "-0.3248"]
    assert poses.text_quaternion_tol(tum) == pytest.approx(2e-4)
    # %g with 6 significant digits (gtsam.writeG2o), trailing zeros stripped
    assert poses.text_quaternion_tol(["0", "0", "0.382683", "0.92388"]) == pytest.approx(2e-6)
    # repr: short fields do not make full-precision text look coarse
    full = ["0.1", "0.2", "0.3", repr(float(np.sqrt(1 - 0.14)))]
    assert poses.text_quaternion_tol(full) == poses.QUATERNION_TOL
    # integers are not trusted beyond the cap
    assert poses.text_quaternion_tol(["1", "1", "0", "0"]) == poses.TEXT_TOL_MAX
    kitti = "1.000000e+00 9.043680e-12 2.326809e-11 9.043683e-12 1.000000e+00".split()
    assert poses.text_rotation_tol(kitti) == pytest.approx(2e-6)
