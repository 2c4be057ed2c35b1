"""One of each: one Trajectory result type, one TUM reader and writer with one sign rule, one
definition per concept, one argument order per family.
"""

from __future__ import annotations

import ast
import dataclasses
import warnings
from pathlib import Path

import numpy as np
import pytest

import liebridge as lb
from liebridge.io import trajectory, trajfile
from liebridge.lie import se3

ROOT = Path(__file__).resolve().parents[1] / "liebridge"
N = 40
#: A body turning twice about z while moving: its quaternion's w crosses 0 three times.
TURN = se3.exp(
    np.c_[np.zeros((N, 2)), np.linspace(0, 4 * np.pi, N), np.linspace(0, 5, N), np.zeros((N, 2))]
)
STAMPS = 1.7e9 + 0.05 * np.arange(N)


# --------------------------------------------------------------------------- Trajectory


def test_trajectory_has_the_promised_fields() -> None:
    names = [f.name for f in dataclasses.fields(lb.io.Trajectory)]
    assert names[:6] == ["stamps", "T", "cov", "frame_id", "child_frame_id", "source"]
    assert lb.io.Trajectory.__dataclass_params__.frozen  # type: ignore[attr-defined]


@pytest.mark.parametrize("fmt", ["tum", "kitti", "euroc"])
def test_every_file_reader_returns_a_trajectory(tmp_path: Path, fmt: str) -> None:
    p = tmp_path / f"t.{fmt}"
    trajfile.write_trajectory(p, STAMPS, TURN, fmt)
    readers = {
        "tum": [lb.io.read_tum, trajfile.read_tum_file, lb.trajectory_io.read_tum],
        "kitti": [lb.io.read_kitti],
        "euroc": [lb.io.read_euroc],
    }[fmt] + [lb.io.read_trajectory, lambda q: lb.io.read_trajectory(q, fmt)]
    for read in readers:
        traj = read(p)
        assert type(traj) is lb.io.Trajectory
        assert traj.T.shape == (N, 4, 4) and traj.stamps.shape == (N,) and traj.cov is None
        assert traj.source == str(p) and len(traj) == N
        np.testing.assert_allclose(traj.T, TURN, atol=1e-14)
        t, T = traj  # the two arrays of earlier releases
        assert t is traj.stamps and T is traj.T
    want = np.arange(N, dtype=float) if fmt == "kitti" else STAMPS
    np.testing.assert_array_equal(lb.io.read_trajectory(p).stamps, want)


def test_the_bag_reader_returns_a_trajectory_with_frames_and_covariance(tmp_path: Path) -> None:
    from liebridge import ros

    cov = np.tile(np.diag([1e-4, 2e-4, 3e-4, 1e-2, 2e-2, 3e-2]), (N, 1, 1))
    msgs = ros.from_poses(
        TURN, cov, convention="gtsam", stamps=STAMPS, frame_id="map", child_frame_id="base",
        msgtype="nav_msgs/msg/Odometry", topic="/odom",
    )  # fmt: skip
    traj = ros.to_trajectory(msgs)
    assert (traj.frame_id, traj.child_frame_id, traj.source) == ("map", "base", "/odom")
    assert traj.convention == "gtsam" and traj.cov is not None
    np.testing.assert_allclose(traj.cov, cov, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(traj.T, TURN, atol=1e-12)
    pytest.importorskip("rosbags")
    bag = tmp_path / "o.bag"
    ros.write_messages(bag, "/odom", msgs)
    back = ros.read_trajectory(bag, "/odom")
    assert type(back) is lb.io.Trajectory and back.source == f"{bag}:/odom"
    assert back.convention == "ros" and back.frame_id == "map"
    np.testing.assert_allclose(back.T, TURN, atol=1e-12)


def test_to_trajectory_refuses_a_topic_whose_frame_changes() -> None:
    from liebridge import ros

    msgs = ros.from_poses(TURN[:4], stamps=STAMPS[:4], frame_id=["map", "odom", "map", "odom"])
    with pytest.raises(ValueError, match=r"frame_id changes .*'map', 'odom'.*\(1,\)"):
        ros.to_trajectory(msgs)


def test_trajectory_validates_its_shapes() -> None:
    with pytest.raises(ValueError, match=r"T: expected shape \(2, 4, 4\)"):
        lb.io.Trajectory(np.zeros(2), np.zeros((3, 4, 4)))
    with pytest.raises(ValueError, match=r"cov: expected shape \(1, 6, 6\)"):
        lb.io.Trajectory(np.zeros(1), np.eye(4)[None], np.eye(6))


# --------------------------------------------------------------------------- one TUM writer


def _body(path: Path) -> np.ndarray:
    rows = [ln.split() for ln in path.read_text().splitlines() if not ln.startswith("#")]
    return np.array([[float(x) for x in r[1:]] for r in rows])


def test_the_three_tum_writers_write_the_same_poses_with_one_sign_rule(tmp_path: Path) -> None:
    from liebridge import ros

    a, b, c = tmp_path / "a.txt", tmp_path / "b.txt", tmp_path / "c.txt"
    lb.io.write_tum(a, STAMPS, TURN)
    trajfile.write_trajectory(b, STAMPS, TURN, "tum")
    ros.write_tum(c, ros.from_poses(TURN, stamps=STAMPS, topic="/t"))
    A, B, C = _body(a), _body(b), _body(c)
    assert np.array_equal(A, B)
    np.testing.assert_allclose(C, A, rtol=0, atol=1e-15)  # same signs, rounding aside
    q = A[:, 3:]
    assert q[0, 3] >= 0  # the first w >= 0
    assert (np.einsum("ij,ij->i", q[1:], q[:-1]) >= 0).all()  # then hemisphere continuity
    assert (q[:, 3] < 0).any()  # not "w >= 0 on every line": that flips at every half turn


def test_tum_quaternion_order_round_trips_through_the_header(tmp_path: Path) -> None:
    p = tmp_path / "w.txt"
    lb.io.write_tum(p, STAMPS, TURN, quat_order="wxyz")
    assert p.read_text().startswith("# timestamp tx ty tz qw qx qy qz")
    np.testing.assert_allclose(lb.io.read_tum(p).T, TURN, atol=1e-14)


def test_write_tum_takes_a_trajectory_and_names_its_frames(tmp_path: Path) -> None:
    traj = lb.io.Trajectory(STAMPS, TURN, frame_id="map", child_frame_id="imu")
    p = tmp_path / "t.txt"
    lb.io.write_tum(p, traj)
    assert "(T_map_imu)" in p.read_text().splitlines()[0]
    back = lb.io.read_tum(p)
    assert np.array_equal(back.stamps, STAMPS)


# --------------------------------------------------------------------------- one name per concept


def _module_level_defs(name: str) -> list[str]:
    found = []
    for path in ROOT.rglob("*.py"):
        for node in ast.parse(path.read_text(encoding="utf-8")).body:
            if isinstance(node, ast.FunctionDef) and node.name == name:
                found.append(str(path.relative_to(ROOT)))
    return sorted(found)


@pytest.mark.parametrize("name", ["to_gtsam", "library_key"])
def test_one_definition_per_concept(name: str) -> None:
    assert len(_module_level_defs(name)) == 1, _module_level_defs(name)


def test_numerical_jacobian_is_defined_once() -> None:
    assert len(_module_level_defs("numerical_jacobian")) == 1


def test_no_hat_outside_lie() -> None:
    assert all(p.startswith("lie/") for p in _module_level_defs("hat")), _module_level_defs("hat")


def test_the_reexports_are_the_same_objects() -> None:
    from liebridge import _validate, interop
    from liebridge.gtsam import glue
    from liebridge.gtsam import uncertain as gu

    assert interop.library_key is _validate.library_key
    assert gu.to_gtsam is glue.to_gtsam
    assert trajfile.read_tum_file is trajectory.read_tum is lb.io.read_tum


def test_library_key_reads_objects_and_classes() -> None:
    gtsam = pytest.importorskip("gtsam")
    from liebridge import interop

    assert interop.library_key(gtsam.Pose3()) == ("gtsam", "Pose3")
    assert interop.library_key(gtsam.Pose3) == ("gtsam", "Pose3")
    assert interop.library_key(np.eye(4)) is None
    with pytest.raises((TypeError, ValueError)):
        lb.lie.se3.log(gtsam.Pose3)  # a class is not a pose


def test_to_gtsam_of_an_uncertain_pose() -> None:
    gtsam = pytest.importorskip("gtsam")
    from liebridge.gtsam.glue import to_gtsam
    from liebridge.uncertain import UncertainPose

    A = UncertainPose(TURN[3], np.diag([1e-4, 2e-4, 3e-4, 1e-2, 2e-2, 3e-2]), "gtsam")
    obj, cov = to_gtsam(A)
    assert isinstance(obj, gtsam.Pose3)
    np.testing.assert_allclose(obj.matrix(), TURN[3], atol=1e-15)
    np.testing.assert_allclose(cov, A.cov, rtol=1e-12)
    with pytest.raises(TypeError, match="group: required"):
        to_gtsam(TURN[3])


# --------------------------------------------------------------------------- argument orders


def test_umeyama_takes_reference_first_like_align() -> None:
    rng = np.random.default_rng(3)
    p_est = rng.normal(size=(30, 3))
    R = se3.exp(np.array([0.3, -0.2, 0.5, 0, 0, 0]))[:3, :3]
    s, t = 1.7, np.array([1.0, -2.0, 0.5])
    p_ref = s * p_est @ R.T + t
    a = lb.traj.umeyama(p_ref, p_est, "sim3")
    np.testing.assert_allclose(a.R_ref_est, R, atol=1e-12)
    np.testing.assert_allclose(a.t_ref_est, t, atol=1e-12)
    assert a.scale == pytest.approx(s, rel=1e-12)
    T_est = np.tile(np.eye(4), (30, 1, 1))
    T_est[:, :3, 3] = p_est
    T_ref = T_est.copy()
    T_ref[:, :3, 3] = p_ref
    b = lb.traj.align(T_ref, T_est, "sim3")
    np.testing.assert_allclose(b.R_ref_est, a.R_ref_est, atol=1e-15)


def test_convert_jacobian_takes_the_conversions_order() -> None:
    X = TURN[5]
    Y = TURN[9]
    J = np.arange(36.0).reshape(6, 6)
    M_in = lb.tangent_map(X, "gtsam", "sophus")
    M_out = lb.tangent_map(Y, "gtsam", "sophus")
    want = M_out @ J @ np.linalg.inv(M_in)
    got = lb.convert_jacobian(J, X, "gtsam", "sophus", at_output=Y)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(
        lb.convert_jacobian(J, None, "gtsam", "sophus", at_output=Y), M_out @ J, atol=1e-12
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        lb.convert_jacobian(J, X, "gtsam", "sophus")  # the new order warns nothing
    with pytest.warns(DeprecationWarning, match="order of earlier releases"):
        old = lb.convert_jacobian(J, "gtsam", "sophus", at_input=X, at_output=Y)
    np.testing.assert_array_equal(old, got)
    with pytest.warns(DeprecationWarning, match="at_input"):
        kw = lb.convert_jacobian(J, src="gtsam", dst="sophus", at_input=X, at_output=Y)
    np.testing.assert_array_equal(kw, got)
    with pytest.raises(TypeError, match="src and dst are required"):
        lb.convert_jacobian(J, X, "gtsam")
