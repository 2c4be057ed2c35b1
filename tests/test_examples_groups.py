"""The groups example runs as a script (on this checkout's liebridge) and agrees with Monte Carlo;
the ``liebridge conventions --group`` table lists the new presets by group."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

from liebridge.cli.table import render
from liebridge.conventions import ALL_PRESETS, GROUP_PRESETS, PRESETS

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
