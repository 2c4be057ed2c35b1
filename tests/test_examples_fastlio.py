"""The FAST-LIO example runs as a script (on this checkout's liebridge) and agrees with Monte
Carlo drawn in FAST-LIO's own 23-dimensional chart."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_fastlio_example_runs() -> None:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    proc = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "fastlio_state_covariance.py"), "--quick"],
        capture_output=True, text=True, timeout=300, env=env, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "converted covariances within Monte Carlo noise" in proc.stdout
    conv = [float(x) for x in re.findall(r"converted ([0-9.]+)", proc.stdout)]
    naive = [float(x) for x in re.findall(r"reordered only ([0-9.]+)", proc.stdout)]
    assert len(conv) == 3 and max(conv) < 0.05
    assert naive[0] > 0.2 and naive[1] < 0.05  # GTSAM: reordering is wrong; OpenVINS: right
