"""``liebridge traj``: one JSON object on stdout, plots, and one clear line per bad input."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from _traj_data import noisy_pair
from test_traj_nees import KNOWN, simulate

from liebridge import conventions as C
from liebridge.cli import main
from liebridge.io import trajfile

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli")
    t_ref, T_ref, t_est, T_est = noisy_pair(n=300)
    trajfile.write_trajectory(d / "ref.txt", t_ref, T_ref)
    trajfile.write_trajectory(d / "est.txt", t_est, T_est)
    return d


def _run(args):
    return subprocess.run(
        [sys.executable, "-m", "liebridge.cli", *args],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )


def test_json_is_one_object_alone_on_stdout(pair):
    r = _run(
        [
            "traj",
            "rpe",
            str(pair / "ref.txt"),
            str(pair / "est.txt"),
            "--align",
            "se3",
            "--delta",
            "3",
            "--unit",
            "frames",
            "--format",
            "json",
        ]
    )
    assert r.returncode == 0, r.stderr
    obj = json.loads(r.stdout)
    assert {"rmse", "mean", "median", "std", "min", "max"} <= set(obj)
    assert r.stdout.strip().count("\n") == 0


@pytest.mark.parametrize("kind", ["se3", "sim3", "4dof", "none"])
def test_nees_cli_consistent_and_wrong_convention(tmp_path, capsys, kind):
    from liebridge import conventions as C

    conv = C.get("ros")
    T_ref, T_est, cov = simulate(conv, n=400, sig_t=(0.05, 0.08, 0.12), sig_r=(1e-3, 2e-3, 3e-3))
    if kind == "none":
        T_ref = np.linalg.inv(KNOWN.matrix) @ T_ref
    t = np.arange(400) * 0.1
    trajfile.write_trajectory(tmp_path / "ref.txt", t, T_ref)
    trajfile.write_trajectory(tmp_path / "est.txt", t, T_est)
    np.save(tmp_path / "cov.npy", cov)
    args = [
        "traj",
        "nees",
        str(tmp_path / "ref.txt"),
        str(tmp_path / "est.txt"),
        "--align",
        kind,
        "--cov",
        str(tmp_path / "cov.npy"),
        "--format",
        "json",
    ]
    assert main([*args, "--convention", "ros"]) == 0
    good = json.loads(capsys.readouterr().out)
    assert main([*args, "--convention", "gtsam"]) == 0
    bad = json.loads(capsys.readouterr().out)
    if kind != "4dof":  # the simulated frame change is not a yaw: 4-DoF cannot undo it
        assert good["anees_lower"] <= good["anees"] <= good["anees_upper"], good
    assert bad["anees"] > bad["anees_upper"]


def test_plots(pair, tmp_path, capsys):
    pytest.importorskip("matplotlib")
    for sub, extra in (("ape", []), ("rpe", ["--delta", "2"])):
        out = tmp_path / f"{sub}.png"
        assert (
            main(
                [
                    "traj",
                    sub,
                    str(pair / "ref.txt"),
                    str(pair / "est.txt"),
                    "--align",
                    "se3",
                    "--plot",
                    str(out),
                    *extra,
                ]
            )
            == 0
        )
        assert out.stat().st_size > 10_000
    T_ref, T_est, cov = simulate(C.get("gtsam"), n=100)
    t = np.arange(100) * 0.1
    trajfile.write_trajectory(tmp_path / "r.txt", t, T_ref)
    trajfile.write_trajectory(tmp_path / "e.txt", t, T_est)
    np.save(tmp_path / "c.npy", cov)
    out = tmp_path / "nees.png"
    assert (
        main(
            [
                "traj",
                "nees",
                str(tmp_path / "r.txt"),
                str(tmp_path / "e.txt"),
                "--cov",
                str(tmp_path / "c.npy"),
                "--convention",
                "gtsam",
                "--align",
                "se3",
                "--plot",
                str(out),
            ]
        )
        == 0
    )
    assert out.stat().st_size > 10_000


def _bad(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def test_bad_input_one_line_each(pair, tmp_path):
    ref = str(pair / "ref.txt")
    far = _bad(tmp_path, "far.txt", "".join(f"{1e6 + i} 0 0 0 0 0 0 1\n" for i in range(5)))
    back = _bad(tmp_path, "back.txt", "0 0 0 0 0 0 0 1\n0.2 1 0 0 0 0 0 1\n0.1 2 0 0 0 0 0 1\n")
    two = _bad(tmp_path, "two.txt", "100.0 0 0 0 0 0 0 1\n100.1 1 0 0 0 0 0 1\n")
    np.save(tmp_path / "short.npy", np.tile(np.eye(6), (149, 1, 1)))
    (tmp_path / "empty.npy").write_bytes(b"")
    cases = [
        (["ape", ref, far], "no overlapping timestamps"),
        (["ape", ref, back], "not strictly increasing: stamp 2 (0.1) goes back in time"),
        (["ape", ref, two, "--align", "se3"], "needs at least 3 associated poses, got 2"),
        (
            [
                "nees",
                ref,
                str(pair / "est.txt"),
                "--cov",
                str(tmp_path / "short.npy"),
                "--convention",
                "gtsam",
            ],
            "--cov: 149 covariances for 150 poses of EST",
        ),
        (
            [
                "nees",
                ref,
                str(pair / "est.txt"),
                "--cov",
                str(tmp_path / "short.npy"),
                "--convention",
                "gtsm",
            ],
            "did you mean 'gtsam'",
        ),
        (["ape", ref, str(tmp_path / "missing.txt")], "no such file"),
        (
            [
                "nees",
                ref,
                str(pair / "est.txt"),
                "--cov",
                str(tmp_path / "empty.npy"),
                "--convention",
                "gtsam",
            ],
            "--cov: cannot read",
        ),
        (["rpe", ref, str(pair / "est.txt"), "--delta", "1000"], "gives no pose pair"),
    ]
    for args, msg in cases:
        r = _run(["traj", *args])
        assert r.returncode == 2, (args, r.stdout, r.stderr)
        assert r.stdout == ""
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1, r.stderr
        assert msg in lines[0], lines[0]
        assert "Traceback" not in r.stderr
