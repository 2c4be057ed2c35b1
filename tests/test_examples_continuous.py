"""examples/lidar_deskew.py runs (--quick), ranks the deskew models as it says, writes its plot."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_lidar_deskew_example(tmp_path: Path) -> None:
    proc = subprocess.run(
        [
            sys.executable,
            str(ROOT / "examples" / "lidar_deskew.py"),
            "--quick",
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
        env={
            **os.environ,
            "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
        },
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = proc.stdout
    assert "nanoseconds with seconds: refused — mixed time units" in out
    rms = {}
    for line in out.splitlines():
        parts = line.rsplit(None, 2)
        if len(parts) == 3 and parts[0].strip() in {
            "kiss_icp (SE(3), end)",
            "ct_icp (split, end)",
            "wrong reference (begin)",
            "no deskew",
        }:
            rms[parts[0].strip()] = float(parts[1])
    assert len(rms) == 4, out
    assert rms["kiss_icp (SE(3), end)"] < 0.005  # the motion is a screw: noise (2 mm) only
    assert 0.01 < rms["ct_icp (split, end)"] < 0.05  # chord vs helix: centimetres
    assert rms["wrong reference (begin)"] > 1.0
    assert rms["no deskew"] > 0.5
    assert (tmp_path / "lidar_deskew.png").stat().st_size > 10_000
