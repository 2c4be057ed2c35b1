"""``liebridge extrinsics convert``: one JSON object per call, clear one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from liebridge.cli import main
from liebridge.frames import system_names
from liebridge.lie import se3

T_CAM_IMU = se3.exp(np.array([-0.4, 1.9, 0.2, 0.05, 0.3, -0.1]))


def _rows(T: np.ndarray) -> str:
    return "\n".join("  - [" + ", ".join(repr(float(x)) for x in r) + "]" for r in T)


@pytest.fixture
def camchain(tmp_path: Path) -> Path:
    path = tmp_path / "camchain-imucam.yaml"
    path.write_text("cam0:\n  T_cam_imu:\n" + _rows(T_CAM_IMU) + "\n  timeshift_cam_imu: 0.0\n")
    return path


HOLDS_CAM_IMU = {"kalibr", "opencv"}


@pytest.mark.parametrize("system", system_names())
def test_json_one_object(system: str, camchain: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["extrinsics", "convert", str(camchain), "--to", system, "--format", "json"]) == 0
    out = capsys.readouterr().out
    obj = json.loads(out)  # exactly one JSON document: json.loads rejects trailing data
    assert out.count("\n") == 1
    T = np.array(obj["T"])
    if system in HOLDS_CAM_IMU:
        np.testing.assert_allclose(T, T_CAM_IMU, atol=1e-15)
        assert (obj["target_frame"], obj["source_frame"]) == ("cam0", "imu0")
    else:
        np.testing.assert_allclose(T, se3.inverse(T_CAM_IMU), atol=1e-15)
        assert (obj["target_frame"], obj["source_frame"]) == ("imu0", "cam0")
    assert obj["system"] == system and obj["from_system"] == "kalibr"
    assert {"parameter", "direction", "snippet"} <= set(obj)
    # T maps source_frame coordinates to target_frame: check on a point
    p_imu = np.array([1.0, -2.0, 0.5])
    p_cam = T_CAM_IMU[:3, :3] @ p_imu + T_CAM_IMU[:3, 3]
    src, dst = (p_imu, p_cam) if obj["source_frame"] == "imu0" else (p_cam, p_imu)
    np.testing.assert_allclose(T[:3, :3] @ src + T[:3, 3], dst, atol=1e-12)


def test_parameters(camchain: Path, capsys: pytest.CaptureFixture[str]) -> None:
    names = {}
    for s in system_names():
        main(["extrinsics", "convert", str(camchain), "--to", s, "--format", "json"])
        names[s] = json.loads(capsys.readouterr().out)["parameter"]
    assert names == {
        "kalibr": "T_cam_imu",
        "okvis": "T_SC",
        "orbslam3": "IMU.T_b_c1",
        "openvins": "T_imu_cam",
        "basalt": "T_imu_cam",
        "vins_fusion": "body_T_cam0",
        "opencv": "rvec, tvec",
    }


def test_from_other_system_file(
    tmp_path: Path, camchain: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    main(["extrinsics", "convert", str(camchain), "--to", "vins_fusion", "--format", "json"])
    snippet = json.loads(capsys.readouterr().out)["snippet"]
    vins = tmp_path / "vins.yaml"
    vins.write_text(snippet)
    for extra in ([], ["--from", "vins_fusion"]):
        main(["extrinsics", "convert", str(vins), "--to", "kalibr", "--format", "json", *extra])
        obj = json.loads(capsys.readouterr().out)
        assert obj["from_system"] == "vins_fusion"
        np.testing.assert_allclose(obj["T"], T_CAM_IMU, atol=1e-15)


def test_text_output(camchain: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["extrinsics", "convert", str(camchain), "--to", "okvis"]) == 0
    out = capsys.readouterr().out
    assert "T_SC maps cam0 coordinates to imu0 coordinates" in out
    assert "frames: target imu0, source cam0" in out and "ReprojectionError.hpp" in out


def test_errors_one_line(tmp_path: Path, camchain: Path) -> None:
    bad = tmp_path / "bad.yaml"
    T = T_CAM_IMU.copy()
    T[0, 0] += 0.05
    bad.write_text("cam0:\n  T_cam_imu:\n" + _rows(T) + "\n")
    nothing = tmp_path / "nothing.yaml"
    nothing.write_text("a: 1\n")
    cases = [
        (["--to-system", "rovio", str(camchain)], "unknown system 'rovio'"),
        (
            ["--to-system", "okvis", "--from-system", "kalibrr", str(camchain)],
            "--from-system: unknown system",
        ),
        (["--to-system", "okvis", str(tmp_path / "missing.yaml")], "no such file"),
        (["--to-system", "okvis", str(bad)], "cam0.T_cam_imu: not a rotation"),
        (["--to-system", "okvis", "--camera", "cam3", str(camchain)], "no camera 'cam3'"),
        (["--to-system", "okvis", str(nothing)], "cannot tell which system"),
    ]
    for args, msg in cases:
        r = subprocess.run(
            [sys.executable, "-m", "liebridge.cli", "extrinsics", "convert", *args],
            capture_output=True,
            text=True,
            check=False,
        )
        assert r.returncode == 2, (args, r.stderr)
        assert r.stdout == ""
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and msg in lines[0], (args, r.stderr)
        assert "Traceback" not in r.stderr
