"""``liebridge traj`` reads bag topics (the ROS issue's readers) as well as trajectory files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rosbags")

from liebridge.cli import main
from liebridge.io import trajectory
from liebridge.lie import se3
from liebridge.ros import from_poses, write_messages


def _trajectories() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(7)
    n = 60
    stamps = 1.7e9 + 0.1 * np.arange(n)
    T_ref = np.stack([se3.exp(np.r_[0, 0, 0.05 * k, 0.5 * k, 0.1 * k, 0]) for k in range(n)])
    T_est = T_ref @ se3.exp(rng.normal(scale=[0.01, 0.01, 0.01, 0.05, 0.05, 0.05], size=(n, 6)))
    return stamps, T_ref, T_est


@pytest.mark.parametrize("suffix", [".bag", ".mcap"])
def test_ape_from_a_bag_topic_equals_ape_from_the_same_poses_in_tum(
    tmp_path: Path, suffix: str, capsys: pytest.CaptureFixture[str]
) -> None:
    stamps, T_ref, T_est = _trajectories()
    trajectory.write_tum(tmp_path / "ref.txt", stamps, T_ref)
    trajectory.write_tum(tmp_path / "est.txt", stamps, T_est)
    msgs = from_poses(
        T_est, np.tile(np.eye(6) * 1e-4, (len(stamps), 1, 1)), stamps=stamps, frame_id="map"
    )
    bag = write_messages(tmp_path / f"est{suffix}", "/est_pose", msgs)
    args = ["traj", "ape", str(tmp_path / "ref.txt")]
    assert main([*args, str(tmp_path / "est.txt"), "--align", "se3", "--format", "json"]) == 0
    from_files = json.loads(capsys.readouterr().out)
    assert (
        main([*args, str(bag), "--est-topic", "/est_pose", "--align", "se3", "--format", "json"])
        == 0
    )
    from_bag = json.loads(capsys.readouterr().out)
    for key in ("rmse", "mean", "median", "std", "min", "max"):
        assert from_bag[key] == pytest.approx(from_files[key], rel=1e-9, abs=1e-12), key


def test_a_missing_topic_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    stamps, T_ref, T_est = _trajectories()
    trajectory.write_tum(tmp_path / "ref.txt", stamps, T_ref)
    bag = write_messages(
        tmp_path / "e.bag", "/est_pose", from_poses(T_est, None, stamps=stamps, frame_id="map")
    )
    assert main(["traj", "ape", str(tmp_path / "ref.txt"), str(bag), "--est-topic", "/nope"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "EST" in err[0] and "/nope" in err[0]
