"""Smoke run of ``benchmarks/bench_jaxlie.py --quick``: every op and size has a row, liebridge
and jaxlie agree on the same inputs, liebridge agrees with GTSAM at the edge angles; without
jax/jaxlie the script says so and exits cleanly."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "benchmarks" / "bench_jaxlie.py"
OPS = {"so3.exp", "so3.log", "se3.exp", "se3.log", "se3.adjoint"}


def _run(args: list[str], tmp_path: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "JAX_PLATFORMS": "cpu"}
    return subprocess.run(
        args, capture_output=True, text=True, timeout=300, cwd=tmp_path, env=env, check=False
    )


def test_bench_jaxlie_quick(tmp_path: Path) -> None:
    pytest.importorskip("jaxlie")  # the `bench` extra; CI does not install it
    out = tmp_path / "jaxlie.json"
    proc = _run([sys.executable, str(SCRIPT), "--quick", "--out", str(out)], tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads(out.read_text())
    assert res["quick"] is True and res["precision"].startswith("float64")
    assert res["jax_backend"] == "cpu"
    assert {(r["op"], r["n"]) for r in res["rows"]} == {(op, n) for op in OPS for n in (200, 1000)}
    for r in res["rows"]:
        assert set(r["median_s"]) == {
            "liebridge",
            "liebridge_numpy",
            "jaxlie_matrix",
            "jaxlie_native",
            "memory_pass",
            "one_pass",
        }
        assert all(v > 0 for v in r["median_s"].values())
        assert r["agreement"]["max_abs_liebridge_vs_jaxlie_matrix"] <= 1e-12
        assert r["agreement"]["max_abs_liebridge_vs_jaxlie_native"] <= 1e-12
        assert r["x_memory_pass"]["liebridge"] > 0 and r["x_one_pass"]["liebridge"] > 0
        assert r["speedup_vs_jaxlie_matrix"] > 0
    edges = {e["op"]: e for e in res["edge_cases"]}
    assert set(edges) == OPS
    # jaxlie 1.5's SE3.exp takes V(ω) = R below θ² = 1e-10: its translation is off by ≈ ½|ω × v|
    # at θ = 1e-6 with 30 m; the script records it (it is jaxlie's, not liebridge's)
    k = edges["se3.exp"]["angles_rad"].index(1e-6)
    assert edges["se3.exp"]["max_abs_liebridge_vs_gtsam"][k] < 1e-12
    assert "| se3.adjoint | 1,000 |" in proc.stdout


def test_bench_jaxlie_skips_without_jax(tmp_path: Path) -> None:
    # jax made unimportable (a None entry in sys.modules raises ImportError on import)
    code = (
        "import runpy, sys; sys.modules['jax'] = None; sys.modules['jaxlie'] = None; "
        f"sys.argv = [{str(SCRIPT)!r}, '--quick', '--out', 'x.json']; "
        f"runpy.run_path({str(SCRIPT)!r}, run_name='__main__')"
    )
    proc = _run([sys.executable, "-c", code], tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "bench_jaxlie: skipped, jax/jaxlie not installed" in proc.stdout
    assert not (tmp_path / "x.json").exists()
