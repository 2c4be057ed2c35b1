"""examples/kalibr_to_vio.py runs, and every system's use of its parameter agrees on a point."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_kalibr_to_vio_example(tmp_path: Path) -> None:
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    r = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "kalibr_to_vio.py"), "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        env=env,
        check=False,
        timeout=300,
    )
    assert r.returncode == 0, r.stdout + r.stderr
    assert (tmp_path / "camchain-imucam.yaml").is_file()
    for name in ("T_SC", "IMU.T_b_c1", "body_T_cam0", "T_imu_cam", "rvec"):
        assert name in r.stdout
    m = re.search(r"max difference (\S+) m", r.stdout)
    assert m and float(m.group(1)) < 1e-12
    m = re.search(r"stereo baseline \|t\| of T_cam1_cam0: (\S+) m", r.stdout)
    assert m and abs(float(m.group(1)) - 0.110) < 0.002  # EuRoC's ~11 cm stereo baseline
