"""The trajectory scan finds what is planted and says nothing on a clean trajectory."""

from __future__ import annotations

import math

import numpy as np
import pytest

from liebridge.doctor import scan_trajectory
from liebridge.doctor.trajectory import measure_quat_order
from liebridge.io.trajectory import write_tum
from liebridge.lie import quaternion, se3, so3


def circle_drive(n=361, turns=1.0, radius=5.0, tilt=0.0, rng=None, noise=0.0):
    """A vehicle driving a circle (forward along its body x axis), yaw 0 → 360°·turns."""
    yaw = np.linspace(0.0, 2 * math.pi * turns, n)
    t = np.stack([radius * np.sin(yaw), radius * (1 - np.cos(yaw)), np.zeros(n)], axis=1)
    R = so3.exp(yaw[:, None] * np.array([0.0, 0.0, 1.0]))
    if tilt:  # a slow pitch/roll wobble
        R = R @ so3.exp(tilt * np.stack([np.sin(3 * yaw), np.cos(2 * yaw), 0 * yaw], axis=1))
    if noise:
        R = R @ so3.exp(rng.normal(0, noise, size=(n, 3)))
        t = t + rng.normal(0, 2 * noise, size=t.shape)
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3], T[:, :3, 3] = R, t
    return np.arange(n) * 0.1, T


def read_rows(path):
    data = np.loadtxt(path, comments="#")
    return data[:, 0], data[:, 1:]


def kinds(d, severity=None):
    return [f["kind"] for f in d.evidence["findings"] if severity in (None, f["severity"])]


# ------------------------------------------------------------------ the clean planar turn


def test_clean_planar_turn_written_by_write_tum_says_nothing(tmp_path):
    stamps, T = circle_drive()
    write_tum(tmp_path / "turn.txt", stamps, T)
    s, rows = read_rows(tmp_path / "turn.txt")
    d = scan_trajectory(s, rows, quat_order="xyzw")
    assert d.verdict == "ok", d
    assert kinds(d, "alarm") == [] and kinds(d, "warning") == []
    assert d.evidence["quat_order"]["order"] in ("xyzw", "undetermined")
    assert "no problems found" in d.explanation


def test_clean_turn_in_place_has_no_order_evidence_and_no_alarm(tmp_path):
    stamps, T = circle_drive(radius=0.0)
    write_tum(tmp_path / "spin.txt", stamps, T)
    s, rows = read_rows(tmp_path / "spin.txt")
    d = scan_trajectory(s, rows, quat_order="xyzw")
    assert d.verdict == "ok", d
    assert d.evidence["quat_order"]["order"] == "undetermined"


def test_branch_cut_crossing_of_the_turn_is_found_as_information():
    stamps, T = circle_drive()  # yaw passes 180° between samples 180 and 181? (1° steps)
    d = scan_trajectory(stamps, T)
    cuts = [f for f in d.evidence["findings"] if f["kind"] == "branch_cut"]
    assert [f["index"] for f in cuts] in ([179], [180]), cuts
    assert all(f["severity"] == "info" for f in cuts) and d.verdict == "ok"


def test_branch_cut_crossings_planted_about_a_tilted_axis():
    axis = np.array([1.0, -2.0, 0.5]) / math.sqrt(5.25)
    ang = math.pi + 0.2 * np.sin(np.linspace(0.1, 4 * math.pi + 0.1, 200))  # crosses π 4×
    R = so3.exp(ang[:, None] * axis)
    d = scan_trajectory(np.arange(200) * 0.05, R, reference=np.eye(3))
    cuts = [f["index"] for f in d.evidence["findings"] if f["kind"] == "branch_cut"]
    expected = np.flatnonzero(np.diff(np.sign(ang - math.pi)) != 0)
    assert len(cuts) == len(expected) >= 3
    assert all(abs(c - e) <= 1 for c, e in zip(cuts, expected, strict=True))
    assert d.verdict == "ok"


# ------------------------------------------------------------------ planted sign flips


def test_planted_sign_flips_are_found_with_the_slerp_spin():
    stamps, T = circle_drive(n=100, turns=0.3)
    q = quaternion.from_matrix(T[:, :3, :3], order="xyzw")
    q[40] *= -1.0  # flips between 39|40 and 40|41
    q[70:] *= -1.0  # and 69|70
    d = scan_trajectory(stamps, q, quat_order="xyzw")
    flips = [f for f in d.evidence["findings"] if f["kind"] == "sign_flip"]
    assert [f["index"] for f in flips] == [39, 40, 69]
    assert all(f["slerp_spin_deg"] > 350 for f in flips)
    clean = scan_trajectory(stamps, quaternion.from_matrix(T[:, :3, :3], order="xyzw"))
    assert "sign_flip" not in kinds(clean)


# ------------------------------------------------------------------ storage order, w-first TUM


def write_w_first_tum(path, stamps, T, canonical=True):
    q = quaternion.from_matrix(T[:, :3, :3], order="wxyz")
    if canonical:
        q = q * np.where(q[:, :1] < 0, -1.0, 1.0)
    else:  # continuous sign (no flips)
        for k in range(1, len(q)):
            if q[k] @ q[k - 1] < 0:
                q[k] = -q[k]
    rows = np.hstack([stamps[:, None], T[:, :3, 3], q])
    np.savetxt(path, rows, header="timestamp tx ty tz qx qy qz qw", fmt="%.9f")


@pytest.mark.parametrize("noise", [0.0, 0.02], ids=["noiseless", "noisy"])
@pytest.mark.parametrize("canonical", [True, False], ids=["w>=0", "continuous"])
def test_w_first_tum_file_is_named(tmp_path, noise, canonical):
    stamps, T = circle_drive(n=300, turns=0.8, tilt=0.05, rng=np.random.default_rng(1), noise=noise)
    write_w_first_tum(tmp_path / "wfirst.txt", stamps, T, canonical)
    s, rows = read_rows(tmp_path / "wfirst.txt")
    d = scan_trajectory(s, rows, quat_order="xyzw")
    assert d.evidence["quat_order"]["order"] == "wxyz", d.evidence["quat_order"]
    assert d.evidence["quat_order"]["confidence"] == "high"
    assert d.verdict == "alarm" and d.cause == "quat_order", d
    assert "stored wxyz" in d.explanation
    # the same file read with its true order raises nothing
    assert scan_trajectory(s, rows, quat_order="wxyz").verdict == "ok"


@pytest.mark.parametrize("noise", [0.0, 0.02], ids=["noiseless", "noisy"])
def test_xyzw_file_is_named_xyzw(tmp_path, noise):
    stamps, T = circle_drive(n=300, turns=0.8, tilt=0.05, rng=np.random.default_rng(2), noise=noise)
    write_tum(tmp_path / "ok.txt", stamps, T)
    s, rows = read_rows(tmp_path / "ok.txt")
    ev = measure_quat_order(rows[:, 3:], rows[:, :3])
    assert (ev["order"], ev["confidence"]) == ("xyzw", "high"), ev
    assert scan_trajectory(s, rows, quat_order="xyzw").verdict == "ok"


# ------------------------------------------------------------------ time, jumps, bad rotations


def test_duplicates_backward_steps_and_gaps():
    stamps, T = circle_drive(n=60, turns=0.2)
    s = stamps.copy()
    s[10] = s[9]  # duplicate
    s[30], s[31] = s[31], s[30]  # backward
    s[45:] += 5.0  # a gap after 44
    d = scan_trajectory(s, T)
    assert {"duplicate_stamp", "backward_stamp", "time_gap"} <= set(kinds(d)), d
    assert d.verdict == "alarm"
    gap = next(f for f in d.evidence["findings"] if f["kind"] == "time_gap")
    assert gap["indices"] == [44] and gap["severity"] == "warning"
    only_gap = stamps.copy()
    only_gap[45:] += 5.0
    assert scan_trajectory(only_gap, T).verdict == "warning"


def test_pose_jump_is_an_alarm():
    stamps, T = circle_drive(n=80, turns=0.2)
    T[50] = T[50] @ se3.exp([0.0, 0.0, 0.8, 1.0, 0.0, 0.0])
    d = scan_trajectory(stamps, T)
    jumps = [f["indices"] for f in d.evidence["findings"] if f["kind"] == "pose_jump"]
    assert jumps == [[49, 50]] and d.verdict == "alarm"


def test_non_orthonormal_rotation_and_non_unit_quaternion():
    stamps, T = circle_drive(n=30, turns=0.1)
    T[7, :3, :3] *= 1.01
    d = scan_trajectory(stamps, T)
    assert d.cause == "non_orthonormal" and d.evidence["findings"][0]["indices"] == [7]
    q = quaternion.from_matrix(circle_drive(n=30, turns=0.1)[1][:, :3, :3], order="xyzw")
    q[12] *= 1.1
    d = scan_trajectory(stamps, q, quat_order="xyzw")
    assert d.cause == "non_unit_quaternion" and d.evidence["findings"][0]["indices"] == [12]


def test_bad_input():
    stamps, T = circle_drive(n=10)
    with pytest.raises(ValueError, match=r"T: expected 10 samples"):
        scan_trajectory(stamps, T[:5])
    with pytest.raises(ValueError, match=r"stamps"):
        scan_trajectory(stamps[:1], T[:1])
    with pytest.raises(ValueError, match=r"T: expected poses"):
        scan_trajectory(stamps, np.zeros((10, 5)))
    bad = stamps.copy()
    bad[3] = np.nan
    with pytest.raises(ValueError, match="stamps"):
        scan_trajectory(bad, T)
    with pytest.raises(ValueError, match="quat_order"):
        scan_trajectory(stamps, np.tile([0, 0, 0, 1.0], (10, 1)), quat_order="zyxw")


# ------------------------------------------------------------------ a user's SLERP


def naive_slerp(q0, q1, tau):  # the bug: no hemisphere check
    th = np.arccos(np.clip(q0 @ q1, -1.0, 1.0))
    return q0 if th < 1e-9 else (np.sin((1 - tau) * th) * q0 + np.sin(tau * th) * q1) / np.sin(th)


def checked_slerp(q0, q1, tau):
    return naive_slerp(q0, q1 if q0 @ q1 >= 0 else -q1, tau)


def test_slerp_without_the_hemisphere_check_is_a_pose_jump():
    keys = quaternion.from_matrix(
        so3.exp(np.linspace(0, 1.2, 6)[:, None] * [0, 0, 1.0]), order="wxyz"
    )
    keys[3] *= -1.0  # stored with the other sign: the same rotation
    taus = np.linspace(0, 1, 10, endpoint=False)
    stamps = np.arange(50) * 0.01
    bad = np.array([naive_slerp(keys[k], keys[k + 1], s) for k in range(5) for s in taus])
    d = scan_trajectory(stamps, bad, quat_order="wxyz")
    jumps = [f for f in d.evidence["findings"] if f["kind"] == "pose_jump"]
    assert d.verdict == "alarm" and len(jumps) == 1 and jumps[0]["indices"][0] == 20, d
    ok = np.array([checked_slerp(keys[k], keys[k + 1], s) for k in range(5) for s in taus])
    assert scan_trajectory(stamps, ok, quat_order="wxyz").verdict == "ok"


def test_a_step_of_nearly_180_degrees_is_an_alarm():
    yaw = np.radians(np.r_[np.arange(0, 20, 1.0), 199.0 + np.arange(0, 20, 1.0)])
    R = so3.exp(yaw[:, None] * np.array([0.0, 0.0, 1.0]))
    d = scan_trajectory(np.arange(len(yaw)) * 0.1, R)
    assert {"pose_jump", "between_near_pi"} <= set(kinds(d, "alarm")), d
    near = next(f for f in d.evidence["findings"] if f["kind"] == "between_near_pi")
    assert near["indices"] == [19]
    ok = scan_trajectory(
        np.arange(40) * 0.1, so3.exp(np.radians(np.arange(40.0))[:, None] * [0, 0, 1.0])
    )
    assert "between_near_pi" not in kinds(ok)
