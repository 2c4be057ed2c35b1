"""Smoke run of ``benchmarks/bench_traj.py --quick``: it runs, agrees with evo, writes its JSON."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_bench_traj_quick(tmp_path: Path) -> None:
    pytest.importorskip("evo")
    out = tmp_path / "traj.json"
    proc = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "bench_traj.py"), str(out), "--quick"],
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
    assert res["config"] == {"poses": 20_000, "repeat": 2, "quick": True}
    assert [r["stage"] for r in res["stages"]] == [
        "read",
        "associate",
        "align",
        "ape",
        "rpe",
        "total",
    ]
    assert res["max_relative_difference"] < 1e-9
