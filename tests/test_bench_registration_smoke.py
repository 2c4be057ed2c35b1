"""Smoke run of ``benchmarks/bench_registration.py --quick``: it runs, agrees with the hand-written
numpy of each library's native convention, and writes its JSON (timings are not asserted)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_bench_registration_quick(tmp_path: Path) -> None:
    out = tmp_path / "registration.json"
    proc = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "bench_registration.py"), str(out), "--quick"],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads(out.read_text())
    assert res["config"] == {"n": 100_000, "repeat": 3, "quick": True}
    assert [r["convention"] for r in res["rows"]] == [
        "open3d",
        "gtsam",
        "small_gicp",
        "kiss_icp",
        "g2o",
        "ros",
    ]
    for row in res["rows"]:
        assert row["max_abs_diff"] < 1e-9  # the same Jacobians as the hand-written formula
        assert row["liebridge_ms"] > 0 and row["hand_ms"] > 0 and row["target"] == 1.5
