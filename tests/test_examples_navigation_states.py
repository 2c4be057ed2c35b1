"""The navigation-state example runs as a script (on this checkout's liebridge) and agrees with
Monte Carlo: an OpenVINS 15×15 covariance converted to GTSAM's graph keys and to VINS."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_navigation_state_example_runs() -> None:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    proc = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "navigation_state_covariance.py"), "--quick"],
        capture_output=True, text=True, timeout=300, env=env, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "converted covariances within Monte Carlo noise" in proc.stdout
    conv = [float(x) for x in re.findall(r"converted ([0-9.]+)", proc.stdout)]
    naive = [float(x) for x in re.findall(r"reordered only ([0-9.]+)", proc.stdout)]
    assert len(conv) == 2 and max(conv) < 0.05
    assert naive[0] > 0.2 and naive[1] < 0.05  # GTSAM keys: reordering is wrong; VINS: exact
    assert "exactly linear (a reordering suffices): False" in proc.stdout
    assert "exactly linear (a reordering suffices): True" in proc.stdout
