"""Smoke run of ``benchmarks/run.py --quick``: it runs and writes the expected JSON."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_run_quick_writes_the_expected_json(tmp_path: Path) -> None:
    out = tmp_path / "run.json"
    proc = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "run.py"), "--quick", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "batched, N =" in proc.stdout and "single call" in proc.stdout
    res = json.loads(out.read_text())
    assert {"command", "machine", "config", "batched", "single", "accuracy", "external"} <= set(res)
    assert {"cpu", "cores", "python", "numpy", "gtsam"} <= set(res["machine"])
    assert res["config"]["quick"] is True

    ops = {r["op"] for r in res["batched"]}
    assert ops == {
        "se3.exp",
        "se3.log",
        "tangent_map gtsam→barfoot",
        "convert_covariance gtsam→barfoot",
    }
    for row in res["batched"]:
        assert {"liebridge", "gtsam_loop", "numpy_copy_floor"} <= set(row["us_per_element"])
        assert {"speedup_vs_gtsam_loop", "x_numpy_copy_floor", "met", "target"} <= set(row)
        assert row["max_diff_vs_gtsam"] < 1e-7  # the same answer as GTSAM (log: GTSAM near π)

    assert {r["op"] for r in res["single"]} == {"tangent_map", "convert_covariance"}
    for row in res["single"]:
        assert {"liebridge", "hand_gtsam", "liebridge_no_validation"} <= set(row["us"])
        assert {"ratio_vs_hand_gtsam", "validation_us", "met", "target"} <= set(row)

    angles = [r["angle"] for r in res["accuracy"]["rows"]]
    assert angles[0] == "0" and angles[-1] == "π" and len(angles) == 12
    for row in res["accuracy"]["rows"]:
        err = row["max_abs_error"]
        assert set(err) == {"log(exp(xi))", "exp(log(T))", "jr"}
        assert err["log(exp(xi))"]["liebridge"] < 1e-14
        assert err["exp(log(T))"]["liebridge"] < 1e-14
        assert err["jr"]["liebridge"] < 1e-14

    assert {"imu", "sphere2500_factors"} <= set(res["external"])
    for entry in res["external"].values():
        assert entry["status"] in {"ok", "skipped", "absent", "failed"}
