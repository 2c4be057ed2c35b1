"""Smoke run of ``benchmarks/bench_backends.py --quick``: every op of every installed backend has
a row, and liebridge agrees with the hand-written code (the script asserts it)."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "benchmarks" / "bench_backends.py"


@pytest.mark.skipif(
    not (importlib.util.find_spec("torch") or importlib.util.find_spec("jax")),
    reason="the torch or jax extra",
)
def test_bench_backends_quick(tmp_path: Path) -> None:
    out = tmp_path / "backends.json"
    env = {**os.environ, "PYTHONPATH": str(ROOT), "JAX_PLATFORMS": "cpu"}
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--quick", "--out", str(out)],
        capture_output=True, text=True, timeout=600, cwd=tmp_path, env=env, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = json.loads(out.read_text())["rows"]
    ops = {"se3.exp", "se3.log", "tangent_map", "convert_covariance", "grad"}
    for backend in ("torch", "jax"):
        if importlib.util.find_spec(backend):
            got = {r["op"] for r in rows if r["backend"] == backend}
            assert got == ops, (backend, got)
    assert all(r["max_rel_diff"] <= 1e-9 for r in rows)
