"""Every example runs as a script on small inputs, prints what its docstring promises, and
writes its plot (checked for existence and size). The four runs start together."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

#: name -> (script, arguments, PNG written or None)
RUNS: dict[str, tuple[str, list[str], str | None]] = {
    "pose_graph": ("pose_graph.py", ["--max-poses", "100", "--no-show"], "pose_graph.png"),
    "covariance_between_libraries": (
        "covariance_between_libraries.py",
        ["--max-poses", "100", "--samples", "500", "--no-show"],
        "covariance_between_libraries.png",
    ),
    "left_jacobian_code": (
        "left_jacobian_code.py",
        ["--points", "100", "--no-show"],
        "left_jacobian_code.png",
    ),
    "detect_conventions": ("detect_conventions.py", [], None),
}


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Any, Path]]:
    procs = {}
    for name, (script, args, _) in RUNS.items():
        out = tmp_path_factory.mktemp(name)
        cmd = [sys.executable, str(EXAMPLES / script), *args]
        if RUNS[name][2] is not None:
            cmd += ["--out", str(out)]
        procs[name] = (
            subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True),
            out,
        )
    results = {}
    for name, (p, out) in procs.items():
        stdout, stderr = p.communicate(timeout=600)
        results[name] = (subprocess.CompletedProcess(p.args, p.returncode, stdout, stderr), out)
    return results


def _num(pattern: str, text: str) -> float:
    m = re.search(pattern, text)
    assert m, f"{pattern!r} not in:\n{text}"
    return float(m.group(1))


@pytest.mark.parametrize("name", list(RUNS))
def test_example_runs_and_writes_its_plot(name: str, runs: dict[str, tuple[Any, Path]]) -> None:
    proc, out = runs[name]
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr
    png = RUNS[name][2]
    if png is not None:
        path = out / png
        assert path.is_file(), proc.stdout
        assert path.stat().st_size > 10_000
        assert f"plot: {path}" in proc.stdout


def test_pose_graph_barfoot_reaches_gtsams_optimum(runs: dict[str, tuple[Any, Path]]) -> None:
    text = runs["pose_graph"][0].stdout
    ref = _num(r"GTSAM \(native factors, GTSAM's LM\): final error (\S+),", text)
    ours = _num(r"GTSAM's objective there (\S+);", text)
    assert ours == pytest.approx(ref, rel=1e-6)
    assert _num(r"barfoot through ConventionGraph.*max position gap to GTSAM (\S+) m", text) < 1e-6
    assert _num(r"naive copy.*max position gap to GTSAM (\S+) m", text) > 0.5


def test_covariance_example_converted_matches_monte_carlo(
    runs: dict[str, tuple[Any, Path]],
) -> None:
    text = runs["covariance_between_libraries"][0].stdout
    rows = {
        m.group(1): m.group(2).split()
        for m in re.finditer(r"^  (sophus|barfoot|ros|symforce)\s+(.*)$", text, re.M)
    }
    assert set(rows) == {"sophus", "barfoot", "ros", "symforce"}
    for name, cells in rows.items():
        exact, converted, naive = cells[0], float(cells[1]), float(cells[2])
        assert exact == ("yes" if name in ("sophus", "barfoot") else "no")
        assert converted < 0.6, (name, cells)  # 500 samples: sampling noise ≈ 0.2–0.4
        assert naive > 3.0, (name, cells)
        if name in ("barfoot", "ros"):  # the reorder alone is not the conversion
            assert float(cells[3]) > 3.0, (name, cells)


def test_left_jacobian_example(runs: dict[str, tuple[Any, Path]]) -> None:
    text = runs["left_jacobian_code"][0].stdout
    assert _num(r"J_left vs FD through barfoot.retract\s+(\S+)", text) < 1e-6
    assert _num(r"converted vs FD through gtsam.Pose3.retract\s+(\S+)", text) < 1e-6
    assert _num(r"pasted J_left vs FD through gtsam.Pose3.retract\s+(\S+)", text) > 1.0
    floor = _num(r"cost at the true pose: (\S+)", text)
    assert _num(r"converted\s+cost \S+ -> (\S+)", text) <= floor * 1.01
    assert _num(r"pasted J_left\s+cost \S+ -> (\S+)", text) > 100 * floor


def test_detect_example(runs: dict[str, tuple[Any, Path]]) -> None:
    text = runs["detect_conventions"][0].stdout
    assert "0 differing from their preset" in text
    assert "agrees    gtsam: gtsam.Pose3.retract" in text
    assert "my_ros_style_retract -> ros:" in text
    assert "my_buggy_retract -> no convention of the model" in text
