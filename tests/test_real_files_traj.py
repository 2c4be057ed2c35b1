"""Trajectory files as the field writes them: quaternion order per file, imperfect real files.

The files are written here in the dialects of real ones (none is copied):

* TUM RGB-D ground truth (``fr2/desk``): three comment lines, the column names on the third,
  4-decimal numbers (quaternions off unit by up to ~1e-4), a repeated stamp whose pose moved on;
* evo's EuRoC estimate (``V102.txt``): numpy's ``%.18e`` of 5-decimal numbers (off unit by up
  to ~8e-6, more than the printed digits explain), 4 stamps repeated;
* EuRoC ground truth csv: integer nanoseconds, 17 columns, quaternions off unit by ~1.5e-4;
* w-first estimates without a header (Eigen's ``w x y z`` printed as is).

The order check is exercised on planar, 3-D, slow, fast and noisy trajectories: it never names
the wrong order, and it says how sure it is.
"""

from __future__ import annotations

import json
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from liebridge.cli import main
from liebridge.io import read_tum, sanity, trajfile
from liebridge.io.euroc import read_euroc

ROOT = Path(__file__).resolve().parents[1]


# --- trajectories --------------------------------------------------------------------------


def _along(v: np.ndarray, bank: float = 0.0) -> np.ndarray:
    """Body x along the velocity, z up, rolled by ``bank``: a vehicle's attitude."""
    f = v / np.linalg.norm(v, axis=1, keepdims=True)
    left = np.cross([0.0, 0.0, 1.0], f)
    left /= np.linalg.norm(left, axis=1, keepdims=True)
    R = np.stack([f, left, np.cross(f, left)], axis=-1)
    return R @ Rotation.from_rotvec([bank, 0.0, 0.0]).as_matrix()


def motion(kind: str, n: int = 600, noise: float = 0.0, seed: int = 0):
    """``(p (n, 3), q_xyzw (n, 4))`` of a named motion; ``noise`` in m and rad per sample."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 1.0, n)
    th = 2 * np.pi * s
    z = np.zeros(n)
    if kind == "car_circle_cw":  # planar, a camera pitched 3° on a car turning clockwise
        p = 5 * np.column_stack([np.cos(-th), np.sin(-th), z])
        R = _along(np.gradient(p, axis=0)) @ Rotation.from_rotvec([0, 0.05, 0]).as_matrix()
    elif kind == "car_circle_ccw":
        p = 5 * np.column_stack([np.cos(th), np.sin(th), z])
        R = _along(np.gradient(p, axis=0))
    elif kind == "figure8":
        p = np.column_stack([10 * np.sin(th), 5 * np.sin(2 * th), z])
        R = _along(np.gradient(p, axis=0))
    elif kind == "helix_banked":  # 3-D: climbing, banked into the turn
        p = np.column_stack([3 * np.cos(2 * th), 3 * np.sin(2 * th), 6 * s])
        R = _along(np.gradient(p, axis=0), bank=0.3)
    elif kind == "drone":  # 3-D: yaw along the path, pitched forward, rolling
        p = np.column_stack([8 * np.cos(th) + 2 * np.sin(3 * th), 6 * np.sin(th), 1.5 + z])
        v = np.gradient(p, axis=0)
        yaw = np.unwrap(np.arctan2(v[:, 1], v[:, 0]))
        ypr = np.column_stack([yaw, 0.2 + z, 0.1 * np.sin(5 * th)])
        R = Rotation.from_euler("ZYX", ypr).as_matrix()
    elif kind == "camera_orbit":  # a camera circling a desk, looking at it, moving sideways
        a = 0.75 * th
        p = np.column_stack([2 * np.cos(a), 2 * np.sin(a), 1.2 + 0.1 * np.sin(3 * a)])
        look = np.array([0.0, 0.0, 0.5]) - p
        look /= np.linalg.norm(look, axis=1, keepdims=True)
        right = np.cross(look, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right, axis=1, keepdims=True)
        R = np.stack([right, np.cross(look, right), look], axis=-1)
    elif kind == "handheld":  # turned every way, moved every way
        R = Rotation.from_rotvec(np.cumsum(rng.normal(0, 0.03, (n, 3)), axis=0)).as_matrix()
        p = np.cumsum(np.cumsum(rng.normal(0, 0.002, (n, 3)), axis=0), axis=0)
    elif kind == "turn_in_place":
        R = Rotation.from_euler("z", -th[:, None]).as_matrix()
        R = R @ Rotation.from_rotvec([0, 0.05, 0]).as_matrix()
        p = np.zeros((n, 3))
    else:
        raise KeyError(kind)
    if noise:
        p = p + rng.normal(0, noise, p.shape)
        R = R @ Rotation.from_rotvec(rng.normal(0, noise, (n, 3))).as_matrix()
    return p, Rotation.from_matrix(R).as_quat()


def poses(p: np.ndarray, q_xyzw: np.ndarray) -> np.ndarray:
    T = np.tile(np.eye(4), (len(p), 1, 1))
    T[:, :3, :3] = Rotation.from_quat(q_xyzw).as_matrix()
    T[:, :3, 3] = p
    return T


def _rows(t, p, q, fmt: str) -> str:
    return "".join(
        " ".join(
            [f"{ti:.4f}" if fmt == "tum_gt" else repr(float(ti))] + [fmt_v(v, fmt) for v in pi]
        )
        + "\n"
        for ti, pi in zip(t, np.column_stack([p, q]), strict=True)
    )


def fmt_v(v: float, fmt: str) -> str:
    return f"{v:.4f}" if fmt == "tum_gt" else repr(float(v))


def tum_ground_truth(path: Path, t, p, q_xyzw, repeat_at=()) -> Path:
    """TUM RGB-D ground truth dialect; each row in ``repeat_at`` gets the stamp before it."""
    t = np.array(t, dtype=float)
    for i in repeat_at:
        t[i] = t[i - 1]
    head = (
        "# ground truth trajectory\n# file: 'rgbd_dataset.bag'\n# timestamp tx ty tz qx qy qz qw\n"
    )
    path.write_text(head + _rows(t, p, q_xyzw, "tum_gt"))
    return path


def evo_estimate(path: Path, t, p, q_xyzw, repeat_at=()) -> Path:
    """evo's ``V102.txt`` dialect: ``%.18e`` (numpy.savetxt) of numbers rounded to 5 decimals."""
    t = np.array(t, dtype=float)
    for i in repeat_at:
        t[i] = t[i - 1]
    np.savetxt(path, np.column_stack([t, np.round(p, 5), np.round(q_xyzw, 5)]))
    return path


EUROC_HEAD = (
    "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], "
    "q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], "
    "b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], "
    "b_a_RS_S_z [m s^-2]\n"
)


def euroc_ground_truth(path: Path, t, p, q_xyzw, off_unit=1.5e-4, repeat_at=(), seed=0) -> Path:
    """EuRoC ``data.csv`` dialect: ns stamps, 6 decimals, quaternions off unit by ``≤ off_unit``."""
    rng = np.random.default_rng(seed)
    ns = np.round(np.asarray(t) * 1e9).astype(np.int64)
    for i in repeat_at:
        ns[i] = ns[i - 1]
    q = q_xyzw[:, [3, 0, 1, 2]] * (1 + off_unit * rng.uniform(-1, 1, (len(t), 1)))
    extra = rng.normal(0, 0.01, (len(t), 9))
    lines = [
        f"{n}," + ",".join(f"{v:.6f}" for v in row) + "\n"
        for n, row in zip(ns.tolist(), np.column_stack([p, q, extra]), strict=True)
    ]
    path.write_text(EUROC_HEAD + "".join(lines))
    return path


def w_first(path: Path, t, p, q_xyzw) -> Path:
    """A w-first estimate without a header (``t x y z qw qx qy qz``), full precision."""
    path.write_text(_rows(t, p, q_xyzw[:, [3, 0, 1, 2]], "full"))
    return path


def _cli(args):
    return subprocess.run(
        [sys.executable, "-m", "liebridge.cli", "traj", *args],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )


def _one_line_error(r) -> str:
    assert r.returncode == 2, r.stderr
    assert r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    return lines[0]


@pytest.fixture(scope="module")
def desk(tmp_path_factory):
    """A hand-held camera (3-D rotation): TUM ground truth and a noisy w-first estimate."""
    d = tmp_path_factory.mktemp("desk")
    p, q = motion("handheld", n=900, seed=3)
    t = 1311868163.8697 + np.arange(900) / 100.0
    gt = tum_ground_truth(d / "gt.txt", t, p, q)
    pe, qe = motion("handheld", n=900, seed=3, noise=0.002)
    est = w_first(d / "est_wxyz.txt", t[::3] + 0.002, pe[::3], qe[::3])
    return gt, est


# --- item 1: the quaternion order, per file ------------------------------------------------


def test_traj_per_file_quat_order_w_first_estimate_against_tum_ground_truth(desk):
    gt, est = desk
    common = ["ape", str(gt), str(est), "-r", "angle_deg", "--align", "se3", "--format", "json"]
    r = _cli([*common, "--est-quat-order", "wxyz"])
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["rmse"] < 1.0  # degrees: only the 0.002 rad noise
    # without it: the misreading shows in the numbers and is named on stderr, with the flag
    r = _cli(common)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["rmse"] > 60.0
    assert "disagree on the quaternion order" in r.stderr
    assert "--est-quat-order wxyz" in r.stderr and "strong evidence" in r.stderr


def test_traj_quat_order_flag_contradicting_header_is_an_error(desk, tmp_path):
    gt, est = desk
    # --quat-order sets both files: REF's header names xyzw, so it must not silently win
    line = _one_line_error(_cli(["ape", str(gt), str(est), "--quat-order", "wxyz"]))
    assert "REF" in line and "header names the quaternion columns qx qy qz qw" in line
    assert "--est-quat-order" in line
    line = _one_line_error(_cli(["ape", str(gt), str(est), "--ref-quat-order", "wxyz"]))
    assert "drop --ref-quat-order" in line
    # a flag that agrees with the header is fine
    r = _cli(["ape", str(gt), str(est), "--ref-quat-order", "xyzw", "--est-quat-order", "wxyz"])
    assert r.returncode == 0, r.stderr
    # EuRoC names w first in its header; KITTI has no quaternions
    p, q = motion("drone", n=200)
    t = 1403715524.0 + np.arange(200) * 0.05
    csv = euroc_ground_truth(tmp_path / "data.csv", t, p, q, off_unit=0.0)
    line = _one_line_error(_cli(["ape", str(csv), str(csv), "--ref-quat-order", "xyzw"]))
    assert "EuRoC" in line and "--ref-quat-order" in line
    kitti = tmp_path / "kitti.txt"
    trajfile.write_trajectory(kitti, t, poses(p, q), format="kitti")
    line = _one_line_error(_cli(["ape", str(kitti), str(kitti), "--est-quat-order", "wxyz"]))
    assert "--est-quat-order" in line and "KITTI" in line


def test_read_tum_header_order_wins_over_contradicting_quat_order(desk, tmp_path):
    gt, _ = desk  # its names are on the third comment line, as in the TUM ground truths
    with pytest.raises(sanity.QuaternionOrderConflictError, match=r"qx qy qz qw \(xyzw\)"):
        read_tum(gt, quat_order="wxyz")
    assert len(read_tum(gt, quat_order="xyzw")) == 900
    with pytest.raises(ValueError, match="header"):
        trajfile.read_trajectory(gt, quat_order="wxyz")
    p, q = motion("drone", n=50)
    t = 1403715524.0 + np.arange(50) * 0.1
    csv = euroc_ground_truth(tmp_path / "data.csv", t, p, q, off_unit=0.0)
    with pytest.raises(sanity.QuaternionOrderConflictError, match="EuRoC"):
        trajfile.read_trajectory(csv, quat_order="xyzw")


@pytest.mark.parametrize("kind", ["car_circle_cw", "car_circle_ccw", "turn_in_place"])
def test_order_check_no_false_alarm_on_planar_turn_written_by_write_tum(tmp_path, kind):
    p, q = motion(kind, n=200)
    path = tmp_path / "turn.txt"
    trajfile.write_trajectory(path, np.arange(200) * 0.1, poses(p, q))  # liebridge's write_tum
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_tum(path)
        data = np.loadtxt(path)
        r = sanity.check_quaternions(data[:, 4:], "xyzw", data[:, 0], positions=data[:, 1:4])
    assert r.suggested_order is None
    if kind != "turn_in_place":  # the translation confirms the order, strongly
        assert r.order_confidence == "strong" and r.order_evidence.likely_order == "xyzw"
    else:  # no translation: rotations alone cannot tell, and it says so
        assert r.order_evidence.confidence == "none"
        assert "translation" in r.order_evidence.reason


def test_order_check_detects_clean_w_first_file_read_as_xyzw(tmp_path):
    p, q = motion("car_circle_ccw", n=300)  # noiseless, w of both signs, no sign flips
    path = w_first(tmp_path / "wfirst.txt", np.arange(300) * 0.1, p, q)
    with pytest.warns(sanity.QuaternionOrderWarning, match=r"likely 'wxyz'.*strong evidence"):
        read_tum(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        T = read_tum(path, quat_order="wxyz").T
    np.testing.assert_allclose(T, poses(p, q), atol=1e-12)


DECIDABLE = ["car_circle_cw", "car_circle_ccw", "figure8", "helix_banked", "drone", "camera_orbit"]


@pytest.mark.parametrize("kind", [*DECIDABLE, "handheld", "turn_in_place"])
@pytest.mark.parametrize("n", [60, 3000], ids=["fast", "slow"])
@pytest.mark.parametrize("noise", [0.0, 0.01])
def test_order_check_on_several_trajectories(kind, n, noise):
    p, q = motion(kind, n=n, noise=noise, seed=n)
    t = np.arange(n) * 0.05
    for stored, truth in ((q, "xyzw"), (q[:, [3, 0, 1, 2]], "wxyz")):
        wrong = "wxyz" if truth == "xyzw" else "xyzw"
        right = sanity.check_quaternions(stored, truth, t, positions=p, warn=False)
        assert right.suggested_order is None, right.messages  # never a false alarm
        misread = sanity.check_quaternions(stored, wrong, t, positions=p, warn=False)
        if kind in DECIDABLE:
            assert misread.suggested_order == truth, misread.order_evidence
            assert misread.order_confidence in ("strong", "moderate")
        else:  # cannot tell from the translation: no guess at all
            assert misread.suggested_order is None
            assert misread.order_evidence.confidence == "none"


@pytest.mark.parametrize("noise", [0.0, 0.01])
def test_relative_order_check_decides_hand_held_motion(noise):
    """REF's rotations decide what EST's alone cannot: body increments are conjugate."""
    _, q = motion("handheld", n=600, seed=5)
    R = Rotation.from_quat(q).as_matrix()
    W, B = Rotation.from_rotvec([[0.3, -1.0, 2.0], [1.0, 0.2, -0.5]]).as_matrix()
    rng = np.random.default_rng(1)
    E = W @ R @ B @ Rotation.from_rotvec(rng.normal(0, noise, (600, 3))).as_matrix()
    ok = sanity.relative_order_evidence(R, E, "xyzw")
    assert ok.likely_order == "xyzw" and ok.confidence != "none"
    bad = sanity.relative_order_evidence(R, sanity.other_reading(E, "xyzw"), "wxyz")
    assert bad.likely_order == "xyzw" and bad.confidence != "none"
    # a planar turn cannot be decided this way (world and body increments share the axis)
    _, q = motion("car_circle_ccw", n=300)
    R = Rotation.from_quat(q).as_matrix()
    assert sanity.relative_order_evidence(
        R, sanity.other_reading(R, "xyzw"), "wxyz"
    ).confidence == ("none")


# --- item 5: imperfect real files ----------------------------------------------------------


@pytest.fixture(scope="module")
def fr2(tmp_path_factory):
    """TUM fr2/desk style ground truth at 100 Hz: row 121 repeats 120's stamp (its pose moved on),
    rows 700 and 701 repeat 699's."""
    d = tmp_path_factory.mktemp("fr2")
    p, q = motion("camera_orbit", n=1500)
    t = 1311868163.8697 + np.arange(1500) / 100.0
    return tum_ground_truth(d / "groundtruth.txt", t, p, q, repeat_at=(121, 700, 701)), t, p, q


def test_real_files_repeated_stamps_tum_ground_truth_keeps_first_with_count(fr2):
    path, _, p, _ = fr2
    with pytest.warns(
        sanity.ImperfectFileWarning, match=r"3 repeated timestamp\(s\) \(first at line 125"
    ):
        traj = read_tum(path)
    assert len(traj) == 1497
    expected = np.delete(np.arange(1500), [121, 700, 701])  # 700, 701 repeat 699: a run of 3
    np.testing.assert_allclose(traj.T[:, :3, 3], np.round(p[expected], 4), atol=1e-12)
    with pytest.warns(sanity.ImperfectFileWarning, match="kept the last"):
        last = read_tum(path, duplicates="last")
    np.testing.assert_allclose(
        last.T[:, :3, 3], np.round(p[np.delete(np.arange(1500), [120, 699, 700])], 4), atol=1e-12
    )
    with pytest.raises(sanity.RepeatedStampError, match=r"groundtruth\.txt: 3 repeated .*line 125"):
        read_tum(path, duplicates="error")
    with pytest.raises(ValueError, match="duplicates: expected one of first, last, error"):
        read_tum(path, duplicates="keep")


@pytest.mark.parametrize("fmt", ["tum", "euroc", "evo"])
def test_real_files_repeated_stamps_same_policy_in_every_reader(tmp_path, fmt):
    p, q = motion("drone", n=300)
    t = 1403715524.0 + np.arange(300) * 0.05
    if fmt == "euroc":
        path = euroc_ground_truth(tmp_path / "data.csv", t, p, q, repeat_at=(50, 51, 200))
        reader = read_euroc
    else:
        writer = tum_ground_truth if fmt == "tum" else evo_estimate
        path = writer(tmp_path / "f.txt", t, p, q, repeat_at=(50, 51, 200))
        reader = read_tum
    for read in (reader, trajfile.read_trajectory):
        with pytest.warns(sanity.ImperfectFileWarning, match=r"3 repeated timestamp\(s\)"):
            traj = read(path)
        assert len(traj) == 297 and (np.diff(traj.stamps) > 0).all()
        with pytest.raises(sanity.RepeatedStampError):
            read(path, duplicates="error")


def test_real_files_quaternions_off_unit_normalised_with_worst_deviation(tmp_path, fr2):
    p, q = motion("drone", n=400)
    t = 1403715524.0 + np.arange(400) * 0.05
    # evo's V102.txt style: 5-decimal quaternions printed with 18 digits (off by up to ~1e-5)
    est = evo_estimate(tmp_path / "V102.txt", t, p, q)
    off = np.abs(np.linalg.norm(np.round(q, 5), axis=1) - 1)
    assert 1e-6 < off.max() < 1e-4
    with pytest.warns(
        sanity.ImperfectFileWarning, match=f"worst {off.max():.3g} at line {np.argmax(off) + 1}"
    ):
        traj = read_tum(est)
    R = traj.T[:, :3, :3]
    np.testing.assert_allclose(
        np.einsum("nji,njk->nik", R, R), np.tile(np.eye(3), (400, 1, 1)), atol=1e-14
    )
    # EuRoC ground truth: off by ~1.5e-4 although printed to 6 decimals
    csv = euroc_ground_truth(tmp_path / "data.csv", t, p, q)
    with pytest.warns(sanity.ImperfectFileWarning, match=r"worst 0\.000"):
        read_euroc(csv)
    # TUM ground truth: 4 decimals explain ~1e-4; normalised without a word (the warning is
    # about its repeated stamps only)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        read_tum(fr2[0])
    assert [str(w.message) for w in caught if "normalised" in str(w.message)] == []
    assert len(caught) == 1 and "repeated timestamp" in str(caught[0].message)


def test_real_files_quaternion_beyond_tolerance_refused_naming_file_line(tmp_path):
    p, q = motion("drone", n=100)
    q = q.copy()
    q[40] *= 1.002
    path = tmp_path / "est.txt"
    path.write_text(_rows(np.arange(100) * 0.1, p, q, "full"))
    with pytest.raises(
        sanity.QuaternionNormError,
        match=r"est\.txt:41: quaternion norm off by 0\.002 \(tolerance 0\.001",
    ):
        read_tum(path)
    with pytest.warns(sanity.ImperfectFileWarning, match=r"worst 0\.002 at line 41"):
        assert len(read_tum(path, quat_tolerance=3e-3)) == 100
    csv = euroc_ground_truth(tmp_path / "data.csv", np.arange(100) * 0.1, p, q, off_unit=0.0)
    with pytest.raises(
        sanity.QuaternionNormError, match=r"data\.csv:42: quaternion norm off by 0\.002"
    ):
        read_euroc(csv)


def test_real_files_traj_cli_duplicates_and_quat_tolerance_flags(tmp_path, fr2):
    gt = fr2[0]
    p, q = motion("camera_orbit", n=1500)
    est = evo_estimate(tmp_path / "est.txt", fr2[1][::5] + 0.003, p[::5], q[::5], repeat_at=(10,))
    r = _cli(["ape", str(gt), str(est), "--format", "json"])
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["n_ref"] == 1497 and json.loads(r.stdout)["n_est"] == 299
    assert "REF: " in r.stderr and "3 repeated timestamp(s)" in r.stderr
    assert "EST: " in r.stderr and "normalised" in r.stderr
    line = _one_line_error(_cli(["ape", str(gt), str(est), "--duplicates", "error"]))
    assert line.count("repeated timestamp") == 1 and "--duplicates first or last" in line
    assert "duplicates=" not in line  # the flag, not the Python keyword
    line = _one_line_error(_cli(["ape", str(gt), str(est), "--quat-tolerance", "1e-6"]))
    assert "quaternion norm off by" in line and "--quat-tolerance accepts" in line
    line = _one_line_error(_cli(["ape", str(gt), str(est), "--quat-tolerance", "nan"]))
    assert "--quat-tolerance" in line


# --- evo's numbers on these files ----------------------------------------------------------


def _evo_ape(ref, est, align: bool):
    from evo.core import metrics, sync

    r, e = sync.associate_trajectories(ref, est)
    if align:
        e.align(r)
    m = metrics.APE(metrics.PoseRelation.translation_part)
    m.process_data((r, e))
    return r.num_poses, m.get_all_statistics()


def _ours(args, capsys):
    assert main(["traj", "ape", *args, "--format", "json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_real_files_match_evo_on_tum_ground_truth_with_repeated_stamps(fr2, tmp_path, capsys):
    pytest.importorskip("evo")
    from evo.tools import file_interface

    gt, t, _, _ = fr2
    pe, qe = motion("camera_orbit", n=1500, noise=0.003, seed=9)
    # an estimate at a third of the rate, each stamp 1 ms before a ground-truth stamp. evo takes
    # the first row of a repeated pair for a stamp before it and the last for a stamp after it;
    # here every estimate stamp that meets a pair lies before it, so "first" is evo's choice
    keep = np.arange(0, 1500, 3)
    est = evo_estimate(tmp_path / "est.txt", t[keep] - 0.001, pe[keep], qe[keep])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ours = _ours([str(gt), str(est), "--align", "se3"], capsys)
    n, theirs = _evo_ape(
        file_interface.read_tum_trajectory_file(str(gt)),
        file_interface.read_tum_trajectory_file(str(est)),
        align=True,
    )
    assert ours["n"] == n
    for k in ("rmse", "mean", "median", "std", "min", "max"):
        assert ours[k] == pytest.approx(float(theirs[k]), rel=1e-9, abs=1e-12), k


def test_real_files_match_evo_on_euroc_ground_truth_and_estimate(tmp_path, capsys):
    pytest.importorskip("evo")
    from evo.tools import file_interface

    p, q = motion("drone", n=4000)
    t = 1403715524.907143168 + np.arange(4000) * 0.005
    gt = euroc_ground_truth(tmp_path / "data.csv", t, p, q)
    pe, qe = motion("drone", n=4000, noise=0.004, seed=2)
    keep = np.arange(3, 4000, 20)
    repeat = (40, 90, 150, 151)
    est = evo_estimate(
        tmp_path / "V102.txt", t[keep] + 0.0021, pe[keep], qe[keep], repeat_at=repeat
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ours = _ours([str(gt), str(est), "--align", "se3"], capsys)
    ref = file_interface.read_euroc_csv_trajectory(str(gt))
    raw = file_interface.read_tum_trajectory_file(str(est))
    # evo keeps every row: each repeated stamp of the shorter file pairs with the same
    # ground-truth pose again; liebridge keeps the first of each (4 rows fewer)
    n_raw, _ = _evo_ape(ref, raw, align=True)
    assert n_raw - ours["n"] == 4
    # on the rows liebridge keeps, evo's own readers, association, alignment and APE agree
    rows = np.loadtxt(est)
    kept = tmp_path / "kept.txt"
    np.savetxt(kept, np.delete(rows, list(repeat), axis=0))
    n, theirs = _evo_ape(ref, file_interface.read_tum_trajectory_file(str(kept)), align=True)
    assert ours["n"] == n
    for k in ("rmse", "mean", "median", "std", "min", "max"):
        assert ours[k] == pytest.approx(float(theirs[k]), rel=1e-9, abs=1e-12), k


def test_real_files_repeated_stamps_in_a_bag_topic_same_policy(tmp_path, capsys):
    pytest.importorskip("rosbags")
    from liebridge.ros import from_poses, write_messages

    p, q = motion("car_circle_ccw", n=80)
    T = poses(p, q)
    stamps = 1.7e9 + 0.1 * np.arange(80)
    trajfile.write_trajectory(tmp_path / "ref.txt", stamps, T)
    bag_stamps = stamps.copy()
    bag_stamps[[30, 31]] = bag_stamps[29]  # a driver that stamped three messages alike
    msgs = from_poses(T, np.tile(np.eye(6) * 1e-4, (80, 1, 1)), stamps=bag_stamps, frame_id="map")
    bag = write_messages(tmp_path / "est.mcap", "/pose", msgs)
    args = ["traj", "ape", str(tmp_path / "ref.txt"), str(bag), "--est-topic", "/pose"]
    assert main([*args, "--format", "json"]) == 0
    captured = capsys.readouterr()
    res = json.loads(captured.out)
    assert res["n_est"] == 78 and res["rmse"] == pytest.approx(0.0, abs=1e-9)  # first kept
    assert "2 repeated timestamp(s)" in captured.err
    assert main([*args, "--duplicates", "error"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--duplicates first or last" in err[0]


def test_misread_rotations_are_the_motion_with_world_and_body_swapped():
    """The fact the order check is built on: ``R'_i = A·R_iᵀ·B`` for fixed rotations A, B."""
    R = Rotation.random(200, random_state=4).as_matrix()
    for order in ("xyzw", "wxyz"):
        M = sanity.other_reading(R, order)
        C = sanity.other_reading(np.eye(3)[None], order)[0]  # = A·B
        # M_i Cᵀ = A R_iᵀ Aᵀ: its rotation vector is A times R_iᵀ's, one A for every i
        a = Rotation.from_matrix(np.swapaxes(R, 1, 2)).as_rotvec()
        b = Rotation.from_matrix(M @ C.T).as_rotvec()
        A, rssd = Rotation.align_vectors(b, a)
        assert rssd < 1e-5  # rotation vectors near π carry ~1e-8 of rounding
        np.testing.assert_allclose(
            M, A.as_matrix() @ np.swapaxes(R, 1, 2) @ A.as_matrix().T @ C, atol=1e-12
        )
        # and it is not the same motion: R'_i ≠ A' R_i B' for any fixed A', B'
        b2 = Rotation.from_matrix(M @ C.T).as_rotvec()
        _, rssd_same = Rotation.align_vectors(b2, Rotation.from_matrix(R).as_rotvec())
        assert rssd_same > 1.0
