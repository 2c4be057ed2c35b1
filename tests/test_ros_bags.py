"""liebridge.ros: bags written with rosbags round-trip bit for bit; conventions; bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from _rosbag_fixtures import (
    STORAGES,
    TYPES,
    MessageFactory,
    bag_path,
    raw_records,
    typestore,
    write_bag,
)

from liebridge import conventions as C
from liebridge import ros
from liebridge.lie import se3

N = 7


def _bag(tmp_path: Path, storage: str, mt: str, n: int = N, seed: int = 0) -> Path:
    ts = typestore(storage)
    fac = MessageFactory(ts, storage == "rosbag1", np.random.default_rng(seed))
    msgs = [fac.make(mt, k) for k in range(n)]
    return write_bag(bag_path(tmp_path, storage), storage, {"/t": (mt, msgs)}, ts)


@pytest.mark.parametrize("storage", STORAGES)
@pytest.mark.parametrize("mt", TYPES)
def test_round_trip_bit_exact(tmp_path: Path, storage: str, mt: str) -> None:
    src = _bag(tmp_path, storage, mt)
    m = ros.read_messages(src, "/t")
    assert m.storage == storage and m.msgtype == mt
    assert len(m.log_time_ns) == N
    out = tmp_path / ("out.bag" if storage == "rosbag1" else "out")
    ros.write_messages(out, "/t", m)  # storage: the one read from
    assert raw_records(out) == raw_records(src)
    if storage == "mcap":  # and as a bare .mcap file
        bare = ros.write_messages(tmp_path / "out.mcap", "/t", m)
        assert bare.is_file() and raw_records(bare) == raw_records(src)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporaries left


@pytest.mark.parametrize(
    ("src_storage", "dst_storage"), [("rosbag1", "mcap"), ("sqlite3", "rosbag1")]
)
def test_cross_format_keeps_every_field(tmp_path: Path, src_storage: str, dst_storage: str) -> None:
    src = _bag(tmp_path, src_storage, "nav_msgs/msg/Odometry")
    m = ros.read_messages(src, "/t")
    name = "x.bag" if dst_storage == "rosbag1" else "x"
    out = ros.write_messages(tmp_path / name, "/t", m, storage=dst_storage)
    m2 = ros.read_messages(out, "/t")
    for name in (
        "position",
        "orientation_xyzw",
        "pose_covariance",
        "twist_linear_angular",
        "twist_covariance",
        "stamp_sec",
        "stamp_nanosec",
        "log_time_ns",
    ):
        a, b = getattr(m, name), getattr(m2, name)
        assert np.array_equal(
            a.view(np.uint64 if a.dtype == np.float64 else a.dtype),
            b.view(np.uint64 if b.dtype == np.float64 else b.dtype),
        ), name
    assert m2.frame_id == m.frame_id and m2.child_frame_id == m.child_frame_id
    if dst_storage == "rosbag1":
        assert (m2.seq == m.seq).all()


def test_fields_and_frames(tmp_path: Path) -> None:
    m = ros.read_messages(_bag(tmp_path, "sqlite3", "tf2_msgs/msg/TFMessage"), "/t")
    # messages hold 1, 2, 3, 1, 2, 3, 1 transforms
    assert len(m) == 13 and list(np.bincount(m.message_index)) == [1, 2, 3, 1, 2, 3, 1]
    assert m.child_frame_id is not None and m.child_frame_id[:3] == ("base0", "base1", "base1")
    assert m.cov is None
    # T is the stored quaternion's rotation (sign irrelevant), translation as stored
    q = m.orientation_xyzw
    R_expected = np.stack([se3.exp(np.r_[0, 0, 0, 0, 0, 0])[:3, :3]] * len(m))
    from scipy.spatial.transform import Rotation

    R_expected = Rotation.from_quat(q).as_matrix()
    np.testing.assert_allclose(m.T[:, :3, :3], R_expected, atol=1e-14)
    assert np.array_equal(m.T[:, :3, 3], m.position)
    assert (q[:, 3] < 0).all()  # raw quaternion sign kept


def test_stamps_exact_and_seconds(tmp_path: Path) -> None:
    m = ros.read_messages(_bag(tmp_path, "rosbag1", "nav_msgs/msg/Odometry"), "/t")
    np.testing.assert_allclose(m.stamps, m.stamp_sec + m.stamp_nanosec * 1e-9, rtol=0, atol=1e-6)
    assert (m.seq == 1000 + np.arange(N)).all()


def _odom_with_psd(tmp_path: Path, storage: str = "mcap") -> ros.RosMessages:
    """Odometry messages whose covariances are SPD (convertible)."""
    rng = np.random.default_rng(3)
    T = se3.exp(rng.normal(size=(N, 6)) * [1, 1, 1, 5, 5, 5])
    A = rng.normal(size=(N, 6, 6))
    cov = A @ A.transpose(0, 2, 1) * 1e-2
    tw = rng.normal(size=(N, 6))
    B = rng.normal(size=(N, 6, 6))
    m = ros.from_poses(
        T,
        cov,
        stamps=np.arange(N) * 0.1 + 5.0,
        msgtype="nav_msgs/Odometry",
        child_frame_id="base_link",
        frame_id="odom",
        twist=tw,
        twist_cov=B @ B.transpose(0, 2, 1),
    )
    p = ros.write_messages(tmp_path / "odom", "/odom", m, storage=storage)
    return ros.read_messages(p, "/odom")


def test_cov_is_message_cov_and_converts_through_conventions(tmp_path: Path) -> None:
    m = _odom_with_psd(tmp_path)
    assert m.convention.name == "ros"
    assert m.cov is not None and m.pose_covariance is not None
    assert np.array_equal(m.cov.reshape(N, 36), m.pose_covariance)  # bit-exact, no arithmetic
    g = m.with_convention("gtsam")
    assert g.cov is not None
    expected = C.convert_covariance(m.cov, m.T, "ros", "gtsam")
    np.testing.assert_allclose(g.cov, expected, rtol=0, atol=0)
    # the ROS → GTSAM map at T is [[0, Rᵀ], [Rᵀ, 0]]: check it independently
    R = m.T[:, :3, :3]
    M = np.zeros((N, 6, 6))
    M[:, :3, 3:] = np.swapaxes(R, -1, -2)
    M[:, 3:, :3] = np.swapaxes(R, -1, -2)
    np.testing.assert_allclose(g.cov, M @ m.cov @ np.swapaxes(M, -1, -2), atol=1e-13)
    # twist: only reordered, (v, ω) → (ω, v); still the child frame
    assert m.twist is not None and g.twist is not None
    assert np.array_equal(g.twist, np.concatenate([m.twist[:, 3:], m.twist[:, :3]], axis=-1))
    # read_messages(convention=...) is the same as with_convention
    g2 = ros.read_messages(tmp_path / "odom", "/odom", convention="gtsam")
    assert g2.cov is not None and np.array_equal(g2.cov, g.cov)


def test_cov_monte_carlo_matches_ros_semantics(tmp_path: Path) -> None:
    """Sample the message's ROS perturbation (t + u, Exp(ω)·R); GTSAM's tangent covariance."""
    m = _odom_with_psd(tmp_path)
    g = m.with_convention("gtsam")
    rng = np.random.default_rng(7)
    T, cov_ros = m.T[2], m.cov[2] * 1e-4  # small: first order
    d = rng.multivariate_normal(np.zeros(6), cov_ros, size=40000)
    Ts = np.broadcast_to(T, (len(d), 4, 4)).copy()
    Ts[:, :3, 3] += d[:, :3]
    Ts[:, :3, :3] = se3.exp(np.c_[d[:, 3:], np.zeros((len(d), 3))])[:, :3, :3] @ T[:3, :3]
    xi = se3.log(se3.inverse(T) @ Ts)  # GTSAM (ω, v)
    emp = np.cov(xi.T)
    assert g.cov is not None
    scale = np.sqrt(np.outer(np.diag(g.cov[2]), np.diag(g.cov[2]))) * 1e-4
    assert np.abs(emp - g.cov[2] * 1e-4).max() / scale.max() < 0.05


def test_from_poses_converts_gtsam_covariance(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    T = se3.exp(rng.normal(size=(4, 6)))
    A = rng.normal(size=(4, 6, 6))
    cov_g = A @ A.transpose(0, 2, 1)
    m = ros.from_poses(T, cov_g, convention="gtsam", stamps=[1, 2, 3, 4.5])
    assert m.convention.name == "gtsam"
    assert m.cov is not None and m.pose_covariance is not None
    np.testing.assert_allclose(m.cov, cov_g, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(
        m.pose_covariance.reshape(4, 6, 6),
        C.convert_covariance(cov_g, T, "gtsam", "ros"),
        atol=1e-14,
    )
    assert (m.orientation_xyzw[:, 3] >= 0).all()
    assert list(m.stamp_nanosec) == [0, 0, 0, 500_000_000]


def test_imu_unknown_orientation(tmp_path: Path) -> None:
    m = ros.read_messages(_bag(tmp_path, "mcap", "sensor_msgs/msg/Imu"), "/t")
    assert list(m.orientation_known) == [k % 3 != 1 for k in range(N)]
    assert np.array_equal(m.T[1], np.eye(4))
    assert m.angular_velocity is not None and m.angular_velocity.shape == (N, 3)


def test_tum_export_full_precision(tmp_path: Path) -> None:
    m = ros.read_messages(
        _bag(tmp_path, "rosbag1", "geometry_msgs/msg/PoseWithCovarianceStamped"), "/t"
    )
    m = m.select(np.arange(0, len(m), 2))  # the fixture alternates odom0/odom1: one frame
    out = tmp_path / "t.tum"
    ros.write_tum(out, m)
    rows = [ln.split() for ln in out.read_text().splitlines() if not ln.startswith("#")]
    assert len(rows) == len(m) == (N + 1) // 2
    for k, r in enumerate(rows):
        s, ns = r[0].split(".")
        assert int(s) == m.stamp_sec[k] and int(ns) == m.stamp_nanosec[k]
        vals = np.array([float(x) for x in r[1:]])
        q = m.orientation_xyzw[k]
        assert np.array_equal(vals[:3], m.position[k])  # the stored doubles, bit for bit
        assert np.array_equal(vals[3:], q) or np.array_equal(vals[3:], -q)  # up to sign
    q = np.array([[float(x) for x in r[4:]] for r in rows])
    assert q[0, 3] >= 0 and (np.einsum("ij,ij->i", q[1:], q[:-1]) >= 0).all()  # the sign rule


# ---- bad input -------------------------------------------------------------------------------


@pytest.mark.parametrize("storage", STORAGES)
def test_truncated_or_corrupt_bag(tmp_path: Path, storage: str) -> None:
    src = _bag(tmp_path, storage, "nav_msgs/msg/Odometry", n=200)
    f = src if src.is_file() else next(p for p in src.iterdir() if p.suffix in (".mcap", ".db3"))
    data = f.read_bytes()
    f.write_bytes(data[: len(data) // 2])
    with pytest.raises(ros.BagError) as e:
        ros.read_messages(src, "/t")
    assert str(src) in str(e.value)
    assert "\n" not in str(e.value)


def test_garbage_file(tmp_path: Path) -> None:
    p = tmp_path / "x.bag"
    p.write_bytes(b"#ROSBAG V2.0\n" + bytes(range(256)) * 4)
    with pytest.raises(ros.BagError, match=r"x\.bag"):
        ros.read_messages(p, "/t")
    with pytest.raises(ros.BagError, match="no such bag"):
        ros.read_messages(tmp_path / "missing.bag", "/t")


def test_topic_of_another_type_and_missing_topic(tmp_path: Path) -> None:
    ts = typestore("rosbag1")
    s = ts.types["std_msgs/msg/String"](data="hi")
    p = write_bag(tmp_path / "s.bag", "rosbag1", {"/chatter": ("std_msgs/msg/String", [s])}, ts)
    with pytest.raises(ros.BagError, match=r"s\.bag: topic /chatter has type std_msgs/msg/String"):
        ros.read_messages(p, "/chatter")
    with pytest.raises(ros.BagError, match=r"no topic '/odom' \(topics: /chatter\)"):
        ros.read_messages(p, "/odom")


@pytest.mark.parametrize("storage", ["rosbag1", "sqlite3"])
def test_covariance_of_wrong_length(tmp_path: Path, storage: str) -> None:
    """A bag whose PoseWithCovariance definition has 35 covariance numbers."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    base = get_typestore(Stores.ROS1_NOETIC if storage == "rosbag1" else Stores.ROS2_HUMBLE)
    ts = get_typestore(Stores.EMPTY)
    ts.register({k: d for k, d in base.fielddefs.items() if not k.endswith("/PoseWithCovariance")})
    ts.register(
        get_types_from_msg(
            "geometry_msgs/Pose pose\nfloat64[] covariance", "geometry_msgs/msg/PoseWithCovariance"
        )
    )
    fac = MessageFactory(ts, storage == "rosbag1", np.random.default_rng(0))
    msgs = [fac.make("geometry_msgs/msg/PoseWithCovarianceStamped", k) for k in range(4)]
    msgs[2].pose.covariance = msgs[2].pose.covariance[:35]
    p = write_bag(
        bag_path(tmp_path, storage),
        storage,
        {"/pose": ("geometry_msgs/msg/PoseWithCovarianceStamped", msgs)},
        ts,
    )
    with pytest.raises(ros.BagError) as e:
        ros.read_messages(p, "/pose")
    msg = str(e.value)
    assert str(p) in msg and "topic /pose, message 2: field pose.covariance" in msg
    assert "expected 36 numbers, got 35" in msg


def test_bad_quaternion_names_message(tmp_path: Path) -> None:
    ts = typestore("sqlite3")
    fac = MessageFactory(ts, False, np.random.default_rng(0))
    msgs = [fac.make("geometry_msgs/msg/PoseWithCovarianceStamped", k) for k in range(4)]
    msgs[3].pose.pose.orientation.w *= 1.1
    p = write_bag(
        bag_path(tmp_path, "sqlite3"),
        "sqlite3",
        {"/pose": ("geometry_msgs/msg/PoseWithCovarianceStamped", msgs)},
        ts,
    )
    with pytest.raises(ValueError, match=r"topic /pose, message 3: orientation quaternion norm"):
        ros.read_messages(p, "/pose")


def test_unconvertible_covariance_names_message(tmp_path: Path) -> None:
    src = _bag(tmp_path, "mcap", "nav_msgs/msg/Odometry")  # random, non-symmetric covariances
    m = ros.read_messages(src, "/t")  # ros: as stored, no validation needed
    with pytest.raises(ValueError, match=r"topic /t, message 0: .*cannot convert it to 'gtsam'"):
        m.with_convention("gtsam")


def test_failed_write_leaves_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    m = ros.read_messages(_bag(tmp_path, "rosbag1", "nav_msgs/msg/Odometry"), "/t")
    target = tmp_path / "out.bag"
    target.write_bytes(b"old")
    calls = {"n": 0}

    def boom(done: int, total: int) -> None:
        calls["n"] += 1
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        ros.write_messages(target, "/t", m, progress=boom)
    assert target.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.bag", "out.bag"]


def test_bad_batch_fields() -> None:
    with pytest.raises(ValueError, match=r"pose_covariance: expected shape \(2, 36\)"):
        ros.RosMessages(
            msgtype="geometry_msgs/PoseWithCovarianceStamped",
            stamp_sec=[1, 2],
            stamp_nanosec=[0, 0],
            frame_id=("a", "a"),
            position=np.zeros((2, 3)),
            orientation_xyzw=[[0, 0, 0, 1.0]] * 2,
            pose_covariance=np.zeros((2, 35)),
        )
    with pytest.raises(ValueError, match="msgtype: 'std_msgs/String' is not supported"):
        ros.RosMessages(
            msgtype="std_msgs/String",
            stamp_sec=[],
            stamp_nanosec=[],
            frame_id=(),
            position=np.zeros((0, 3)),
            orientation_xyzw=np.zeros((0, 4)),
        )


@pytest.mark.parametrize("preset", [c.name for c in C.PRESETS])
def test_every_preset_round_trips_through_the_message(preset: str) -> None:
    """from_poses(cov in preset) → raw ROS numbers → cov in preset again: the same matrix."""
    rng = np.random.default_rng(4)
    T = se3.exp(rng.normal(size=(3, 6)) * [1, 1, 1, 10, 10, 10])
    A = rng.normal(size=(3, 6, 6))
    cov = A @ A.transpose(0, 2, 1) * 1e-3
    m = ros.from_poses(T, cov, convention=preset, stamps=[0.0, 1.0, 2.0])
    assert m.cov is not None and m.pose_covariance is not None
    np.testing.assert_allclose(m.cov, cov, rtol=1e-9, atol=1e-12 * np.abs(cov).max())
    expected_ros = C.convert_covariance(cov, m.T, preset, "ros")
    np.testing.assert_allclose(
        m.pose_covariance.reshape(3, 6, 6), expected_ros, rtol=1e-9, atol=1e-15
    )


def test_empty_topic_and_select(tmp_path: Path) -> None:
    ts = typestore("mcap")
    p = write_bag(bag_path(tmp_path, "mcap"), "mcap", {"/odom": ("nav_msgs/msg/Odometry", [])}, ts)
    m = ros.read_messages(p, "/odom")
    assert len(m) == 0 and m.T.shape == (0, 4, 4)
    assert m.cov is not None and m.cov.shape == (0, 6, 6)
    tf = ros.read_messages(_bag(tmp_path, "sqlite3", "tf2_msgs/msg/TFMessage"), "/t")
    sub = tf.select(np.flatnonzero(np.asarray(tf.child_frame_id) == "base2"))
    assert len(sub) == 3 and list(sub.message_index) == [0, 0, 0]  # message 2: 3 transforms
    assert len(sub.log_time_ns) == 1 and sub.log_time_ns[0] == tf.log_time_ns[2]
    assert np.array_equal(sub.T, tf.T[tf.message_index == 2])
