"""Smoke run of ``benchmarks/bench_scale.py --quick``: it runs and its figures hold together."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_bench_scale_quick(tmp_path: Path) -> None:
    pytest.importorskip("rosbags")
    pytest.importorskip("yaml")
    out = tmp_path / "scale.json"
    proc = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "bench_scale.py"), "--quick", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads(out.read_text())
    bag = res["bag_export_tum"]
    # streamed: the export grows far less per message than the whole read
    assert (
        bag["export_tum"]["rss_growth_bytes_per_message"]
        < 0.5 * bag["read_messages"]["rss_growth_bytes_per_message"]
    )
    held = res["read_messages_bytes"]  # arrays, not message objects: well under a kB a message
    assert held["read_messages_held_bytes_per_message"] < 800
    assert held["read_messages_held_bytes_per_message"] < held["user_list_held_bytes_per_message"]
    comp = res["unscented_compose"]
    assert (
        comp["chunked_rss_growth_bytes_per_pose"]
        < 0.2 * comp["one_chunk_rss_growth_bytes_per_pose"]
    )
    assert res["kalibr_yaml"]["extrinsics_convert_parses"] == 1
