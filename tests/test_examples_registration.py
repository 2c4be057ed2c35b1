"""examples/registration_loop_closure.py: 200 noisy registrations by small_gicp (and Open3D where
installed) into GTSAM loop-closure factors; liebridge's information is consistent (mean NEES
inside the 95 % χ² bounds; for GICP after inflate="nees"), the copied Hessian and the transposed
order are not."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "registration_loop_closure.py"


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, Path]:
    pytest.importorskip("small_gicp", reason="small_gicp (extra 'registration') not installed")
    out = tmp_path_factory.mktemp("registration")
    proc = subprocess.run(
        [sys.executable, str(EXAMPLE), "--runs", "200", "--out", str(out), "--no-show"],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert proc.returncode == 0, proc.stderr
    return proc.stdout, out


def _rows(text: str) -> dict[tuple[str, str], tuple[float, float, float, str]]:
    rows = {}
    for m in re.finditer(
        r"^(small_gicp GICP|small_gicp|open3d)\s+(\([abc]\)[^\d]+?)"
        r"\s+([\d.]+)\s+([\d.]+)\s+([\d.e+-]+)\s+(yes|no)$",
        text,
        re.M,
    ):
        rows[m[1], m[2].strip()] = (float(m[3]), float(m[4]), float(m[5]), m[6])
    return rows


def test_liebridge_is_consistent_and_the_common_errors_are_not(run) -> None:
    text, _ = run
    lo, hi = (float(x) for x in re.search(r"\[([\d.]+), ([\d.]+)\]", text).groups())
    assert 5.0 < lo < 6.0 < hi < 7.0
    rows = _rows(text)
    libs = {lib for lib, _ in rows}
    assert {"small_gicp", "small_gicp GICP"} <= libs
    for lib in libs - {"small_gicp GICP"}:  # ICP: σ² from the residuals is consistent
        a = rows[lib, "(a) liebridge"]
        b = rows[lib, "(b) Hessian copied"]
        c = rows[lib, "(c) transposed order"]
        assert lo <= a[2] <= hi and a[3] == "yes"
        assert b[2] < lo and b[3] == "no"
        assert c[2] > hi and c[3] == "no"
        # in the graph: the loop closure weighted right gives the smallest error of x2
        assert a[0] < b[0] and a[1] < b[1] and a[1] < c[1]
    # GICP with small_gicp's normalised point covariances: residual σ² alone is over-confident,
    # the held-out NEES calibration is consistent, H copied and the transposed order are not
    g = {name: rows["small_gicp GICP", name] for lib, name in rows if lib == "small_gicp GICP"}
    assert g["(a) residual σ² only"][2] > hi
    assert lo <= g["(a) liebridge, nees"][2] <= hi and g["(a) liebridge, nees"][3] == "yes"
    assert g["(b) Hessian copied"][2] < lo
    assert g["(c) transposed order"][2] > hi
    assert g["(a) liebridge, nees"][1] < g["(b) Hessian copied"][1]


def test_plot_is_written(run) -> None:
    _, out = run
    png = out / "registration_loop_closure.png"
    assert png.exists() and png.stat().st_size > 10_000
