"""examples/nees_consistency.py runs (--quick), prints its three verdicts and writes its plot."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_nees_example(tmp_path: Path) -> None:
    proc = subprocess.run(
        [
            sys.executable,
            str(ROOT / "examples" / "nees_consistency.py"),
            "--quick",
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
        # the script's own directory comes first on sys.path: point it at this checkout
        env={
            **os.environ,
            "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
        },
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    verdicts = {ln.split("  ")[0].strip(): ln.rsplit(" ", 1)[-1] for ln in lines if "ANEES" in ln}
    assert verdicts == {
        "ros (correct)": "consistent",
        "left read as right": "INCONSISTENT",
        "(ω, v) swapped": "INCONSISTENT",
    }, proc.stdout
    swapped = next(ln for ln in lines if ln.startswith("(ω, v)"))
    assert float(re.search(r"ANEES =\s+(\S+)", swapped).group(1)) > 100
    png = tmp_path / "nees_consistency.png"
    assert png.stat().st_size > 20_000
