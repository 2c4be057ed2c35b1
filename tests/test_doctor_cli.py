"""``liebridge doctor jacobian|traj``: the diagnosis in words, JSON, exit status, errors."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from liebridge.cli import main
from liebridge.io.trajectory import write_tum
from liebridge.lie import so3

ROOT = Path(__file__).resolve().parents[1]
USER = ROOT / "examples" / "doctor_user_jacobian.py"


def call(capsys, *args):
    try:
        code = main(list(args))
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 0
    out = capsys.readouterr()
    return code, out.out, out.err


def test_jacobian_of_the_example_module(capsys):
    code, out, err = call(capsys, "doctor", "jacobian", f"{USER}:transform")
    assert code == 1, err
    assert out.startswith("verdict: convention_mismatch")
    assert "(v, ω) order" in out and "swap the rotation and translation column blocks" in out
    assert "evidence (max relative error per probe point):" in out
    code, out, _ = call(capsys, "doctor", "jacobian", f"{USER}:transform", "--solver", "sophus")
    assert code == 0 and out.startswith("verdict: correct")


def test_jacobian_json_and_dotted_module(capsys, tmp_path, monkeypatch):
    (tmp_path / "mymod.py").write_text(
        "import numpy as np\n"
        "from liebridge.lie import so3\n"
        "def f(R):\n    return so3.log(R)\n"
        "def jacobian(R):\n    return np.eye(3)\n"
        "point = so3.exp([0.4, -0.2, 0.9])\n"
    )
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    code, out, _ = call(capsys, "doctor", "jacobian", "mymod:f", "--format", " JSON")
    d = json.loads(out)
    assert code == 1 and d["verdict"] == "mistake" and d["cause"] == "jr_inv_omitted"


@pytest.mark.parametrize(
    "args, message",
    [
        (["jacobian", "nomodule_xyz:f"], "MODULE: importing 'nomodule_xyz' raised"),
        (["jacobian", "no-colon"], "TARGET: expected MODULE:FUNCTION"),
        (["jacobian", f"{USER}:nothere"], "has no function 'nothere'"),
        (["jacobian", f"{USER}:transform", "--solver", "gtsm"], "--solver: unknown name"),
        (["traj", "/nonexistent/file.txt"], "FILE: no such file"),
    ],
)
def test_usage_errors_are_one_line(capsys, args, message):
    code, _, err = call(capsys, "doctor", *args)
    assert code == 2 and message in err and err.count("\n") == 1 and "Traceback" not in err


def test_a_function_that_raises_is_one_line(capsys, tmp_path):
    mod = tmp_path / "raising.py"
    mod.write_text("def f(T):\n    raise ZeroDivisionError('boom')\njacobian = None\n")
    code, _, err = call(capsys, "doctor", "jacobian", f"{mod}:f")
    assert code == 2 and "f: raised ZeroDivisionError" in err


def _circle(n=300):
    yaw = np.linspace(0.0, 1.6 * np.pi, n)
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3] = so3.exp(yaw[:, None] * np.array([0.0, 0.0, 1.0]))
    T[:, :3, 3] = np.stack([5 * np.sin(yaw), 5 * (1 - np.cos(yaw)), 0 * yaw], axis=1)
    return np.arange(n) * 0.1, T


def test_traj_clean_and_w_first(capsys, tmp_path):
    stamps, T = _circle()
    write_tum(tmp_path / "ok.tum", stamps, T)
    code, out, _ = call(capsys, "doctor", "traj", str(tmp_path / "ok.tum"))
    assert code == 0 and out.startswith("verdict: ok")
    rows = np.loadtxt(tmp_path / "ok.tum")
    rows[:, 4:8] = rows[:, [7, 4, 5, 6]]  # w first in the xyzw columns
    np.savetxt(tmp_path / "w.tum", rows, header="timestamp tx ty tz qx qy qz qw")
    code, out, _ = call(capsys, "doctor", "traj", str(tmp_path / "w.tum"), "--format", "json")
    d = json.loads(out)
    assert code == 1 and d["cause"] == "quat_order"
    assert d["evidence"]["quat_order"]["order"] == "wxyz"
    # a header that names qw first declares wxyz: no alarm
    np.savetxt(tmp_path / "w2.tum", rows, header="timestamp tx ty tz qw qx qy qz")
    code, out, _ = call(capsys, "doctor", "traj", str(tmp_path / "w2.tum"))
    assert code == 0, out


def test_traj_bad_file_is_one_line(capsys, tmp_path):
    (tmp_path / "bad.tum").write_text("0 1 2 3 0 0 0 1\n1 1 2 x 0 0 0 1\n")
    code, _, err = call(capsys, "doctor", "traj", str(tmp_path / "bad.tum"))
    assert code == 2 and "bad.tum:2: not a number" in err


def test_console_script_runs_without_traceback(tmp_path):
    out = subprocess.run(
        [sys.executable, "-m", "liebridge.cli", "doctor", "jacobian", f"{USER}:transform"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 1 and "verdict: convention_mismatch" in out.stdout
    assert out.stderr == ""


def test_example_script_runs(tmp_path):
    pytest.importorskip("matplotlib")
    out = subprocess.run(
        [
            sys.executable,
            str(ROOT / "examples" / "convention_doctor.py"),
            "--out",
            str(tmp_path),
            "--no-show",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 0, out.stderr
    text = out.stdout
    for title, verdict in [
        ("left Jacobian, GTSAM solver", "convention_mismatch"),
        ("old skew sign", "mistake"),
        ("between residual without Jr⁻¹", "mistake"),
        ("small-angle Jacobian", "small_angle_only"),
        ("inverted residual", "mistake"),
        ("missing adjoint", "mistake"),
        ("w-first TUM file", "alarm"),
        ("SLERP without the hemisphere check", "alarm"),
        ("SLERP with the check", "ok"),
    ]:
        block = text.split(f"== {title}\n", 1)[1]
        assert block.startswith(f"verdict: {verdict}\n"), (title, block[:200])
    assert (tmp_path / "convention_doctor.png").stat().st_size > 10_000


def test_readme_doctor_section_runs():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    quick = readme.split("## Quick start", 1)[1].split("```python", 1)[1].split("```", 1)[0]
    block = readme.split("## The convention doctor", 1)[1].split("```python", 1)[1]
    block = block.split("```", 1)[0]
    ns: dict = {}
    exec(compile(quick, "README quick start", "exec"), ns)  # T_world_body, se3, np
    exec(compile(block, "README doctor", "exec"), ns)
    assert (ns["d"].verdict, ns["d"].cause) == ("convention_mismatch", "right_vs_left")
    assert "Ad_X on the right" in ns["d"].explanation


@pytest.mark.parametrize("sub", [["doctor"], ["doctor", "jacobian"], ["doctor", "traj"]])
def test_help(capsys, sub):
    code, out, _ = call(capsys, *sub, "--help")
    assert code == 0 and out.startswith(f"usage: liebridge {' '.join(sub)}")


def test_doctor_without_a_subcommand_is_a_usage_error(capsys):
    code, _, err = call(capsys, "doctor")
    assert code == 2 and "Traceback" not in err


def test_traj_plot(capsys, tmp_path):
    pytest.importorskip("matplotlib")
    stamps, T = _circle()
    write_tum(tmp_path / "ok.tum", stamps, T)
    code, _, err = call(
        capsys, "doctor", "traj", str(tmp_path / "ok.tum"), "--plot", str(tmp_path / "scan.png")
    )
    assert code == 0 and "wrote" in err
    assert (tmp_path / "scan.png").stat().st_size > 10_000
    code, _, err = call(
        capsys,
        "doctor",
        "traj",
        str(tmp_path / "ok.tum"),
        "--plot",
        str(tmp_path / "nodir" / "scan.png"),
    )
    assert code == 2 and "--plot: directory" in err


PAGES = sorted((ROOT / "docs" / "cookbook").glob("doctor-*.md"))


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.stem)
def test_cookbook_page_shows_what_its_code_prints(page, tmp_path, monkeypatch):
    """The report shown on each symptom page is the one its code prints (verdict lines)."""
    import contextlib
    import io
    import re

    text = page.read_text(encoding="utf-8")
    code = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    shown = re.search(r"Output:\n\n```text\n(.*?)```", text, re.S).group(1)
    monkeypatch.chdir(tmp_path)
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        exec(compile(code, page.name, "exec"), {"__name__": page.stem})
    printed = buf.getvalue()
    assert printed.splitlines()[0] == shown.splitlines()[0]
    assert len(printed.splitlines()) == len(shown.splitlines())


def test_there_is_a_page_per_failure_table_row():
    guide = (ROOT / "docs" / "doctor.md").read_text(encoding="utf-8")
    linked = set(re.findall(r"\(cookbook/(doctor-[a-z0-9-]+)\.md\)", guide))
    assert linked == {p.stem for p in PAGES} and len(linked) >= 10
