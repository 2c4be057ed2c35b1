"""liebridge.ros ↔ GTSAM, the `liebridge bag` command and the bag_to_gtsam example."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import gtsam
import numpy as np
import pytest

pytest.importorskip("rosbags")

from liebridge import ros
from liebridge.cli import main
from liebridge.lie import se3

ROOT = Path(__file__).resolve().parents[1]


def _odometry_bag(tmp_path: Path, n: int = 25, name: str = "od.bag") -> tuple[Path, np.ndarray]:
    """Dead-reckoned odometry with first-order propagated covariance (GTSAM tangent)."""
    rng = np.random.default_rng(5)
    Q = np.diag([1e-4, 2e-4, 3e-4, 1e-2, 2e-2, 3e-2])
    Ts, C = [se3.exp(np.array([0.1, 0.2, 0.3, 1.0, 2.0, 3.0]))], [np.eye(6) * 1e-6]
    for _ in range(n - 1):
        Z = se3.exp(rng.normal(size=6) * [0.1, 0.1, 0.3, 1.0, 0.2, 0.1])
        A = se3.adjoint(se3.inverse(Z))
        Ts.append(Ts[-1] @ Z)
        C.append(A @ C[-1] @ A.T + Q)
    m = ros.from_poses(
        np.array(Ts),
        np.array(C),
        convention="gtsam",
        stamps=np.arange(n) * 0.1,
        msgtype="nav_msgs/Odometry",
        frame_id="odom",
    )
    return ros.write_messages(tmp_path / name, "/odom", m), Q


def test_increment_covariance_converted_not_copied(tmp_path: Path) -> None:
    p, Q = _odometry_bag(tmp_path)
    m = ros.read_messages(p, "/odom")
    Z, cz = ros.increment_covariances(m)
    np.testing.assert_allclose(cz, np.broadcast_to(Q, cz.shape), atol=1e-12)
    np.testing.assert_allclose(Z, se3.inverse(m.T[:-1]) @ m.T[1:], atol=0)
    assert m.cov is not None
    assert np.abs((m.cov[1:] - m.cov[:-1]) - Q).max() > 1.0 * Q.max()  # a copy would be wrong


def test_gtsam_round_trip_reproduces_message_covariance(tmp_path: Path) -> None:
    """Bag → odometry graph → GTSAM marginals → messages: the ROS covariances come back."""
    p, _ = _odometry_bag(tmp_path)
    m = ros.read_messages(p, "/odom")
    graph = gtsam.NonlinearFactorGraph()
    for f in ros.odometry_factors(m):
        graph.add(f)
    values = gtsam.Values()
    for k in range(len(m)):
        values.insert(k, gtsam.Pose3(m.T[k]))
    assert graph.error(values) < 1e-12
    out = ros.messages_from_gtsam(graph, values, range(len(m)), stamps=m.stamps, frame_id="odom")
    assert out.cov is not None and m.cov is not None
    rel = np.abs(out.cov - m.cov).max() / np.abs(m.cov).max()
    assert rel < 1e-8, rel
    np.testing.assert_allclose(out.T, m.T, atol=1e-12)
    q = ros.write_messages(tmp_path / "opt", "/opt", out, storage="sqlite3")
    back = ros.read_messages(q, "/opt")
    assert back.pose_covariance is not None and out.pose_covariance is not None
    assert np.array_equal(back.pose_covariance, out.pose_covariance)


def test_increment_difference_rejects_non_growing_covariance(tmp_path: Path) -> None:
    T = se3.exp(np.random.default_rng(0).normal(size=(5, 6)))
    m = ros.from_poses(
        T,
        np.tile(np.eye(6) * 1e-2, (5, 1, 1)),
        stamps=np.arange(5.0),
        msgtype="nav_msgs/Odometry",
        twist_cov=np.tile(np.eye(6) * 1e-2, (5, 1, 1)),
    )
    with pytest.raises(ValueError, match=r"message 1: pose covariance does not grow"):
        ros.increment_covariances(m)
    _, cz = ros.increment_covariances(m, "twist")  # dt = 1: Σ_Z = Σ_twist reordered
    np.testing.assert_allclose(cz, np.tile(np.eye(6) * 1e-2, (4, 1, 1)))


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    rc = main(list(argv))
    o = capsys.readouterr()
    return rc, o.out, o.err


def test_cli_info_export_write_marginals(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    p, _ = _odometry_bag(tmp_path)
    rc, out, _ = run(capsys, "bag", "info", str(p))
    assert rc == 0 and "/odom" in out and "nav_msgs/msg/Odometry" in out and "[reads]" in out
    tum = tmp_path / "o.tum"
    assert (
        run(capsys, "bag", "export", str(p), "--topic", "/odom", "--format", "tum", str(tum))[0]
        == 0
    )
    m = ros.read_messages(p, "/odom")
    first = tum.read_text().splitlines()[2].split()
    assert np.array_equal([float(x) for x in first[1:]], [*m.position[1], *m.orientation_xyzw[1]])
    npz = tmp_path / "o.npz"
    rc, *_ = run(
        capsys,
        "bag",
        "export",
        str(p),
        "--topic",
        "/odom",
        "--format",
        "npz",
        str(npz),
        "--convention",
        "gtsam",
    )
    assert rc == 0
    d = np.load(npz)
    g = m.with_convention("gtsam")
    assert g.cov is not None and np.array_equal(d["cov"], g.cov) and str(d["convention"]) == "gtsam"
    g2o_path = tmp_path / "o.g2o"
    rc, *_ = run(
        capsys, "bag", "export", str(p), "--topic", "/odom", "--format", "g2o", str(g2o_path)
    )
    assert rc == 0
    from liebridge.io import g2o

    graph = g2o.read(g2o_path)
    _, cz = ros.increment_covariances(m)
    np.testing.assert_allclose(np.linalg.inv(graph.information), cz, rtol=1e-6, atol=1e-12)
    out_bag = tmp_path / "marg.mcap"
    rc, out, err = run(capsys, "bag", "write-marginals", str(p), str(out_bag), "--topic", "/odom")
    assert rc == 0 and "optimized" in err
    back = ros.read_messages(out_bag, "/liebridge/poses")
    assert back.msgtype == "geometry_msgs/msg/PoseWithCovarianceStamped" and len(back) == len(m)
    assert back.cov is not None and m.cov is not None
    assert np.abs(back.cov - m.cov).max() / np.abs(m.cov).max() < 1e-8
    data = gtsam.findExampleDataFile("pose3example.txt")
    rc, out, _ = run(
        capsys, "bag", "write-marginals", data, str(tmp_path / "pe.bag"), "--msgtype", "odometry"
    )
    assert rc == 0
    pe = ros.read_messages(tmp_path / "pe.bag", "/liebridge/poses")
    assert pe.msgtype == "nav_msgs/msg/Odometry" and len(pe) == 5


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["bag", "info", "{tmp}/missing.bag"], "missing.bag: no such bag"),
        (
            ["bag", "export", "{bag}", "--topic", "/nope", "--format", "tum", "{tmp}/x.tum"],
            "no topic '/nope' (topics: /odom)",
        ),
        (["bag", "info", "{tmp}/trunc.bag"], "trunc.bag: not a readable bag"),
        (
            [
                "bag",
                "export",
                "{bag}",
                "--topic",
                "/odom",
                "--format",
                "npz",
                "{tmp}/x.npz",
                "--convention",
                "nope",
            ],
            "--convention",
        ),
        (["bag", "write-marginals", "{bag}", "{tmp}/x.bag"], "--topic: required"),
    ],
)
def test_cli_bad_input_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], expected: str
) -> None:
    p, _ = _odometry_bag(tmp_path)
    data = p.read_bytes()
    (tmp_path / "trunc.bag").write_bytes(data[: len(data) // 3])
    rc, _, err = run(capsys, *[a.format(tmp=tmp_path, bag=p) for a in argv])
    assert rc == 2
    assert err.count("\n") == 1 and expected in err and "Traceback" not in err, err
    assert not (tmp_path / "x.tum").exists() and not (tmp_path / "x.npz").exists()


def test_cli_wrong_covariance_length_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    base = get_typestore(Stores.ROS1_NOETIC)
    ts = get_typestore(Stores.EMPTY)
    ts.register({k: d for k, d in base.fielddefs.items() if not k.endswith("/PoseWithCovariance")})
    ts.register(
        get_types_from_msg(
            "geometry_msgs/Pose pose\nfloat64[] covariance", "geometry_msgs/msg/PoseWithCovariance"
        )
    )
    t = ts.types
    mt = "geometry_msgs/msg/PoseWithCovarianceStamped"
    with Writer(tmp_path / "w.bag") as w:
        c = w.add_connection("/pose", mt, typestore=ts)
        for k, n in enumerate((36, 36, 36, 6)):
            msg = t[mt](
                header=t["std_msgs/msg/Header"](
                    seq=k, stamp=t["builtin_interfaces/msg/Time"](sec=k, nanosec=0), frame_id="map"
                ),
                pose=t["geometry_msgs/msg/PoseWithCovariance"](
                    pose=t["geometry_msgs/msg/Pose"](
                        position=t["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
                        orientation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
                    ),
                    covariance=np.eye(6).ravel()[:n],
                ),
            )
            w.write(c, k + 1, ts.serialize_ros1(msg, mt))
    rc, _, err = run(
        capsys,
        "bag",
        "export",
        str(tmp_path / "w.bag"),
        "--topic",
        "/pose",
        "--format",
        "tum",
        str(tmp_path / "w.tum"),
    )
    assert rc == 2 and err.count("\n") == 1
    assert "w.bag: topic /pose, message 3: field pose.covariance: expected 36 numbers, got 6" in err
    assert not (tmp_path / "w.tum").exists()


def test_example_bag_to_gtsam(tmp_path: Path) -> None:
    r = subprocess.run(
        [
            sys.executable,
            str(ROOT / "examples" / "bag_to_gtsam.py"),
            "--quick",
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"},
    )
    assert r.returncode == 0, r.stderr
    line = next(ln for ln in r.stdout.splitlines() if ln.startswith("increment covariance"))
    conv = float(line.split("converted rel. error ")[1].split(";")[0])
    copied = float(line.split("copied (no conversion) ")[1])
    assert conv < 1e-9 and copied > 1.0
    rmse = next(ln for ln in r.stdout.splitlines() if ln.startswith("position RMSE"))
    odo = float(rmse.split("odometry ")[1].split(" m")[0])
    opt = float(rmse.split("optimized ")[1].split(" m")[0])
    assert opt < odo
    png = tmp_path / "bag_to_gtsam.png"
    assert png.is_file() and png.stat().st_size > 10_000
    back = ros.read_messages(tmp_path / "optimized.bag", "/optimized")
    assert len(back) == 60 and back.storage == "rosbag1"


def test_cli_progress_on_long_bag(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    n = 4500
    m = ros.from_poses(
        np.tile(np.eye(4), (n, 1, 1)),
        None,
        stamps=np.arange(n) * 0.01,
        msgtype="geometry_msgs/TransformStamped",
    )
    p = ros.write_messages(tmp_path / "long.bag", "/tf_one", m)
    rc, _, err = run(
        capsys,
        "bag",
        "export",
        str(p),
        "--topic",
        "/tf_one",
        "--format",
        "tum",
        str(tmp_path / "l.tum"),
    )
    assert rc == 0
    assert "read /tf_one: 2000/4500 messages" in err and "read /tf_one: 4500/4500 messages" in err
