"""Hostile inputs on the newer surfaces: no wrong answer, crash or hang; a clear error instead.

One test per class of failure found by a hostile-input run, named after the bug it pins (each
fails on the code before its fix), plus the kind of test that finds the class: a property test
that every operation taking a convention checks the convention's group against the element's,
and one that no public function returns non-finite output for finite input without saying why.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
import time
from pathlib import Path
from typing import Any

import gtsam
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import liebridge as lb
import liebridge.gtsam as F
from liebridge import traj
from liebridge.cli import main
from liebridge.conventions import get, names
from liebridge.frames import StampedTransform, Transform, TransformTree
from liebridge.frames import calibration as calib
from liebridge.io import g2o2d
from liebridge.lie import se3, sim3, so3
from liebridge.uncertain import UncertainPose, fuse

RNG = np.random.default_rng(20261127)
X5 = se3.exp(RNG.normal(size=(5, 6)) * 0.5)
C6 = np.diag([0.01, 0.02, 0.03, 0.1, 0.2, 0.3])


def _cli(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    rc = main(argv)
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return rc, out, err


# ============================================================== wrong answers and damaged files
def test_unscented_convert_covariance_keeps_every_covariance_at_one_pose() -> None:
    """Five covariances at one pose: five results (the chunk loop dropped four)."""
    C = np.stack([C6 * (k + 1) for k in range(5)])
    out = lb.convert_covariance(C, X5[0], "gtsam", "symforce", method="unscented")
    assert out.shape == (5, 6, 6)
    one = [lb.convert_covariance(c, X5[0], "gtsam", "symforce", method="unscented") for c in C]
    np.testing.assert_allclose(out, np.stack(one), rtol=1e-12, atol=1e-15)


def test_unscented_convert_covariance_one_covariance_at_more_poses_than_a_chunk() -> None:
    """One covariance at more poses than a chunk holds (numpy's broadcast error before)."""
    X = se3.exp(RNG.normal(size=(7, 6)))
    out = lb.convert_covariance(C6, X, "gtsam", "sophus", method="unscented", chunk_size=3)
    ref = np.stack([lb.convert_covariance(C6, x, "gtsam", "sophus", method="unscented") for x in X])
    np.testing.assert_allclose(out, ref, rtol=1e-12, atol=1e-15)
    batched = np.broadcast_to(X, (2, 7, 4, 4))  # and over two batch axes, cov broadcast too
    out2 = lb.convert_covariance(C6, batched, "gtsam", "sophus", method="unscented", chunk_size=4)
    np.testing.assert_allclose(out2, np.stack([ref, ref]), rtol=1e-12, atol=1e-15)


def test_ape_of_huge_translations_is_finite_not_inf() -> None:
    """Translations 1e200 apart: the error is 1.7e200 (the norm squared overflowed to inf)."""
    T, E = np.tile(np.eye(4), (3, 1, 1)), np.tile(np.eye(4), (3, 1, 1))
    E[:, :3, 3] = 1e200
    for rel in ("trans_part", "full"):
        np.testing.assert_allclose(traj.ape(T, E, rel), np.sqrt(3.0) * 1e200, rtol=1e-15)
    err, _ = traj.rpe(T, np.cumsum(E, axis=0) / np.arange(1, 4)[:, None, None] * 0 + E)
    assert np.isfinite(err).all()


def test_ape_beyond_float64_says_why() -> None:
    T, E = np.tile(np.eye(4), (2, 1, 1)), np.tile(np.eye(4), (2, 1, 1))
    T[:, :3, 3], E[:, :3, 3] = -1e308, 1e308
    with pytest.raises(ValueError, match="ape: the error at index 0 overflows float64"):
        traj.ape(T, E)


def test_statistics_of_huge_errors_is_finite_or_says_why() -> None:
    s = traj.statistics([1e150, 2e150, 3e150])
    assert s.rmse == pytest.approx(np.sqrt(14.0 / 3.0) * 1e150, rel=1e-14)
    assert s.mean == pytest.approx(2e150, rel=1e-15) and np.isfinite(s.std)
    with pytest.raises(ValueError, match=r"sum of squares .* overflows float64 .*1e\+200"):
        traj.statistics([1e200, 1e200])


def test_nees_of_a_subnormal_covariance_says_why_not_inf() -> None:
    X = se3.exp(np.zeros((3, 6)))
    Y = se3.exp(np.full((3, 6), 1e-3))
    with pytest.raises(ValueError, match="NEES at pose 0 overflows float64"):
        traj.nees(X, Y, np.stack([np.eye(6) * 1e-316] * 3), "gtsam")


def test_traj_nees_cov_npy_complex_or_huge_header_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    t = np.arange(5.0)
    tum = "\n".join(f"{s} {s} 0 0 0 0 0 1" for s in t)
    (tmp_path / "a.tum").write_text(tum)
    np.save(tmp_path / "c.npy", np.stack([np.eye(6)] * 5) * (1 + 1j))
    rc, _, err = _cli(
        [
            "traj",
            "nees",
            str(tmp_path / "a.tum"),
            str(tmp_path / "a.tum"),
            "--cov",
            str(tmp_path / "c.npy"),
            "--convention",
            "gtsam",
        ],
        capsys,
    )
    assert rc == 2 and "complex" in err
    huge = tmp_path / "h.npy"
    with open(huge, "wb") as fh:
        np.lib.format.write_array_header_1_0(
            fh, {"descr": "<f8", "fortran_order": False, "shape": (10**11, 6, 6)}
        )
        fh.write(b"\0" * 64)
    rc, _, err = _cli(
        [
            "traj",
            "nees",
            str(tmp_path / "a.tum"),
            str(tmp_path / "a.tum"),
            "--cov",
            str(huge),
            "--convention",
            "gtsam",
        ],
        capsys,
    )
    assert rc == 2 and "header promises shape (100000000000, 6, 6)" in err


def test_g2o_graph_2d_validates_and_does_not_freeze_the_callers_arrays() -> None:
    ids, xyt = np.array([0, 1]), np.zeros((2, 3))
    edges, z, info = np.array([[0, 1]]), np.array([[1.0, 0.0, 0.0]]), np.eye(3)[None].copy()
    g = g2o2d.G2OGraph2D(ids, xyt, edges, z, info)
    for a in (ids, xyt, edges, z, info):
        assert a.flags.writeable  # the caller's arrays stay the caller's
    assert not g.information.flags.writeable
    bad_info = info.copy()
    bad_info[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="information"):
        g2o2d.G2OGraph2D(ids, xyt, edges, z, bad_info)
    with pytest.raises(ValueError, match="not positive semi-definite"):
        g2o2d.G2OGraph2D(ids, xyt, edges, z, -info)
    with pytest.raises(ValueError, match="vertex_ids: expected integer ids"):
        g2o2d.G2OGraph2D(ids + 0.5, xyt, edges, z, info)
    with pytest.raises(ValueError, match=r"edges\[0\]: \(0, 7\) refers to a missing vertex"):
        g2o2d.G2OGraph2D(ids, xyt, np.array([[0, 7]]), z, info)


@pytest.mark.parametrize(
    "lines",
    [
        ["VERTEX_SE2 2 2 0 0"],  # a vertex without an edge
        ["VERTEX_SE2 2 2 0 0", "VERTEX_SE2 3 3 0 0", "EDGE_SE2 2 3 1 0 0 1 0 0 1 0 1"],  # 2 parts
    ],
    ids=["unconnected_vertex", "two_parts"],
)
def test_optimize_2d_graph_not_tied_to_its_gauge_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], lines: list[str]
) -> None:
    base = ["VERTEX_SE2 0 0 0 0", "VERTEX_SE2 1 1 0 0", "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1"]
    f = tmp_path / "g.g2o"
    f.write_text("\n".join(base + lines) + "\n")
    rc, _, err = _cli(["optimize", str(f), "--marginals", str(tmp_path / "m.npy")], capsys)
    assert rc == 2 and "the graph is not connected" in err
    assert not (tmp_path / "m.npy").exists()


def _chain(with_prior: bool) -> tuple[Any, Any]:
    g = gtsam.NonlinearFactorGraph()
    Z = se3.exp(np.array([0.0, 0.0, 0.1, 1.0, 0.0, 0.0]))
    g.add(F.between(0, 1, Z, C6, "gtsam", native=False))
    if with_prior:
        g.add(F.prior(0, np.eye(4), C6, "gtsam", native=False))
    v = gtsam.Values()
    v.insert(0, gtsam.Pose3())
    v.insert(1, gtsam.Pose3(Z @ se3.exp(np.full(6, 0.05))))
    return g, v


def test_isam2_failed_update_can_be_retried_and_gtsam_state_is_rebuilt() -> None:
    """A failed update (no prior) left the wrapper refusing the retry and GTSAM's ISAM2 off."""
    isam = F.ISAM2()
    with pytest.raises(RuntimeError, match=r"Indeterminant|Indeterminate"):
        isam.update(*_chain(with_prior=False))
    isam.update(*_chain(with_prior=True))
    ref = F.ISAM2()
    ref.update(*_chain(with_prior=True))
    for _ in range(12):  # past a relinearization (skip 10)
        isam.update()
        ref.update()
    for k in (0, 1):
        np.testing.assert_allclose(
            isam.calculate_estimate().atPose3(k).matrix(),
            ref.calculate_estimate().atPose3(k).matrix(),
            atol=1e-12,
        )
    assert isam.isam2.getFactorsUnsafe().size() == ref.isam2.getFactorsUnsafe().size()


def test_prior_with_subnormal_covariance_refused() -> None:
    """1e-310·I passes every relative test; its inverse overflows (optimize returned the start)."""
    with pytest.raises(ValueError, match=r"singular covariance .* at least 1e-200"):
        F.prior(0, np.eye(4), 1e-310 * np.eye(6))
    F.prior(0, np.eye(4), 1e-20 * np.eye(6))  # a tight but representable prior stays valid


@pytest.mark.parametrize("tol", [-1.0, 0.0, float("nan"), 0.5])
def test_transform_tolerance_outside_its_range_refused(tol: float) -> None:
    A = np.eye(4)
    A[:3, :3] *= 1.4  # ‖RᵀR − I‖ = 0.96: accepted by tol = -1 before
    with pytest.raises(ValueError, match=r"tol .*expected a rotation tolerance in"):
        Transform(A, "a", "b", tol=tol)


def test_transform_tree_lookup_between_stamps_far_apart() -> None:
    """Stamps ±1e308: the midpoint is halfway, not the first pose (the difference overflowed)."""
    T1 = np.eye(4)
    T1[0, 3] = 2.0
    tf = StampedTransform(Transform(np.stack([np.eye(4), T1]), "a", "b"), np.array([-1e308, 1e308]))
    assert TransformTree([tf]).lookup("a", "b", 0.0).T[0, 3] == pytest.approx(1.0, abs=1e-15)
    Tq = traj.interpolate_poses(np.array([0.0]), np.array([-1e308, 1e308]), tf.transform.T)
    assert Tq[0, 0, 3] == pytest.approx(1.0, abs=1e-15)


# ---------------------------------------------------------- the group of a convention, checked
NOT_POSE = sorted(n for n in names() if getattr(get(n), "group", None) not in ("se3", "so3"))
POSE_OPERATIONS: dict[str, Any] = {
    "UncertainPose": lambda c: UncertainPose(np.eye(4), np.eye(6), c),
    "UncertainPose.to": lambda c: UncertainPose(np.eye(4), np.eye(6), "gtsam").to(c),
    "traj.nees": lambda c: traj.nees(X5, X5, np.stack([np.eye(6)] * 5), c),
    "Alignment.transform_covariance": lambda c: traj.align(X5, X5).transform_covariance(
        X5, np.stack([np.eye(6)] * 5), c
    ),
    "Alignment.covariance_map": lambda c: traj.align(X5, X5).covariance_map(X5, c),
    "synchronize": lambda c: traj.synchronize(
        np.arange(5.0), X5, np.arange(5.0), X5, cov_est=np.stack([np.eye(6)] * 5), convention=c
    ),
    "interpolate_covariances": lambda c: traj.interpolate_covariances(
        np.array([0.5]), np.arange(5.0), X5, np.stack([np.eye(6)] * 5), c
    ),
    "Transform": lambda c: Transform(np.eye(4), "a", "b", np.eye(6), c),
}


def test_every_non_pose_group_is_covered() -> None:
    assert {"gtsam_similarity3", "gtsam_pose2", "gtsam_rot2", "gtsam_navstate"} <= set(NOT_POSE)
    assert any(type(get(n)).__name__ == "Bundle" for n in NOT_POSE)


@pytest.mark.parametrize("op", sorted(POSE_OPERATIONS))
@pytest.mark.parametrize("name", NOT_POSE)
def test_pose_operation_refuses_a_convention_of_another_group(op: str, name: str) -> None:
    """Every operation on poses that takes a convention checks the convention's group."""
    with pytest.raises(ValueError, match=rf"convention.*{name!r} is a convention of"):
        POSE_OPERATIONS[op](name)


def test_uncertain_pose_of_a_gtsam_pose2_names_the_group() -> None:
    with pytest.raises(ValueError, match="'gtsam_pose2' is a convention of se2"):
        UncertainPose(gtsam.Pose2(1.0, 2.0, 0.3), np.eye(3), "gtsam_pose2")


# ------------------------------------------------------------------ ROS: topics, frames, stamps
rosbags = pytest.importorskip("rosbags")
from liebridge import ros  # noqa: E402


def _bag(tmp_path: Path, frames: list[str]) -> Path:
    n = len(frames)
    T = se3.exp(np.c_[np.zeros((n, 3)), np.arange(n)[:, None] * [1.0, 0.0, 0.0]])
    m = ros.from_poses(T, np.stack([C6] * n), stamps=np.arange(n) + 1.0, frame_id=frames)
    return ros.write_messages(tmp_path / "a.bag", "/odom", m)


def test_write_marginals_empty_out_topic_refused_before_writing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = _bag(tmp_path, ["map"] * 4)
    out = tmp_path / "out.bag"
    rc, _, err = _cli(
        ["bag", "write-marginals", str(bag), str(out), "--topic", "/odom", "--out-topic", ""],
        capsys,
    )
    assert rc == 2 and "--out-topic: '' is not a ROS topic name" in err and not out.exists()
    with pytest.raises(ValueError, match="topic: 'a b' is not a ROS topic name"):
        ros.write_messages(out, "a b", ros.read_messages(bag, "/odom"))


def test_transform_messages_empty_frame_id_refused(tmp_path: Path) -> None:
    m = ros.read_messages(_bag(tmp_path, ["map"] * 3), "/odom")
    with pytest.raises(ValueError, match="new_frame_id: frame name must be non-empty"):
        ros.transform_messages(m, np.eye(4), "")


def test_topic_whose_frame_id_alternates_is_not_one_trajectory(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = _bag(tmp_path, ["map", "odom", "map", "odom"])
    rc, _, err = _cli(
        ["bag", "export", str(bag), "--topic", "/odom", "--to", "tum", str(tmp_path / "o.tum")],
        capsys,
    )
    assert rc == 2 and "frame_id 'odom' differs from the first message's 'map'" in err
    m = ros.read_messages(bag, "/odom")
    with pytest.raises(ValueError, match="message 1: frame_id 'odom'"):
        ros.increment_covariances(m)
    tum = tmp_path / "r.tum"
    tum.write_text("\n".join(f"{k + 1.0} {k} 0 0 0 0 0 1" for k in range(4)) + "\n")
    rc, _, err = _cli(["traj", "ape", str(bag), str(tum), "--ref-topic", "/odom"], capsys)
    assert rc == 2 and "differs from the first message's" in err


@pytest.mark.parametrize("stamp", [1e300, 9.3e9, -3e9])
def test_from_poses_stamps_a_ros_time_cannot_hold_refused(stamp: float) -> None:
    with pytest.raises(ValueError, match=r"stamps: stamp 1 .* outside the seconds a ROS time"):
        ros.from_poses(np.stack([np.eye(4)] * 2), stamps=[0.0, stamp])


@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("--prior-sigma", "0"),
        ("--prior-sigma", "nan"),
        ("--prior-sigma", "inf"),
        ("--period", "-1"),
        ("--period", "nan"),
        ("--period", "inf"),
        ("--period", "1e300"),
    ],
)
def test_write_marginals_bad_sigma_or_period_is_one_clear_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], option: str, value: str
) -> None:
    g = tmp_path / "g.g2o"
    g.write_text(
        "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 1 0 0 0 0 0 1\n"
        "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\n"
    )
    rc, _, err = _cli(
        ["bag", "write-marginals", str(g), str(tmp_path / "o.bag"), option, value], capsys
    )
    assert rc == 2 and option in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize(
    "text",
    ["", "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 1 0 0 0 0 0 1\n"],
    ids=["empty", "two_parts"],
)
def test_write_marginals_empty_or_split_graph_is_one_clear_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str
) -> None:
    g = tmp_path / "g.g2o"
    g.write_text(text)
    rc, _, err = _cli(["bag", "write-marginals", str(g), str(tmp_path / "o.bag")], capsys)
    assert rc == 2 and len(err.strip().splitlines()) == 1


def test_bag_export_g2o_all_zero_covariances_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    n = 4
    T = se3.exp(np.c_[np.zeros((n, 3)), np.arange(n)[:, None] * [1.0, 0.0, 0.0]])
    m = ros.from_poses(T, np.zeros((n, 6, 6)), stamps=np.arange(n) + 1.0)
    bag = ros.write_messages(tmp_path / "z.bag", "/p", m)
    rc, _, err = _cli(
        ["bag", "export", str(bag), "--topic", "/p", "--to", "g2o", str(tmp_path / "o.g2o")],
        capsys,
    )
    assert rc == 2 and "singular" in err and "Singular matrix" not in err


# ============================================================================ crash and hang
def test_isam2_relinearize_skip_zero_refused_not_sigfpe() -> None:
    """GTSAM divides by relinearizeSkip: 0 killed the process (run in a subprocess)."""
    code = textwrap.dedent(
        """
        import gtsam, liebridge.gtsam as F
        for skip in (0, -3):
            p = gtsam.ISAM2Params()
            p.relinearizeSkip = skip
            try:
                F.ISAM2(p)
            except ValueError as e:
                assert "relinearizeSkip" in str(e), e
            else:
                raise SystemExit("accepted")
        p = gtsam.ISAM2Params()
        p.setRelinearizeThreshold(float("nan"))
        try:
            F.ISAM2(p)
        except ValueError as e:
            assert "relinearizeThreshold" in str(e), e
        else:
            raise SystemExit("nan accepted")
        print("ok")
        """
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, (r.returncode, r.stderr)
    assert r.stdout.strip() == "ok"


def _bomb(levels: int) -> str:
    lines = ["a0: &a0 [0.0, 1.0]"]
    lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 9) + "]" for i in range(1, levels + 1)]
    return "\n".join([*lines, f"cam0:\n  T_cam_imu: *a{levels}"]) + "\n"


@pytest.mark.parametrize(
    ("text", "match"),
    [
        (_bomb(9), "aliases expand it by more than"),
        (
            "cam0: &c\n  T_cam_imu: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n  me: *c\n",
            "refers to its own anchor",
        ),
        (
            "cam0:\n"
            + "".join("  " * (k + 1) + f"k{k}:\n" for k in range(100))
            + "  " * 101
            + "1\n",
            "nested more than 64 levels",
        ),
        ("[" * 100_000 + "]" * 100_000, "not valid YAML|nested"),
        ('{"a": ' + "[" * 100_000 + "]" * 100_000 + "}", "JSON nested too deep"),
    ],
    ids=["alias_bomb", "self_anchor", "deep_block", "deep_flow", "deep_json"],
)
def test_calibration_yaml_alias_bomb_and_depth_refused_quickly(
    tmp_path: Path, text: str, match: str
) -> None:
    f = tmp_path / "camchain.yaml"
    f.write_text(text)
    for read in (
        calib.read_kalibr,
        calib.read_extrinsic,
        calib.read_timeshift,
        calib.detect_file_system,
    ):
        t0 = time.perf_counter()
        with pytest.raises(ValueError, match=match):
            read(f)
        assert time.perf_counter() - t0 < 5.0


def test_calibration_yaml_shared_anchor_still_read(tmp_path: Path) -> None:
    """A few aliases (a shared block) are fine: only an expansion beyond the limit is refused."""
    f = tmp_path / "camchain.yaml"
    f.write_text(
        "cam0:\n  T_cam_imu: &T [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\ncam1:\n  T_cam_imu: *T\n"
    )
    chain = calib.read_kalibr(f)
    np.testing.assert_array_equal(chain.camera("cam1").T_cam_imu.T, np.eye(4))


def test_write_kalibr_self_referential_or_bomb_fields_refused_quickly(tmp_path: Path) -> None:
    me: dict[str, Any] = {"a": 1}
    me["me"] = me
    bomb: list[Any] = [1.0, 2.0]
    for _ in range(12):
        bomb = [bomb] * 9
    for fields, match in ((me, "holds itself"), (bomb, "shared sub-objects expand it")):
        cam = calib.KalibrCamera("cam0", Transform(np.eye(4), "cam0", "imu0"), fields={"x": fields})
        t0 = time.perf_counter()
        with pytest.raises(ValueError, match=match):
            calib.write_kalibr(tmp_path / "o.yaml", calib.KalibrCamchain((cam,)))
        assert time.perf_counter() - t0 < 5.0
    shared = [1.0, 2.0]
    cam = calib.KalibrCamera(
        "cam0", Transform(np.eye(4), "cam0", "imu0"), fields={"x": [shared, shared]}
    )
    calib.write_kalibr(tmp_path / "o.yaml", calib.KalibrCamchain((cam,)))
    assert calib.read_kalibr(tmp_path / "o.yaml").camera("cam0").fields["x"] == [shared, shared]


# ================================================================================ valid input
@pytest.mark.parametrize("s", [1e-110, 1e-300, 1e103, 1e300])
def test_sim3_log_of_scales_whose_determinant_under_or_overflows(s: float) -> None:
    X = np.eye(4)
    X[:3, :3] = s * so3.exp(np.array([0.1, -0.2, 0.3]))
    X[:3, 3] = [1.0, 2.0, 3.0]
    xi = sim3.log(X)
    assert xi[6] == pytest.approx(np.log(s), rel=1e-14)
    np.testing.assert_allclose(xi[:3], [0.1, -0.2, 0.3], rtol=1e-12)
    np.testing.assert_allclose(sim3.exp(xi), X, rtol=1e-12, atol=1e-12 * max(s, 1.0))


def test_sim3_exp_log_scale_below_normal_range_refused_not_zero_matrix() -> None:
    with pytest.raises(ValueError, match=r"log-scale λ = -800 .* underflows"):
        sim3.exp(np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -800.0]))


def test_kalibr_rigid_transform_printed_with_4_decimals_read(tmp_path: Path) -> None:
    R = so3.exp(np.array([0.3, -0.2, 0.1]))
    rows = [[*R[i], [0.1, 0.2, 0.3][i]] for i in range(3)] + [[0, 0, 0, 1]]
    text = "cam0:\n  T_cam_imu:\n" + "".join(
        "  - [" + ", ".join(f"{x:.4f}" for x in r) + "]\n" for r in rows
    )
    f = tmp_path / "camchain-imucam.yaml"
    f.write_text(text)
    T = calib.read_kalibr(f).camera("cam0").T_cam_imu
    np.testing.assert_allclose(T.R, R, atol=6e-5)
    np.testing.assert_allclose(calib.read_extrinsic(f).T, T.T)
    f.write_text(text.replace(f"{R[0, 0]:.4f}", f"{R[0, 0] + 0.01:.4f}", 1))
    with pytest.raises(ValueError, match=f"{f}: cam0.T_cam_imu"):
        calib.read_kalibr(f)


def test_fuse_with_a_zero_covariance_returns_that_estimate() -> None:
    """B exact: the posterior is B with covariance 0 (rounding negatives reached the check)."""
    A = UncertainPose(X5[0], C6, "gtsam")
    Tb = X5[0] @ se3.exp(np.array([0.0, 0.0, 0.01, 0.02, 0.0, 0.0]))
    out = fuse(A, UncertainPose(Tb, np.zeros((6, 6)), "gtsam"))
    np.testing.assert_allclose(out.T, Tb, atol=1e-12)
    assert np.abs(out.cov).max() < 1e-15


# ========================================================== finite output, or an error saying why
MAGNITUDE = st.sampled_from([0.0, 1e-316, 1e-300, 1e-12, 1.0, 1e12, 1e150, 1e200, 1e300, 1.7e308])


@given(MAGNITUDE, MAGNITUDE, st.sampled_from(["trans_part", "full", "angle_deg", "rot_part"]))
def test_traj_metrics_finite_or_say_why(a: float, b: float, rel: str) -> None:
    T, E = np.tile(np.eye(4), (3, 1, 1)), np.tile(np.eye(4), (3, 1, 1))
    T[:, :3, 3], E[:, :3, 3] = -a, b
    for f in (lambda: traj.ape(T, E, rel), lambda: traj.rpe(T, E, 1, "frames", rel)[0]):
        try:
            err = f()
        except ValueError as exc:
            assert "overflows float64" in str(exc)
            continue
        assert np.isfinite(err).all()
        try:
            s = traj.statistics(err)
        except ValueError as exc:
            assert "overflows float64" in str(exc)
            continue
        assert all(np.isfinite(v) for v in s.as_dict().values())


@given(MAGNITUDE.filter(lambda v: v > 0), st.sampled_from([1e-3, 1.0, 1e3]))
def test_nees_finite_or_say_why(cov_scale: float, err: float) -> None:
    X = se3.exp(np.zeros((2, 6)))
    Y = se3.exp(np.full((2, 6), err * 1e-3))
    try:
        r = traj.nees(X, Y, np.stack([np.eye(6) * cov_scale] * 2), "gtsam")
    except ValueError as exc:
        assert "overflows float64" in str(exc) or "positive definite" in str(exc)
        return
    assert np.isfinite(r.nees).all() and np.isfinite(r.anees)


@given(st.sampled_from([1e-300, 1e-100, 1e-5, 1.0, 1e5, 1e100, 1e300]))
def test_sim3_round_trip_finite_or_say_why(s: float) -> None:
    X = np.eye(4)
    X[:3, :3] = s * so3.exp(np.array([0.4, 0.1, -0.7]))
    xi = sim3.log(X)
    assert np.isfinite(xi).all()
    try:
        Y = sim3.exp(xi)
    except ValueError as exc:
        assert "overflows" in str(exc) or "underflows" in str(exc)
        return
    assert np.isfinite(Y).all()


def test_extrinsics_convert_of_a_4_decimal_kalibr_file_is_one_json_object(
    tmp_path: Path, capsys: Any
) -> None:
    """extrinsics convert --format json stays one JSON object with a 4-decimal Kalibr file."""
    f = tmp_path / "camchain-imucam.yaml"
    R = so3.exp(np.array([0.3, -0.2, 0.1]))
    f.write_text(
        "cam0:\n  T_cam_imu:\n"
        + "".join("  - [" + ", ".join(f"{x:.4f}" for x in [*R[i], 0.1]) + "]\n" for i in range(3))
        + "  - [0, 0, 0, 1]\n"
    )
    rc, out, _ = _cli(
        ["extrinsics", "convert", str(f), "--to-system", "okvis", "--format", "json"], capsys
    )
    assert rc == 0 and json.loads(out)["system"] == "okvis"


# ======================================================== tracebacks and unclear errors, as lines
def _kalibr(tmp_path: Path, shift: str) -> Path:
    f = tmp_path / "camchain-imucam.yaml"
    f.write_text(
        "cam0:\n  T_cam_imu: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n"
        f"  timeshift_cam_imu: {shift}\n"
    )
    return f


@pytest.mark.parametrize(
    ("shift", "match"),
    [("1" + "0" * 400, "is beyond float64"), ("1.0e+300", "beyond ±9.2e\\+09 s")],
    ids=["one_and_400_zeros", "1e300"],
)
def test_kalibr_timeshift_beyond_float64_or_int64_ns_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], shift: str, match: str
) -> None:
    f = _kalibr(tmp_path, shift)
    with pytest.raises(ValueError, match=f"cam0.timeshift_cam_imu: .*{match}"):
        calib.read_kalibr(f)
    with pytest.raises(ValueError, match=match):
        calib.read_timeshift(f)
    rc, _, err = _cli(["extrinsics", "convert", str(f), "--to-system", "basalt"], capsys)
    assert rc == 2 and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("system", ["okvis", "orbslam3"])
def test_extrinsics_convert_from_the_wrong_system_names_the_missing_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], system: str
) -> None:
    f = _kalibr(tmp_path, "0.01")
    rc, _, err = _cli(
        ["extrinsics", "convert", str(f), "--from-system", system, "--to-system", "kalibr"], capsys
    )
    assert rc == 2 and f"expected in a {system} file" in err and "KeyError" not in err


def test_optimize_none_graph_is_a_type_error_naming_it() -> None:
    with pytest.raises(
        TypeError, match=r"graph: expected gtsam.NonlinearFactorGraph, got NoneType"
    ):
        F.optimize(None, gtsam.Values())
    with pytest.raises(TypeError, match=r"values: expected gtsam.Values, got list"):
        F.optimize(gtsam.NonlinearFactorGraph(), [])


def test_axes_with_a_list_field_is_a_type_error_naming_it() -> None:
    from liebridge.frames import Axes

    with pytest.raises(TypeError, match=r"Axes.x: expected a str, got list"):
        Axes("enu", "world", ["east"], "north", "up")  # type: ignore[arg-type]


def test_kitti_segments_non_integer_step_refused() -> None:
    T = se3.exp(np.c_[np.zeros((30, 3)), np.arange(30.0)[:, None] * [10.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match=r"step: expected an integer ≥ 1, got 2.5"):
        traj.kitti_segment_errors(T, T, step=2.5)  # type: ignore[arg-type]


@pytest.mark.parametrize("ratio", [float("nan"), 0.5, float("inf")])
def test_twist_frame_check_ratio_outside_its_range_refused(tmp_path: Path, ratio: float) -> None:
    n = 4
    T = se3.exp(np.c_[np.zeros((n, 3)), np.arange(n)[:, None] * [1.0, 0.0, 0.0]])
    m = ros.from_poses(T, stamps=np.arange(n) + 1.0, msgtype="nav_msgs/msg/Odometry")
    with pytest.raises(ValueError, match="ratio: expected a finite number ≥ 1"):
        ros.twist_frame_check(m, ratio=ratio)


@pytest.mark.parametrize("align", ["se3", "sim3", "4dof", "none"])
@pytest.mark.parametrize("order", ["big_ref", "big_est"])
def test_traj_cli_on_1e300_poses_is_one_line_without_numpy_warnings(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], align: str, order: str
) -> None:
    rng = np.random.default_rng(3)
    big, small = tmp_path / "big.tum", tmp_path / "small.tum"
    big.write_text(
        "".join(
            f"{k} {' '.join(map(repr, (1e300 * rng.random(3)).tolist()))} 0 0 0 1\n"
            for k in range(1, 8)
        )
    )
    small.write_text(
        "".join(f"{k} {' '.join(map(repr, rng.random(3).tolist()))} 0 0 0 1\n" for k in range(1, 8))
    )
    ref, est = (big, small) if order == "big_ref" else (small, big)
    with np.errstate(over="warn", divide="warn", invalid="warn"), _no_warning():  # numpy default
        rc, _, err = _cli(["traj", "ape", str(ref), str(est), "--align", align], capsys)
    assert len(err.strip().splitlines()) <= 1, err
    assert rc in (0, 2) and ("RuntimeWarning" not in err)


class _no_warning:
    """Fail on any warning raised inside the block (numpy's RuntimeWarning included)."""

    def __enter__(self) -> None:
        import warnings

        self._ctx = warnings.catch_warnings()
        self._ctx.__enter__()
        warnings.simplefilter("error")

    def __exit__(self, *exc: object) -> None:
        self._ctx.__exit__(*exc)


# ===================================================================================== scale
@pytest.mark.parametrize("op", ["compose", "relative", "inverse", "transform", "act"])
def test_unscented_uncertain_ops_chunked_equal_unchunked(
    monkeypatch: pytest.MonkeyPatch, op: str
) -> None:
    """The unscented compose (and its siblings) runs in chunks; the results do not change."""
    from liebridge.uncertain import ops

    rng = np.random.default_rng(5)
    A = UncertainPose(se3.exp(rng.normal(size=(7, 6)) * 0.3), C6, "ros")
    B = UncertainPose(se3.exp(rng.normal(size=(7, 6)) * 0.3), C6 * 2.0, "ros")
    run = {
        "compose": lambda: ops.compose(A, B, method="unscented"),
        "relative": lambda: ops.relative(A, B, method="unscented"),
        "inverse": lambda: ops.inverse(A, method="unscented"),
        "transform": lambda: ops.transform(A, B.T, "right", method="unscented"),
        "act": lambda: ops.act(A, np.ones(3), 0.01 * np.eye(3), method="unscented"),
    }[op]
    whole = run()
    monkeypatch.setattr(ops, "UNSCENTED_BYTES", 1)  # one element per pass
    parts = run()
    np.testing.assert_allclose(parts.cov, whole.cov, rtol=1e-12, atol=1e-15)


def test_unscented_compose_memory_does_not_grow_with_the_batch() -> None:
    import tracemalloc

    from liebridge.uncertain import ops

    peaks = []
    for n in (400, 1600):
        X = se3.exp(np.random.default_rng(n).normal(size=(n, 6)) * 0.3)
        A, B = UncertainPose(X, C6, "gtsam"), UncertainPose(X, C6, "gtsam")
        chunk_bytes, ops.UNSCENTED_BYTES = ops.UNSCENTED_BYTES, 2**20
        try:
            tracemalloc.start()
            ops.compose(A, B, method="unscented")
            peaks.append(tracemalloc.get_traced_memory()[1])
        finally:
            tracemalloc.stop()
            ops.UNSCENTED_BYTES = chunk_bytes
    per_element_io = 2000 * 8  # inputs, output and their copies: O(batch), ≈ 1 kB each
    assert peaks[1] < peaks[0] + 1200 * per_element_io  # not 4× the sigma points


def test_extrinsics_convert_parses_a_large_kalibr_file_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``extrinsics convert`` parsed FILE four times (detect, extrinsic, Kalibr chain, shift)."""
    f = _kalibr(tmp_path, "0.01")
    f.write_text(f.read_text() + "  lut:\n" + "  - [0.5, 0.25]\n" * 2000)
    calls: list[str] = []
    real = calib._load_text
    monkeypatch.setattr(
        calib, "_load_text", lambda text, path: calls.append(str(path)) or real(text, path)
    )
    rc, out, _ = _cli(["extrinsics", "convert", str(f), "--to-system", "okvis"], capsys)
    assert rc == 0 and "time offset: t_imu = t_cam + 0.01 s" in out
    assert calls == [str(f)]
    parsed = calib.CalibrationFile.read(f)
    assert len(calls) == 2 and parsed.system == "kalibr"
    np.testing.assert_array_equal(calib.read_extrinsic(parsed).T, np.eye(4))
    assert (
        calib.read_timeshift(parsed) == 0.01 and calib.read_kalibr(parsed).cameras[0].name == "cam0"
    )
    assert len(calls) == 2


def _odometry_bag(tmp_path: Path, n: int, frames: list[str] | None = None) -> Path:
    rng = np.random.default_rng(n)
    T = se3.exp(rng.normal(size=(n, 6)))
    A = rng.normal(size=(n, 6, 6)) * 0.1
    m = ros.from_poses(
        T,
        A @ np.swapaxes(A, -1, -2) + 0.01 * np.eye(6),
        stamps=np.arange(n) * 0.1 + 1.0,
        msgtype="nav_msgs/msg/Odometry",
        frame_id=frames or "odom",
        twist=rng.normal(size=(n, 6)),
    )
    return ros.write_messages(tmp_path / "od.bag", "/odom", m)


@pytest.mark.parametrize("batch", [1, 3, 7, 100])
def test_streamed_bag_batches_equal_the_whole_read(tmp_path: Path, batch: int) -> None:
    bag = _odometry_bag(tmp_path, 10)
    whole = ros.read_messages(bag, "/odom")
    parts = list(ros.iter_messages(bag, "/odom", batch=batch))
    assert [len(p) for p in parts] == [min(batch, 10 - k) for k in range(0, 10, batch)]
    for name in ("stamps", "position", "orientation_xyzw", "pose_covariance", "twist_covariance"):
        np.testing.assert_array_equal(
            np.concatenate([getattr(p, name) for p in parts]), getattr(whole, name)
        )
    assert sum((p.frame_id for p in parts), ()) == whole.frame_id


def test_read_messages_in_batches_equals_one_batch(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from liebridge.ros import bag as bag_module

    bag = _odometry_bag(tmp_path, 10)
    one = ros.read_messages(bag, "/odom")
    monkeypatch.setattr(bag_module, "BATCH_MESSAGES", 3)
    many = ros.read_messages(bag, "/odom")
    for name in (
        "stamp_sec",
        "stamp_nanosec",
        "message_index",
        "log_time_ns",
        "pose_covariance",
        "twist_linear_angular",
        "twist_covariance",
        "position",
        "orientation_xyzw",
    ):
        np.testing.assert_array_equal(getattr(many, name), getattr(one, name))
    assert many.frame_id == one.frame_id and many.child_frame_id == one.child_frame_id


def test_bag_export_tum_streams_and_checks_frames_across_batches(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from liebridge.ros import bag as bag_module

    monkeypatch.setattr(bag_module, "BATCH_MESSAGES", 4)
    bag = _odometry_bag(tmp_path, 10)
    out = tmp_path / "o.tum"
    rc, stdout, _ = _cli(
        ["bag", "export", str(bag), "--topic", "/odom", "--to", "tum", str(out)], capsys
    )
    assert rc == 0 and "10 poses T_odom_base_link" in stdout
    ros.write_tum(tmp_path / "ref.tum", ros.read_messages(bag, "/odom"))
    assert out.read_text() == (tmp_path / "ref.tum").read_text()
    (tmp_path / "two").mkdir()
    bag2 = _odometry_bag(tmp_path / "two", 10, ["odom"] * 5 + ["map"] * 5)
    out2 = tmp_path / "o2.tum"
    rc, _, err = _cli(
        ["bag", "export", str(bag2), "--topic", "/odom", "--to", "tum", str(out2)], capsys
    )
    assert rc == 2 and "not one trajectory" in err and not out2.exists()
    tum = tmp_path / "r.tum"
    tum.write_text("\n".join(f"{1.0 + 0.1 * k} {k} 0 0 0 0 0 1" for k in range(10)) + "\n")
    rc, _, err = _cli(["traj", "ape", str(bag2), str(tum), "--ref-topic", "/odom"], capsys)
    assert rc == 2 and "not one trajectory" in err


def test_transform_with_more_covariances_than_poses_is_named() -> None:
    """Three covariances for one pose: numpy's axis text before; a sentence naming both now."""
    with pytest.raises(ValueError, match=r"batch shape \(3,\) has more covariances than T's"):
        Transform(np.eye(4), "a", "b", np.stack([C6] * 3))
    tf = Transform(np.stack([np.eye(4)] * 3), "a", "b", C6)  # one for three broadcasts
    assert tf.cov is not None and tf.cov.shape == (3, 6, 6)


def test_iter_messages_refuses_bad_arguments_at_the_call(tmp_path: Path) -> None:
    bag = _odometry_bag(tmp_path, 3)
    with pytest.raises(ValueError, match="batch: expected a positive int, got 0"):
        ros.iter_messages(bag, "/odom", batch=0)
    with pytest.raises(ValueError, match="convention"):
        ros.iter_messages(bag, "/odom", convention="no_such_convention")


@pytest.mark.parametrize("op", ["compose", "inverse", "relative", "act"])
def test_uncertain_op_overflow_names_the_operation_not_the_input(op: str) -> None:
    """Translations 1e200: "cov contains NaN or Inf" (as if the input were bad) and warnings."""
    import warnings

    from liebridge.uncertain import ops

    X = np.eye(4)
    X[:3, 3] = 1e200
    A = UncertainPose(X, np.eye(6), "ros")
    run = {
        "compose": lambda: ops.compose(A, A),
        "inverse": lambda: ops.inverse(A, method="unscented"),
        "relative": lambda: ops.relative(A, UncertainPose(-X + 2 * np.eye(4), np.eye(6), "ros")),
        "act": lambda: ops.act(A, np.full(3, 1e200)),
    }[op]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=rf"^{op}: .*overflows float64"):
            run()


def test_nees_of_poses_too_far_apart_names_them() -> None:
    X = np.tile(np.eye(4), (2, 1, 1))
    Y = X.copy()
    X[:, :3, 3], Y[:, :3, 3] = 1e300, -1e300
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=r"the NEES at pose 0 overflows .*component 2e\+300"):
            traj.nees(X, Y, np.stack([np.eye(6)] * 2), "gtsam")
        X[:, :3, 3], Y[:, :3, 3] = 1.7e308, -1.7e308
        with pytest.raises(ValueError, match=r"T_ref, T_est: the error .* at pose 0 overflows"):
            traj.nees(X, Y, np.stack([np.eye(6)] * 2), "gtsam")


def test_ros_messages_keeps_copying_the_callers_arrays(tmp_path: Path) -> None:
    """The reader's no-copy path is its own: a caller's arrays are copied, never frozen."""
    n = 3
    pos, q = np.zeros((n, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    m = ros.RosMessages(
        msgtype="geometry_msgs/msg/PoseWithCovarianceStamped",
        stamp_sec=np.arange(n),
        stamp_nanosec=np.zeros(n, dtype=np.int64),
        frame_id=("map",) * n,
        position=pos,
        orientation_xyzw=q,
        pose_covariance=np.tile(np.eye(6).ravel(), (n, 1)),
    )
    assert pos.flags.writeable and q.flags.writeable and m.position is not pos
    pos[0, 0] = 5.0
    assert m.position[0, 0] == 0.0
    read = ros.read_messages(_odometry_bag(tmp_path, 4), "/odom")
    assert not read.position.flags.writeable and not read.cov.flags.writeable


@given(
    MAGNITUDE,
    st.sampled_from([1e-12, 1.0, 1e6]),
    st.sampled_from(["gtsam", "ros", "barfoot", "sophus"]),
    st.sampled_from(
        ["compose", "inverse", "relative", "act", "convert_linear", "convert_unscented"]
    ),
)
def test_covariance_operations_finite_or_say_why(t: float, s: float, conv: str, op: str) -> None:
    """Finite input: a finite result or a ValueError, never inf/NaN and never a numpy warning."""
    import warnings

    from liebridge.uncertain import ops

    X = se3.exp(np.array([0.3, -0.2, 0.1, 0.0, 0.0, 0.0]))
    X[:3, 3] = [t, -t, 0.5 * t]
    C = np.diag([1e-2, 2e-2, 3e-2, 1.0, 2.0, 3.0]) * s
    A = UncertainPose(X, C, conv)
    run = {
        "compose": lambda: ops.compose(A, A).cov,
        "inverse": lambda: ops.inverse(A).cov,
        "relative": lambda: ops.relative(A, A).cov,
        "act": lambda: ops.act(A, np.array([t, 1.0, -t])).cov,
        "convert_linear": lambda: lb.convert_covariance(C, X, conv, "gtsam"),
        "convert_unscented": lambda: lb.convert_covariance(C, X, conv, "gtsam", method="unscented"),
    }[op]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            out = run()
        except ValueError:
            return
    assert np.isfinite(out).all()
