"""Smoke run of ``benchmarks/bench_files.py --quick``: it runs, rows agree."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_bench_files_quick(tmp_path: Path) -> None:
    out = tmp_path / "files.json"
    proc = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "bench_files.py"), "--quick", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads(out.read_text())
    rows = {r["op"]: r for r in res["rows"]}
    assert set(rows) == {"read_tum", "read_kitti", "read_g2o_3d", "read_g2o_2d", "read_g2o_edge3"}
    for r in rows.values():
        assert r["ratio_vs_loadtxt"] > 0 and r["returned_mib"] > 0 and r["peak_mib"] > 0
    assert rows["read_g2o_3d"]["evo"] == "evo has no reader for this format"
    copies = rows["read_g2o_edge3"]["vertices"] // 2500  # sphere2500: 2500 poses, 4949 edges
    assert rows["read_g2o_edge3"]["edges"] == 4949 * copies + copies - 1  # + the joining edges
    # --only: those rows re-run and replaced, the others kept
    before = {r["op"]: r["s"] for r in res["rows"]}
    args = ["--quick", "--only", "edge3", "--out", str(out)]
    proc = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "bench_files.py"), *args],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    after = {r["op"]: r["s"] for r in json.loads(out.read_text())["rows"]}
    assert set(after) == set(before)
    assert all(after[op] == before[op] for op in before if op != "read_g2o_edge3")
    have_evo = importlib.util.find_spec("evo") is not None
    for op in ("read_tum", "read_kitti"):
        assert ("ratio_vs_evo" in rows[op]) == have_evo
        assert have_evo or rows[op]["evo"].startswith("skipped: evo is not installed")
