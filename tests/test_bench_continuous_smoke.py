"""Smoke run of ``benchmarks/bench_continuous.py --quick``: it runs, agrees, writes its JSON."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_bench_continuous_quick(tmp_path: Path) -> None:
    out = tmp_path / "continuous.json"
    proc = subprocess.run(
        [
            sys.executable,
            str(ROOT / "benchmarks" / "bench_continuous.py"),
            str(out),
            "--quick",
            "--repeat",
            "1",
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
    res = json.loads(out.read_text())
    assert [r["row"] for r in res["rows"]] == ["deskew", "spline_evaluate"]
    for r in res["rows"]:
        assert r["max_abs_difference"] < 1e-9, r  # same answers before any timing
