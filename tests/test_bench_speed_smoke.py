"""Smoke run of ``benchmarks/bench_speed.py --quick``: it runs, rows agree."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_bench_speed_quick(tmp_path: Path) -> None:
    out = tmp_path / "speed.json"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "bench_speed.py"), "--quick", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads(out.read_text())
    assert {r["op"] for r in res["files"]} == {"read_tum", "read_kitti"}
    for r in res["files"]:
        assert r["ratio_vs_loadtxt"] > 0 and r["returned_mib"] > 0
    assert res["unscented"][0]["ratio_chunked_vs_one_pass"] > 0
    assert {"speedup_vs_hand_numpy", "x_memory_pass", "met"} <= set(res["batched"])
    assert {r["op"] for r in res["single"]} == {"tangent_map", "convert_covariance"}
