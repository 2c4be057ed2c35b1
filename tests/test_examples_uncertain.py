"""examples/uncertain_relative_pose.py runs quickly, measures what its docstring promises and
writes its plot."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "uncertain_relative_pose.py"


def test_uncertain_relative_pose_example(tmp_path: Path) -> None:
    proc = subprocess.run(
        [sys.executable, str(EXAMPLE), "--quick", "--no-show", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=300,
        # the liebridge next to this test (a checkout need not be the installed one)
        env={
            **os.environ,
            "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
        },
    )
    assert proc.returncode == 0, proc.stderr
    errors = {
        m.group(1).strip(): float(m.group(2))
        for m in re.finditer(r"^\s+(.+?)\s+([0-9.]+)$", proc.stdout, re.M)
    }
    right = {k: e for k, e in errors.items() if "(liebridge)" in k}
    wrong = {k: e for k, e in errors.items() if "(wrong)" in k}
    assert len(right) == 4 and len(wrong) == 3, proc.stdout
    assert max(right.values()) < 0.03, proc.stdout
    assert min(wrong.values()) > 0.2, proc.stdout
    png = tmp_path / "uncertain_relative_pose.png"
    assert png.is_file() and png.stat().st_size > 20000
