"""Smoke run of ``bench_speed.py --quick --parts batched,single,kernels``: the rows exist, agree
(each row first asserts liebridge == the hand-written numpy / GTSAM expression) and say whether
the compiled conversion pass ran."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_bench_speed_compiled_parts(tmp_path: Path) -> None:
    out = tmp_path / "speed.json"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, str(ROOT / "benchmarks" / "bench_speed.py"), "--quick"]
    cmd += ["--parts", "batched,single,kernels", "--out", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=ROOT, env=env)
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads(out.read_text())
    ops = {r["op"] for r in res["batched_all"]}
    assert "convert_covariance gtsam→ros (batched)" in ops and len(ops) == 6
    assert res["batched"] == res["batched_all"][0]
    for r in res["batched_all"]:
        assert r["speedup_vs_hand_numpy"] > 0 and r["x_memory_pass"] > 0
        assert isinstance(r["compiled"], bool)
    assert {r["op"] for r in res["kernels"]} == {
        "se3.exp",
        "se3.log",
        "se3.adjoint",
        "so3.exp",
        "so3.log",
    }
    assert len(res["single_more"]) == 3
    assert {r["op"] for r in res["single"]} == {"tangent_map", "convert_covariance"}
