"""examples/incremental_isam2.py runs, and GTSAM's iSAM2 on the same CustomFactors agrees."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def test_incremental_isam2_example_runs_and_agrees_with_gtsam() -> None:
    proc = subprocess.run(
        [
            sys.executable,
            str(ROOT / "examples" / "incremental_isam2.py"),
            "--max-poses",
            "150",
            "--compare-poses",
            "100",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert re.search(r"ISAM2 \(g2o\): 150 poses in 6 updates", proc.stdout), proc.stdout
    m = re.search(r"max pose difference ([0-9.e+-]+)", proc.stdout)
    assert m, proc.stdout
    assert float(m.group(1)) < 1e-8


def test_docs_worked_example_runs() -> None:
    text = (ROOT / "docs" / "isam2.md").read_text()
    code = re.search(r"```python\n(.*?)```", text, re.S)
    assert code, "no python block in docs/isam2.md"
    ns: dict[str, object] = {}
    exec(compile(code.group(1), "docs/isam2.md", "exec"), ns)
    est: Any = ns["estimate"]
    np.testing.assert_allclose(est.atPose3(2).translation(), [2.0, 0.0, 0.0], atol=1e-3)
