"""TransformTree: chains, interpolation against GTSAM and tf2's formula, clear lookup errors."""

from __future__ import annotations

import gtsam
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation, Slerp

from liebridge.frames import FrameLookupError, StampedTransform, Transform, TransformTree
from liebridge.lie import se3


def _pose(rng: np.random.Generator, scale: float = 1.0) -> np.ndarray:
    return se3.exp(np.concatenate([rng.normal(size=3), scale * rng.normal(size=3)]))


@pytest.fixture
def tree_and_data() -> tuple[TransformTree, dict[str, np.ndarray]]:
    rng = np.random.default_rng(5)
    stamps = np.array([0.0, 0.1, 0.25, 0.4])
    T_odom_base = np.stack([_pose(rng, 3.0) for _ in stamps])
    T_map_odom = _pose(rng, 30.0)
    T_base_cam = _pose(rng, 0.2)
    T_base_imu = _pose(rng, 0.1)
    tree = TransformTree(
        [
            Transform(T_map_odom, "map", "odom"),
            StampedTransform(Transform(T_odom_base, "odom", "base"), stamps),
            Transform(T_base_cam, "base", "cam"),
            Transform(T_base_imu, "base", "imu"),
        ]
    )
    data = {
        "stamps": stamps,
        "T_odom_base": T_odom_base,
        "T_map_odom": T_map_odom,
        "T_base_cam": T_base_cam,
        "T_base_imu": T_base_imu,
    }
    return tree, data


def test_static_chain_both_directions(tree_and_data: tuple[TransformTree, dict]) -> None:
    tree, d = tree_and_data
    T = tree.lookup("cam", "imu").T
    expected = se3.inverse(d["T_base_cam"]) @ d["T_base_imu"]
    np.testing.assert_allclose(T, expected, atol=1e-12)
    np.testing.assert_allclose(tree.lookup("imu", "cam").T, se3.inverse(expected), atol=1e-12)
    assert tree.chain("cam", "imu") == ["cam", "base", "imu"]


def test_at_stamp_exact(tree_and_data: tuple[TransformTree, dict]) -> None:
    tree, d = tree_and_data
    for how in ("lerp_slerp", "geodesic"):
        got = tree.lookup("map", "cam", d["stamps"][2], interpolation=how).T
        want = d["T_map_odom"] @ d["T_odom_base"][2] @ d["T_base_cam"]
        np.testing.assert_allclose(got, want, atol=1e-12)


def test_lerp_slerp_is_tf2_formula_and_gtsam_rot3_slerp(tree_and_data: tuple) -> None:
    """tf2 ``TimeCache::interpolate``: translation setInterpolate3, rotation slerp (short arc)."""
    tree, d = tree_and_data
    s, T = d["stamps"], d["T_odom_base"]
    t = np.array([0.03, 0.17, 0.3, 0.399])
    got = tree.lookup("odom", "base", t, interpolation="lerp_slerp").T
    slerp = Slerp(s, Rotation.from_matrix(T[:, :3, :3]))
    R_ref = slerp(t).as_matrix()
    for k, tk in enumerate(t):
        i = np.searchsorted(s, tk) - 1
        tau = (tk - s[i]) / (s[i + 1] - s[i])
        trans = (1 - tau) * T[i, :3, 3] + tau * T[i + 1, :3, 3]
        np.testing.assert_allclose(got[k, :3, 3], trans, atol=1e-12)
        np.testing.assert_allclose(got[k, :3, :3], R_ref[k], atol=1e-12)
        R_gt = gtsam.Rot3(T[i, :3, :3]).slerp(tau, gtsam.Rot3(T[i + 1, :3, :3])).matrix()
        np.testing.assert_allclose(got[k, :3, :3], R_gt, atol=1e-9)


def test_geodesic_is_gtsam_pose3_slerp(tree_and_data: tuple) -> None:
    tree, d = tree_and_data
    s, T = d["stamps"], d["T_odom_base"]
    t = 0.2
    got = tree.lookup("odom", "base", t, interpolation="geodesic").T
    tau = (t - s[1]) / (s[2] - s[1])
    ref = gtsam.Pose3(T[1]).slerp(tau, gtsam.Pose3(T[2])).matrix()
    np.testing.assert_allclose(got, ref, atol=1e-9)


def test_geodesic_direction_invariant_lerp_slerp_not() -> None:
    rng = np.random.default_rng(2)
    T0 = _pose(rng, 2.0)
    T1 = T0 @ se3.exp(np.array([0.0, 0.0, 1.2, 1.0, 0.5, 0.0]))
    stamps = np.array([0.0, 1.0])
    fwd = TransformTree([StampedTransform(Transform(np.stack([T0, T1]), "a", "b"), stamps)])
    inv = np.stack([se3.inverse(T0), se3.inverse(T1)])
    bwd = TransformTree([StampedTransform(Transform(inv, "b", "a"), stamps)])
    g1 = fwd.lookup("a", "b", 0.5, interpolation="geodesic").T
    g2 = bwd.lookup("a", "b", 0.5, interpolation="geodesic").T
    np.testing.assert_allclose(g1, g2, atol=1e-12)
    l1 = fwd.lookup("a", "b", 0.5, interpolation="lerp_slerp").T
    l2 = bwd.lookup("a", "b", 0.5, interpolation="lerp_slerp").T
    np.testing.assert_allclose(l1[:3, :3], l2[:3, :3], atol=1e-12)  # rotations agree
    assert np.abs(l1[:3, 3] - l2[:3, 3]).max() > 0.05  # translations do not


def test_disconnected_chain_names_frames() -> None:
    tree = TransformTree([Transform(np.eye(4), "map", "odom"), Transform(np.eye(4), "base", "cam")])
    with pytest.raises(FrameLookupError) as exc:
        tree.lookup("map", "cam")
    msg = str(exc.value)
    assert "'map'" in msg and "'cam'" in msg and "not connected" in msg
    assert "['map', 'odom']" in msg and "['base', 'cam']" in msg


def test_other_lookup_errors(tree_and_data: tuple) -> None:
    tree, _ = tree_and_data
    with pytest.raises(FrameLookupError, match="unknown frame 'lidar'"):
        tree.lookup("lidar", "cam")
    with pytest.raises(FrameLookupError, match="without a time"):
        tree.lookup("map", "cam")
    with pytest.raises(FrameLookupError, match=r"outside its data \[0.0, 0.4\]"):
        tree.lookup("map", "cam", 0.5)
    with pytest.raises(FrameLookupError, match=r"time -0.1 is outside"):
        tree.lookup("map", "cam", [[0.1, 0.2], [0.3, -0.1]])
    with pytest.raises(ValueError, match="interpolation"):
        tree.lookup("map", "cam", 0.1, interpolation="cubic")
    with pytest.raises(ValueError, match="already connected"):
        tree.add(Transform(np.eye(4), "map", "cam"))
    with pytest.raises(ValueError, match="not strictly increasing at index 2"):
        StampedTransform(Transform(np.stack([np.eye(4)] * 3), "a", "b"), [0.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="StampedTransform"):
        TransformTree([Transform(np.stack([np.eye(4)] * 2), "a", "b")])


def test_batched_times(tree_and_data: tuple) -> None:
    tree, _ = tree_and_data
    t = np.array([[0.05, 0.1], [0.2, 0.35]])
    batch = tree.lookup("map", "imu", t)
    assert batch.T.shape == (2, 2, 4, 4)
    np.testing.assert_allclose(batch.T[1, 0], tree.lookup("map", "imu", 0.2).T, atol=1e-12)


def test_static_covariances_carried_through_the_chain() -> None:
    rng = np.random.default_rng(8)
    S = np.diag([1e-4, 1e-4, 4e-4, 1e-3, 1e-3, 2e-3])
    a_b = Transform(_pose(rng, 2.0), "a", "b", S)
    c_b = Transform(_pose(rng, 1.0), "c", "b", 2 * S)
    tree = TransformTree([a_b, c_b])
    got = tree.lookup("a", "c")
    ref = a_b @ c_b.inverse()
    np.testing.assert_allclose(got.T, ref.T, atol=1e-12)
    np.testing.assert_allclose(got.cov, ref.cov, atol=1e-15)
    same = tree.lookup("b", "b", [0.0, 1.0])
    assert same.T.shape == (2, 4, 4) and same.name == "T_b_b"


@given(st.floats(0.0, 0.4), st.sampled_from(["lerp_slerp", "geodesic"]))
def test_lookups_chain_and_invert(t: float, how: str) -> None:
    rng = np.random.default_rng(5)
    stamps = np.array([0.0, 0.1, 0.25, 0.4])
    tree = TransformTree(
        [
            Transform(_pose(rng, 30.0), "map", "odom"),
            StampedTransform(
                Transform(np.stack([_pose(rng, 3.0) for _ in stamps]), "odom", "base"), stamps
            ),
            Transform(_pose(rng, 0.2), "base", "cam"),
        ]
    )
    a_c = tree.lookup("map", "cam", t, interpolation=how)
    a_b = tree.lookup("map", "base", t, interpolation=how)
    b_c = tree.lookup("base", "cam", t, interpolation=how)
    np.testing.assert_allclose((a_b @ b_c).T, a_c.T, atol=1e-9)
    np.testing.assert_allclose(
        tree.lookup("cam", "map", t, interpolation=how).T, a_c.inverse().T, atol=1e-9
    )
