"""Bags in the shapes the field records, read as they are: evo's example bags, nav2, odometry.

Every bag here is written with rosbags directly (``tests/_rosbag_fixtures.py``), in the shape of
the files users bring: evo's ``ROS_example.bag`` / ``ROS2_example`` (``geometry_msgs/PoseStamped``
ground truth and estimates), a SLAM system's ``nav_msgs/Path`` (each message the whole
trajectory so far), nav2's ``/amcl_pose`` (``PoseWithCovarianceStamped``, planar covariance) and
a driver's ``/odom`` with all-zero covariances. Where evo reads a bag, its numbers are the oracle.
"""

from __future__ import annotations

import gc
import json
import tracemalloc
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from _rosbag_fixtures import bag_path, typestore, write_bag  # isort: skip

import liebridge as lb
from liebridge import ros
from liebridge.cli import main
from liebridge.io import g2o
from liebridge.lie import se3, so3

STORAGES = ("rosbag1", "sqlite3", "mcap")
T0 = 1_700_000_000


# ----------------------------------------------------------------------------- bag builders
def _stamp(ts: Any, t: float) -> Any:
    ns = round(t * 1e9)
    return ts.types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)


def _header(ts: Any, storage: str, t: float, frame: str, k: int) -> Any:
    kw = {"seq": k} if storage == "rosbag1" else {}
    return ts.types["std_msgs/msg/Header"](stamp=_stamp(ts, t), frame_id=frame, **kw)


def _pose(ts: Any, T: np.ndarray) -> Any:
    q = lb.lie.quaternion.from_matrix(T[:3, :3], order="xyzw")
    t = ts.types
    return t["geometry_msgs/msg/Pose"](
        position=t["geometry_msgs/msg/Point"](x=T[0, 3], y=T[1, 3], z=T[2, 3]),
        orientation=t["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]),
    )


def _pose_stamped(ts: Any, storage: str, t: float, T: np.ndarray, k: int, frame: str) -> Any:
    return ts.types["geometry_msgs/msg/PoseStamped"](
        header=_header(ts, storage, t, frame, k), pose=_pose(ts, T)
    )


def _trajectories() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Ground truth at 100 Hz; an estimate at ~33 Hz, 2 ms late, drifting and noisy."""
    rng = np.random.default_rng(11)
    t_gt = T0 + 0.01 * np.arange(300)
    s = t_gt - T0
    xi = np.c_[0.1 * np.sin(s), 0.05 * s, 0.4 * s, 2 * np.sin(0.5 * s), 1.5 * s, 0.2 * s]
    T_gt = se3.exp(xi)
    t_est = t_gt[::3] + 0.002
    z = np.zeros_like(t_est)
    drift = se3.exp(np.c_[z, z, 0.01 * (t_est - T0), 0.03 * (t_est - T0), z, z])
    noise = se3.exp(rng.normal(scale=[0.01, 0.01, 0.01, 0.03, 0.03, 0.03], size=(100, 6)))
    T_est = drift @ T_gt[::3] @ noise
    return t_gt, T_gt, t_est, T_est


def _evo_example_bag(tmp: Path, storage: str) -> Path:
    """evo's example bag's shape: PoseStamped /groundtruth and two estimate topics."""
    ts = typestore(storage)
    t_gt, T_gt, t_est, T_est = _trajectories()
    gt = [
        _pose_stamped(ts, storage, t, T, k, "world")
        for k, (t, T) in enumerate(zip(t_gt, T_gt, strict=True))
    ]
    est = [
        _pose_stamped(ts, storage, t, T, k, "world")
        for k, (t, T) in enumerate(zip(t_est, T_est, strict=True))
    ]
    est2 = [
        _pose_stamped(
            ts, storage, t + 0.001, T @ se3.exp(np.r_[0, 0, 0.02, 0.05, 0, 0]), k, "world"
        )
        for k, (t, T) in enumerate(zip(t_est, T_est, strict=True))
    ]
    # A SLAM system's path: message j holds every pose estimated so far (grows to the whole).
    path_type = ts.types["nav_msgs/msg/Path"]
    paths = [
        path_type(header=_header(ts, storage, t_est[j], "world", j), poses=est[: j + 1])
        for j in range(0, len(est), 9)
    ]
    paths.append(path_type(header=_header(ts, storage, t_est[-1], "world", 99), poses=est))
    return write_bag(
        bag_path(tmp, storage, "ROS_example"),
        storage,
        {
            "/groundtruth": ("geometry_msgs/msg/PoseStamped", gt),
            "/ORB_SLAM": ("geometry_msgs/msg/PoseStamped", est),
            "/S_PTAM": ("geometry_msgs/msg/PoseStamped", est2),
            "/slam/path": ("nav_msgs/msg/Path", paths),
        },
        ts,
    )


def _evo_ape(bag: Path, storage: str, ref: str, est: str, align: str) -> dict[str, float]:
    """APE translation part as evo_ape computes it from the bag (evo's own bag reader)."""
    from evo.core import metrics, sync
    from evo.tools import file_interface
    from rosbags.rosbag1 import Reader as Reader1
    from rosbags.rosbag2 import Reader as Reader2

    reader = Reader1(bag) if storage == "rosbag1" else Reader2(bag)
    reader.open()
    try:
        traj_ref = file_interface.read_bag_trajectory(reader, ref)
        traj_est = file_interface.read_bag_trajectory(reader, est)
    finally:
        reader.close()
    traj_ref, traj_est = sync.associate_trajectories(traj_ref, traj_est, max_diff=0.01)
    if align != "none":
        traj_est.align(traj_ref, correct_scale=align == "sim3")
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((traj_ref, traj_est))
    return dict(ape.get_all_statistics())


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    rc = main(list(argv))
    o = capsys.readouterr()
    return rc, o.out, o.err


def _ape_json(capsys: pytest.CaptureFixture[str], *argv: str) -> dict[str, Any]:
    rc, out, err = _run(capsys, "traj", "ape", *argv, "--format", "json")
    assert rc == 0, err
    return dict(json.loads(out))


# --------------------------------------------------------------- PoseStamped (evo's bags)
@pytest.mark.parametrize("storage", STORAGES)
@pytest.mark.parametrize("align", ["none", "se3", "sim3"])
def test_posestamped_topics_were_refused_and_now_evaluate_as_evo_does(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], storage: str, align: str
) -> None:
    bag = _evo_example_bag(tmp_path, storage)
    for est in ("/ORB_SLAM", "/S_PTAM"):
        ours = _ape_json(
            capsys,
            *(str(bag), str(bag)),
            *("--ref-topic", "/groundtruth", "--est-topic", est, "--align", align),
        )
        theirs = _evo_ape(bag, storage, "/groundtruth", est, align)
        assert ours["n_associated"] == 100
        for key in ("rmse", "mean", "median", "std", "min", "max"):
            assert ours[key] == pytest.approx(theirs[key], rel=1e-9, abs=1e-12), (est, key)


@pytest.mark.parametrize("storage", STORAGES)
def test_posestamped_topic_is_exported_read_and_written_back_as_stored(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], storage: str
) -> None:
    bag = _evo_example_bag(tmp_path, storage)
    rc, out, _ = _run(capsys, "bag", "info", str(bag))
    assert rc == 0 and "geometry_msgs/msg/PoseStamped  [reads]" in out
    m = ros.read_messages(bag, "/groundtruth")
    assert m.msgtype == "geometry_msgs/msg/PoseStamped" and m.cov is None and len(m) == 300
    t_gt, T_gt, _, _ = _trajectories()
    np.testing.assert_allclose(m.T, T_gt, atol=1e-12)
    assert set(m.frame_id) == {"world"} and m.child_frame_id is None
    tum = tmp_path / "gt.tum"
    assert (
        _run(
            capsys,
            "bag",
            "export",
            str(bag),
            "--topic",
            "/groundtruth",
            "--format",
            "tum",
            str(tum),
        )[0]
        == 0
    )
    rows = [ln.split() for ln in tum.read_text().splitlines() if not ln.startswith("#")]
    assert len(rows) == 300 and float(rows[7][0]) == pytest.approx(t_gt[7], abs=1e-9)
    assert [float(x) for x in rows[7][1:4]] == m.position[7].tolist()
    # the raw fields go back bit for bit
    out_bag = tmp_path / ("back.bag" if storage == "rosbag1" else f"back_{storage}")
    ros.write_messages(out_bag, "/groundtruth", m, storage=storage)
    back = ros.read_messages(out_bag, "/groundtruth")
    assert np.array_equal(back.position, m.position)
    assert np.array_equal(back.orientation_xyzw, m.orientation_xyzw)
    assert np.array_equal(back.stamp_nanosec, m.stamp_nanosec) and back.frame_id == m.frame_id


# ----------------------------------------------------------------------------- nav_msgs/Path
@pytest.mark.parametrize("storage", ["rosbag1", "mcap"])
def test_nav_path_topic_was_refused_and_its_last_message_is_the_trajectory(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], storage: str
) -> None:
    bag = _evo_example_bag(tmp_path, storage)
    b = str(bag)
    from_poses = _ape_json(capsys, b, b, "--ref-topic", "/groundtruth", "--est-topic", "/ORB_SLAM")
    from_path = _ape_json(capsys, b, b, "--ref-topic", "/groundtruth", "--est-topic", "/slam/path")
    for key in ("rmse", "mean", "max", "n_est", "n_associated"):
        assert from_path[key] == from_poses[key], key
    first = _ape_json(
        capsys, b, b, "--ref-topic", "/groundtruth", "--est-topic", "/slam/path",
        "--path-message", "1",
    )  # fmt: skip
    assert first["n_est"] == 10
    m = ros.read_messages(bag, "/slam/path", path_message=0)
    assert len(m) == 1 and m.msgtype == "nav_msgs/msg/Path" and m.frame_id == ("world",)
    rc, _, err = _run(
        capsys, "traj", "ape", b, b, "--ref-topic", "/groundtruth", "--est-topic", "/slam/path",
        "--path-message", "40",
    )  # fmt: skip
    assert rc == 2 and len(err.strip().splitlines()) == 1
    assert "--path-message 40" in err and "13 nav_msgs/Path messages" in err
    with pytest.raises(ValueError, match="read, not written"):
        ros.write_messages(tmp_path / "p.bag", "/p", ros.read_messages(bag, "/slam/path"))


# --------------------------------------------------------------------- NEES from the bag
def _covariances(n: int, rng: np.random.Generator) -> np.ndarray:
    A = rng.normal(size=(n, 6, 6)) * 0.05
    return A @ np.swapaxes(A, -1, -2) + np.diag([4e-4, 4e-4, 4e-4, 1e-4, 1e-4, 1e-4])


def _nees_bags(tmp: Path) -> tuple[Path, Path, Path, np.ndarray, np.ndarray]:
    """REF as TUM; EST as a PoseWithCovarianceStamped bag, an Odometry bag and a TUM file."""
    rng = np.random.default_rng(5)
    t_gt, T_gt, _, _ = _trajectories()
    n = len(t_gt)
    C_ros = _covariances(n, rng)
    # errors drawn from the covariances, in ROS's perturbation (t + u, Exp(w) R)
    e = np.einsum("nij,nj->ni", np.linalg.cholesky(C_ros), rng.normal(size=(n, 6)))
    T_est = T_gt.copy()
    T_est[:, :3, 3] += e[:, :3]
    T_est[:, :3, :3] = so3.exp(e[:, 3:]) @ T_gt[:, :3, :3]
    lb.io.trajectory.write_tum(tmp / "ref.txt", t_gt, T_gt)
    lb.io.trajectory.write_tum(tmp / "est.txt", t_gt, T_est)
    pwcs = ros.write_messages(
        tmp / "est.bag", "/est", ros.from_poses(T_est, C_ros, stamps=t_gt, frame_id="map")
    )
    odom = ros.write_messages(
        tmp / "odom.mcap",
        "/odom",
        ros.from_poses(T_est, C_ros, stamps=t_gt, frame_id="map", msgtype="nav_msgs/msg/Odometry"),
    )
    return tmp / "ref.txt", pwcs, odom, T_est, C_ros


def _nees_json(capsys: pytest.CaptureFixture[str], *argv: str) -> dict[str, Any]:
    rc, out, err = _run(capsys, "traj", "nees", *argv, "--format", "json")
    assert rc == 0, err
    return dict(json.loads(out))


def test_traj_nees_required_cov_and_now_reads_covariances_from_the_bag_topic(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    ref, pwcs, odom, _, C_ros = _nees_bags(tmp_path)
    np.save(tmp_path / "cov.npy", C_ros)
    given = _nees_json(
        capsys, str(ref), str(tmp_path / "est.txt"), "--cov", str(tmp_path / "cov.npy"),
        "--convention", "ros", "--align", "se3",
    )  # fmt: skip
    for bag, topic in ((pwcs, "/est"), (odom, "/odom")):
        got = _nees_json(capsys, str(ref), str(bag), "--est-topic", topic, "--align", "se3")
        assert got["covariance_source"] == f"EST topic {topic}" and got["convention"] == "ros"
        for key in ("anees", "rmse", "max", "n_associated"):
            assert got[key] == pytest.approx(given[key], rel=1e-9), (topic, key)
    # errors drawn from the covariances: ANEES ≈ 6 (the statistic is meaningful, not just equal)
    assert 5.0 < given["anees"] < 7.0
    # in another convention the covariances are converted, not relabelled: ANEES moves little
    g = _nees_json(capsys, str(ref), str(pwcs), "--est-topic", "/est", "--convention", "gtsam")
    assert g["convention"] == "gtsam" and g["anees"] == pytest.approx(given["anees"], rel=0.05)


def test_traj_nees_reads_the_npz_that_bag_export_writes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    ref, pwcs, _, T_est, C_ros = _nees_bags(tmp_path)
    npz = tmp_path / "est.npz"
    rc, *_ = _run(
        capsys, "bag", "export", str(pwcs), "--topic", "/est", "--format", "npz", str(npz),
        "--convention", "gtsam",
    )  # fmt: skip
    assert rc == 0
    np.save(tmp_path / "cov_gtsam.npy", lb.convert_covariance(C_ros, T_est, "ros", "gtsam"))
    given = _nees_json(
        capsys, str(ref), str(tmp_path / "est.txt"), "--cov", str(tmp_path / "cov_gtsam.npy"),
        "--convention", "gtsam",
    )  # fmt: skip
    got = _nees_json(capsys, str(ref), str(npz))
    assert got["convention"] == "gtsam" and got["covariance_source"] == f"EST {npz}"
    for key in ("anees", "rmse", "n_associated"):
        assert got[key] == pytest.approx(given[key], rel=1e-9), key
    # asked in ROS's convention, the npz's GTSAM covariances are converted back
    np.save(tmp_path / "cov.npy", C_ros)
    ros_given = _nees_json(
        capsys, str(ref), str(tmp_path / "est.txt"), "--cov", str(tmp_path / "cov.npy"),
        "--convention", "ros",
    )  # fmt: skip
    as_ros = _nees_json(capsys, str(ref), str(npz), "--convention", "ros")
    assert as_ros["anees"] == pytest.approx(ros_given["anees"], rel=1e-9)


def test_traj_nees_without_covariances_anywhere_names_the_flag(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = _evo_example_bag(tmp_path, "rosbag1")
    b = str(bag)
    rc, _, err = _run(
        capsys, "traj", "nees", b, b, "--ref-topic", "/groundtruth", "--est-topic", "/ORB_SLAM"
    )
    assert rc == 2 and len(err.strip().splitlines()) == 1
    assert "--cov" in err and "PoseStamped" in err and "Traceback" not in err
    t_gt, T_gt, _, _ = _trajectories()
    lb.io.trajectory.write_tum(tmp_path / "r.txt", t_gt, T_gt)
    rc, _, err = _run(capsys, "traj", "nees", str(tmp_path / "r.txt"), str(tmp_path / "r.txt"))
    assert rc == 2 and "--cov" in err and len(err.strip().splitlines()) == 1
    np.save(tmp_path / "c.npy", np.tile(np.eye(6), (300, 1, 1)))
    rc, _, err = _run(
        capsys, "traj", "nees", *(str(tmp_path / "r.txt"),) * 2, "--cov", str(tmp_path / "c.npy")
    )
    assert rc == 2 and "--convention" in err


# --------------------------------------------------------------- g2o of absolute poses
def _amcl_bag(tmp: Path, planar: bool = True) -> tuple[Path, ros.RosMessages]:
    """nav2's /amcl_pose: planar motion, covariance in x, y, yaw only (zeros elsewhere)."""
    n = 12
    yaw = 0.3 * np.arange(n)
    T = se3.exp(np.c_[np.zeros(n), np.zeros(n), yaw, 0.5 * np.arange(n), np.sin(yaw), 0 * yaw])
    C = np.zeros((n, 6, 6))
    C[:, 0, 0], C[:, 1, 1], C[:, 0, 1], C[:, 1, 0] = 0.04, 0.09, 0.01, 0.01
    C[:, 5, 5] = 0.02 + 0.001 * np.arange(n)
    if not planar:
        C[:, 2, 2], C[:, 3, 3], C[:, 4, 4] = 0.01, 0.003, 0.004
    m = ros.from_poses(T, C, stamps=T0 + np.arange(n) * 0.5, frame_id="map")
    return ros.write_messages(tmp / "amcl.bag", "/amcl_pose", m), m


def test_independent_increment_covariance_matches_monte_carlo() -> None:
    """Σ_Z = Σ_{k+1} + Ad(Z⁻¹) Σ_k Ad(Z⁻¹)ᵀ, sampled in ROS's own perturbation."""
    rng = np.random.default_rng(3)
    T = se3.exp(np.array([[0.2, -0.1, 0.4, 1.0, 2.0, 0.5], [0.5, 0.3, -0.2, 3.0, 1.0, 1.5]]))
    C = _covariances(2, rng) * 0.5
    m = ros.from_poses(T, C, stamps=[1.0, 2.0], frame_id="map")
    Z, cz = ros.increment_covariances(m, "independent")
    k = 200_000
    e = [np.einsum("ij,nj->ni", np.linalg.cholesky(C[i]), rng.normal(size=(k, 6))) for i in (0, 1)]
    Ts = []
    for i in (0, 1):  # ROS: position error in the parent frame, rotation about the fixed axes
        Ti = np.broadcast_to(T[i], (k, 4, 4)).copy()
        Ti[:, :3, 3] += e[i][:, :3]
        Ti[:, :3, :3] = so3.exp(e[i][:, 3:]) @ T[i, :3, :3]
        Ts.append(Ti)
    xi = se3.log(se3.inverse(Z[0]) @ se3.inverse(Ts[0]) @ Ts[1])  # GTSAM's (ω, v), right
    emp = np.cov(xi.T)
    scale = np.sqrt(np.outer(np.diag(cz[0]), np.diag(cz[0])))
    assert np.abs(emp - cz[0]).max() / scale.max() < 0.03
    assert np.abs(xi.mean(axis=0)).max() < 0.05 * np.sqrt(np.diag(cz[0])).max()


def test_bag_export_g2o_refused_pose_with_covariance_and_now_writes_rank_deficient_information(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag, m = _amcl_bag(tmp_path)
    out = tmp_path / "amcl.g2o"
    rc, text, err = _run(
        capsys, "bag", "export", str(bag), "--topic", "/amcl_pose", "--format", "g2o", str(out)
    )
    assert rc == 0, err
    assert "--increment independent" in text and "rank 3" in text
    graph = g2o.read(out)
    _, cz = ros.increment_covariances(m, "independent")
    info = graph.information
    assert info.shape == (11, 6, 6)
    lam = np.linalg.eigvalsh(info)
    assert (lam[:, :3] < 1e-9 * lam[:, -1:]).all() and (lam[:, 3:] > 1e-3).all()  # rank 3
    # the Moore–Penrose pseudo-inverse: Λ Σ Λ = Λ, Σ Λ Σ = Σ, to the file's 9-digit precision
    np.testing.assert_allclose(info @ cz @ info, info, atol=1e-6 * np.abs(info).max())
    np.testing.assert_allclose(cz @ info @ cz, cz, atol=1e-6 * np.abs(cz).max())
    # unconstrained exactly where the messages carry no variance: z, roll, pitch of the body
    for k in range(11):
        null = np.linalg.eigh(cz[k])[1][:, :3]
        assert np.abs(info[k] @ null).max() < 1e-6 * np.abs(info[k]).max()
    # with full 6-dof covariances the information is the plain inverse
    (tmp_path / "full").mkdir()
    bag6, m6 = _amcl_bag(tmp_path / "full", planar=False)
    out6 = tmp_path / "full.g2o"
    rc, text, _ = _run(
        capsys, "bag", "export", str(bag6), "--topic", "/amcl_pose", "--format", "g2o", str(out6)
    )
    assert rc == 0 and "rank-deficient" not in text
    _, cz6 = ros.increment_covariances(m6, "independent")
    np.testing.assert_allclose(
        np.linalg.inv(g2o.read(out6).information), cz6, rtol=1e-6, atol=1e-12
    )


def test_bag_export_g2o_of_all_zero_odometry_covariances_said_singular_matrix(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    n = 8
    T = se3.exp(np.c_[np.zeros((n, 2)), 0.1 * np.arange(n), np.arange(n), np.zeros((n, 2))])
    m = ros.from_poses(
        T, None, stamps=T0 + np.arange(n), frame_id="odom", msgtype="nav_msgs/msg/Odometry"
    )
    bag = ros.write_messages(tmp_path / "odom.bag", "/odom", m)
    for extra, hint in (((), "--increment twist"), (("--increment", "twist"), "--format tum")):
        rc, _, err = _run(
            capsys, "bag", "export", str(bag), "--topic", "/odom", "--format", "g2o",
            str(tmp_path / "o.g2o"), *extra,
        )  # fmt: skip
        assert rc == 2 and len(err.strip().splitlines()) == 1
        assert "all zero" in err and hint in err and "Singular" not in err
    assert not (tmp_path / "o.g2o").exists()
    rc, _, err = _run(
        capsys, "bag", "write-marginals", str(bag), str(tmp_path / "w.bag"), "--topic", "/odom"
    )
    assert rc == 2 and "rank 0 of 6" in err and "Singular" not in err


def test_bag_export_g2o_messages_named_python_keywords_not_cli_flags(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag, _ = _amcl_bag(tmp_path)
    errors = []
    for inc in ("twist", "difference"):
        rc, _, err = _run(
            capsys, "bag", "export", str(bag), "--topic", "/amcl_pose", "--format", "g2o",
            str(tmp_path / "x.g2o"), "--increment", inc,
        )  # fmt: skip
        assert rc == 2
        errors.append(err)
    rc, _, err = _run(
        capsys, "bag", "write-marginals", str(bag), str(tmp_path / "w.bag"), "--topic",
        "/amcl_pose", "--increment", "twist",
    )  # fmt: skip
    errors.append(err)
    for err in errors:
        assert "--increment independent" in err, err
        assert "increment=" not in err and "increment '" not in err and "msgs:" not in err, err


# ------------------------------------------------------------------------------ scale
def test_read_messages_held_900_bytes_an_odometry_message_now_about_750(tmp_path: Path) -> None:
    """The arrays ``read_messages`` returns: ~750 B an Odometry message (the pose matrices,
    128 B more, are built at first use)."""
    n = 10_000
    rng = np.random.default_rng(0)
    T = se3.exp(rng.normal(size=(n, 6)))
    m = ros.from_poses(
        T, np.tile(np.eye(6), (n, 1, 1)), stamps=T0 + 0.01 * np.arange(n), frame_id="odom",
        msgtype="nav_msgs/msg/Odometry", twist=rng.normal(size=(n, 6)),
    )  # fmt: skip
    bag = ros.write_messages(tmp_path / "big.bag", "/odom", m)
    del m
    ros.read_messages(bag, "/odom")  # imports and type stores loaded before the count
    gc.collect()
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        held = ros.read_messages(bag, "/odom")
        gc.collect()
        per_message = (tracemalloc.get_traced_memory()[0] - before) / n
    finally:
        tracemalloc.stop()
    assert len(held) == n
    assert per_message < 800, per_message
    np.testing.assert_allclose(held.T, T, atol=1e-12)  # the pose matrices, on demand
