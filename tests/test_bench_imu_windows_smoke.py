"""Smoke run of ``benchmarks/bench_imu_windows.py --quick``: it runs, agrees with GTSAM; JSON."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_bench_imu_windows_quick(tmp_path: Path) -> None:
    out = tmp_path / "imu_windows.json"
    proc = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "bench_imu_windows.py"), str(out), "--quick"],
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
    assert res["quick"] is True and res["window"] == 100 and res["windows"] == 20
    methods = [r["method"] for r in res["results"]]
    assert methods == [
        "gtsam manifold loop",
        "liebridge windows",
        "liebridge windows numpy",
        "liebridge per-window",
    ]
    agree = res["agreement_with_gtsam"]
    assert agree["max_abs_dR"] < 1e-9 and agree["max_abs_dp_m"] < 1e-9
    assert agree["max_abs_dv_mps"] < 1e-9
    assert agree["cov_rel"] < 1e-9 and agree["bias_jacobian_rel"] < 1e-9
    assert "preintegrate_windows" in proc.stdout


def test_bench_imu_combined_quick(tmp_path: Path) -> None:
    out = tmp_path / "imu_combined.json"
    proc = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "bench_imu_combined.py"), str(out), "--quick"],
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
    assert res["quick"] is True and res["samples"] == 2000
    assert [r["method"] for r in res["results"]] == ["gtsam combined loop", "liebridge combined"]
    agree = res["agreement_with_gtsam"]
    assert agree["max_abs_dR"] < 1e-9 and agree["max_abs_dp_m"] < 1e-9
    assert agree["max_abs_dv_mps"] < 1e-9 and agree["cov_rel"] < 1e-9
