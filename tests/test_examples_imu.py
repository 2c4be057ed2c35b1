"""examples/imu_preintegration.py runs on a short prefix of the KITTI data and both graphs agree."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "imu_preintegration.py"


def test_imu_example_runs_and_agrees_with_gtsam() -> None:
    out = subprocess.run(
        [sys.executable, str(EXAMPLE), "--samples", "1500"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    text = out.stdout
    assert "keyframes: 15" in text
    dpos = float(re.search(r"max position difference: (\S+) m", text).group(1))  # type: ignore[union-attr]
    drot = float(re.search(r"max rotation difference: (\S+) rad", text).group(1))  # type: ignore[union-attr]
    gap = float(re.search(r"preintegration: (\S+) m", text).group(1))  # type: ignore[union-attr]
    assert dpos < 1e-3 and drot < 1e-4
    assert 0.0 < gap < 1e-4  # tangent vs manifold preintegration: a second-order difference
    assert "agree: yes" in text


def test_imu_example_rejects_bad_arguments() -> None:
    out = subprocess.run(
        [sys.executable, str(EXAMPLE), "--samples", "many"], capture_output=True, text=True
    )
    assert out.returncode == 2
    assert "--samples" in out.stderr
