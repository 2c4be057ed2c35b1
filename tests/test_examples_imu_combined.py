"""examples/imu_combined_kitti.py runs (--quick) and its graph's optimum equals GTSAM's."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "imu_combined_kitti.py"


def test_combined_example_runs_and_agrees_with_gtsam() -> None:
    out = subprocess.run(
        [sys.executable, str(EXAMPLE), "--quick"],
        capture_output=True,
        text=True,
        timeout=300,
        env={
            **os.environ,
            "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
        },
    )
    assert out.returncode == 0, out.stdout + out.stderr
    text = out.stdout
    assert "keyframes: 15" in text
    dpos = float(re.search(r"max position difference: (\S+) m", text).group(1))  # type: ignore[union-attr]
    drot = float(re.search(r"max rotation difference: (\S+) rad", text).group(1))  # type: ignore[union-attr]
    assert dpos < 1e-6 and drot < 1e-8
    errs = re.findall(r"error (\S+) -> (\S+) in", text)
    assert len(errs) == 2 and float(errs[0][1]) < 1e-3 * float(errs[0][0])
    assert abs(float(errs[0][1]) - float(errs[1][1])) <= 1e-6 * float(errs[1][1])
    assert "agree: yes" in text
