"""Every example runs as a script on small inputs, prints what its docstring promises, and
writes its plot (checked for existence and size). The four runs start together.

Also here (folded in from its twin file): The groups example runs as a script (on this checkout's
liebridge) and agrees with Monte Carlo;.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from liebridge.cli.table import render
from liebridge.conventions import ALL_PRESETS, GROUP_PRESETS, PRESETS

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


# --------------------------------------------------------------------------- examples_groups
# The groups example runs as a script (on this checkout's liebridge) and agrees with Monte Carlo;
# the ``liebridge conventions --group`` table lists the new presets by group.

ROOT = Path(__file__).resolve().parents[1]


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    return env


def test_groups_example_runs() -> None:
    proc = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "groups_pose2_sim3_navstate.py"), "--samples",
         "40000"],
        capture_output=True, text=True, timeout=300, env=_env(), check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "all within Monte Carlo noise" in proc.stdout
    diffs = [float(x) for x in re.findall(r"([0-9.]+)%", proc.stdout)]
    assert len(diffs) == 4 and max(diffs) < 5.0


def test_conventions_table_by_group() -> None:
    text = render("table", "all")
    for c in ALL_PRESETS:
        assert re.search(rf"^{c.name}\s", text, re.M), c.name
    md = render("markdown", "all")
    assert md.count("#### ") == len({c.group for c in ALL_PRESETS})
    assert render("markdown") == render("markdown", None)  # default: SE(3) table, as before
    se2 = [line.split()[0] for line in render("table", "se2").splitlines()[2:]]
    assert se2 == [c.name for c in GROUP_PRESETS if c.group == "se2"]
    proc = subprocess.run(
        [sys.executable, "-m", "liebridge.cli", "conventions", "--group", "sim3"],
        capture_output=True, text=True, env=_env(), check=True,
    )  # fmt: skip
    names = [line.split()[0] for line in proc.stdout.splitlines()[2:] if line.strip()]
    assert names == [c.name for c in GROUP_PRESETS if c.group == "sim3"]
    assert len(PRESETS) + len(GROUP_PRESETS) == len(ALL_PRESETS)
    one = subprocess.run(
        [sys.executable, "-m", "liebridge.cli", "conventions", "manif_se23"],
        capture_output=True, text=True, env=_env(), check=True,
    ).stdout  # fmt: skip
    assert "manif_se23 (se23)" in one and "from gtsam_navstate's tangent: linear to first" in one
