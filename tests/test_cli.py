"""The ``liebridge`` command, run as a subprocess (``python -m liebridge.cli``).

Results are checked against the library (and GTSAM) computing the same thing in-process; bad
input must give one line on stderr naming the problem, a non-zero exit status and no traceback.
The bad-input commands run concurrently (one fixture) to keep the suite fast.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import gtsam
import numpy as np
import pytest

import liebridge as lb
from liebridge.cli import main
from liebridge.conventions import PRESETS

CLI = [sys.executable, "-m", "liebridge.cli"]
POSE3EXAMPLE = gtsam.findExampleDataFile("pose3example.txt")
SPHERE = gtsam.findExampleDataFile("sphere2500.txt")
SUBCOMMANDS = (
    ["conventions"],
    ["detect"],
    ["convert-cov"],
    ["optimize"],
    ["g2o"],
    ["g2o", "convert"],
    ["demo"],
)


def run(*args: str, env: dict[str, str] | None = None, cwd: Path | None = None) -> Any:
    return subprocess.run(
        [*CLI, *args], capture_output=True, text=True, env=env, cwd=cwd, timeout=300
    )


def call(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    """Run ``liebridge ARGS`` in this process (for the many cheap variants): code, out, err."""
    try:
        code = main(list(args))
    except SystemExit as exc:  # argparse: --help, usage errors
        code = exc.code if isinstance(exc.code, int) else 0
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _env_without(fake_dir: Path) -> dict[str, str]:
    """An environment whose PYTHONPATH shadows some modules with ones that fail to import."""
    env = dict(os.environ)
    env["PYTHONPATH"] = str(fake_dir) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def _floats(text: str) -> np.ndarray:
    rows = [line for line in text.splitlines() if line.strip() and not line.startswith("#")]
    return np.array([[float(x) for x in r.split()] for r in rows])


def _field(text: str, name: str) -> str:
    return (
        next(line for line in text.splitlines() if line.startswith(name + ":"))
        .split(":", 1)[1]
        .strip()
    )


POSE_XYZQ = "1.5 -2 0.8 0.1 -0.3 0.2 0.927361849549570"  # xyz then qx qy qz qw (unit)
T_POSE = lb.poses.to_matrix(np.array([float(x) for x in POSE_XYZQ.split()]), layout="xyz_qxyzw")
COV_G = np.diag([1e-3, 2e-3, 3e-3, 0.04, 0.05, 0.06])
COV_G[0, 4] = COV_G[4, 0] = 1e-3


def _cov_text(C: np.ndarray) -> str:
    return " ".join(repr(float(x)) for x in C.reshape(-1))


# --------------------------------------------------------------------------- help, version, demo


@pytest.mark.parametrize("sub", SUBCOMMANDS, ids=[" ".join(s) for s in SUBCOMMANDS])
def test_help_on_every_subcommand(sub: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = call(capsys, *sub, "--help")
    assert code == 0
    assert out.startswith(f"usage: liebridge {' '.join(sub)}")


def test_top_level_help_lists_subcommands() -> None:
    out = run("--help")
    assert out.returncode == 0
    for name in ("conventions", "detect", "convert-cov", "optimize", "g2o", "demo"):
        assert name in out.stdout
    assert run().stdout == out.stdout  # no subcommand: the same help


# --------------------------------------------------------------------------- conventions


def test_conventions_table_and_json(capsys: pytest.CaptureFixture[str]) -> None:
    code, table, _ = call(capsys, "conventions")
    assert code == 0
    lines = table.splitlines()
    assert lines[0].split() == ["name", "side", "order", "chart", "rotation", "quat", "evidence"]
    for c in PRESETS:
        row = next(line for line in lines if line.split()[0] == c.name)
        assert row.split()[1:6] == [c.side, c.order, c.chart, c.rotation, c.quat_order]
    data = json.loads(run("conventions", "--format", "json").stdout)
    assert [d["name"] for d in data] == [c.name for c in PRESETS]
    for d, c in zip(data, PRESETS, strict=True):
        assert (d["side"], d["order"], d["chart"], d["rotation"], d["quat_order"]) == (
            c.side,
            c.order,
            c.chart,
            c.rotation,
            c.quat_order,
        )
        assert d["source"] == c.source and d["notes"] == c.notes


def test_conventions_one_preset_in_full(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = call(capsys, "conventions", "ros")
    assert code == 0
    assert "ros: side=left, order=trans_first, chart=so3xr3_world" in out
    assert "linear to first order only" in out
    assert lb.conventions.ROS.source in out
    code, out, _ = call(capsys, "conventions", "symforce", "--format", "json")
    assert code == 0
    d = json.loads(out)
    assert (d["name"], d["chart"], d["order"]) == ("symforce", "so3xr3_world", "rot_first")


# --------------------------------------------------------------------------- detect


def test_detect_all_installed_libraries() -> None:
    out = run("detect", "all")
    assert out.returncode == 0, out.stdout + out.stderr  # 1 would mean a preset is contradicted
    assert "DIFFERS" not in out.stdout
    for probe, preset in (
        ("pin.integrate on a free-flyer joint", "pinocchio"),
        ("(R3 × SO3).integrate", "pinocchio_r3xso3"),
        ("sym.Pose3.retract", "symforce"),
        ("(body twist)", "mr_body"),
        ("(space twist)", "mr_space"),
        ("concat_globally_uncertain_transforms", "pytransform3d_global"),
    ):
        block = next(b for b in out.stdout.split("\n\n") if probe in b)
        assert f"=> agrees with preset {preset!r}" in block, block
    gtsam_block = next(b for b in out.stdout.split("\n\n") if "gtsam.Pose3.retract" in b)
    assert "=> agrees with preset 'gtsam'" in gtsam_block
    assert "quaternion storage: wxyz via Rot3.Quaternion" in gtsam_block
    assert "quaternion storage: xyzw via Rot3.toQuaternion().coeffs()" in gtsam_block
    scipy_block = next(b for b in out.stdout.split("\n\n") if "RigidTransform" in b)
    assert "no preset for scipy" in scipy_block and "rot_first" in scipy_block


def test_detect_list(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = call(capsys, "detect", "--list")
    assert code == 0
    assert "pinocchio (also: pin): pip install pin" in out


# --------------------------------------------------------------------------- convert-cov


def test_convert_cov_matches_library_and_is_a_permutation_for_sophus() -> None:
    out = run(
        "convert-cov",
        "--from",
        "gtsam",
        "--to",
        "sophus",
        "--pose",
        POSE_XYZQ,
        "--layout",
        "xyz_qxyzw",
        "--cov",
        _cov_text(COV_G),
    )
    assert out.returncode == 0, out.stderr
    assert "# conversion: exact" in out.stdout
    P = np.block([[np.zeros((3, 3)), np.eye(3)], [np.eye(3), np.zeros((3, 3))]])
    np.testing.assert_allclose(_floats(out.stdout), P @ COV_G @ P, rtol=0, atol=1e-18)


def test_convert_cov_files_batches_and_information(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    T = lb.lie.se3.exp(rng.normal(size=(3, 6)))
    A = rng.normal(size=(3, 6, 6))
    C = A @ A.transpose(0, 2, 1) * 1e-3 + np.eye(6) * 1e-4
    np.save(tmp_path / "T.npy", T)
    np.save(tmp_path / "C.npy", C)
    out = run(
        "convert-cov",
        "--from",
        "gtsam",
        "--to",
        "barfoot",
        "--pose",
        str(tmp_path / "T.npy"),
        "--cov",
        str(tmp_path / "C.npy"),
        "--out",
        str(tmp_path / "out.npy"),
    )
    assert out.returncode == 0, out.stderr
    got = np.load(tmp_path / "out.npy")
    np.testing.assert_array_equal(got, lb.convert_covariance(C, T, "gtsam", "barfoot"))
    # information: Λ_B = M⁻ᵀ Λ_A M⁻¹, the inverse of the converted covariance; text output
    np.save(tmp_path / "I.npy", np.linalg.inv(C))
    out = run(
        "convert-cov",
        "--from",
        "gtsam",
        "--to",
        "barfoot",
        "--pose",
        str(tmp_path / "T.npy"),
        "--cov",
        str(tmp_path / "I.npy"),
        "--information",
        "--out",
        str(tmp_path / "info.txt"),
    )
    assert out.returncode == 0, out.stderr
    blocks = _floats((tmp_path / "info.txt").read_text()).reshape(3, 6, 6)
    np.testing.assert_allclose(blocks, np.linalg.inv(got), rtol=1e-8)


def test_convert_cov_unscented(capsys: pytest.CaptureFixture[str]) -> None:
    """Across a chart change (g2o): the library's sigma-point result, and the header says so."""
    code, out, err = call(
        capsys,
        "convert-cov",
        "--from",
        "gtsam",
        "--to",
        "g2o",
        "--pose",
        POSE_XYZQ,
        "--layout",
        "xyz_qxyzw",
        "--cov",
        _cov_text(COV_G),
        "--method",
        "unscented",
    )
    assert code == 0, err
    how = next(line for line in out.splitlines() if line.startswith("# conversion:"))
    assert "unscented" in how and "first order" not in how  # one method named, not two
    want = lb.convert_covariance(COV_G, T_POSE, "gtsam", "g2o", method="unscented")
    # rounding-level entries (|correlation| ≤ 16 ε) are printed as exact zeros
    np.testing.assert_allclose(_floats(out), want, rtol=1e-12, atol=4e-15 * np.abs(want).max())


def test_convert_cov_diagonal_shorthand_and_matrix_pose(
    capsys: pytest.CaptureFixture[str],
) -> None:
    pose = " ".join(repr(float(x)) for x in T_POSE.reshape(-1))
    code, out, err = call(
        capsys,
        "convert-cov",
        "--from",
        "gtsam",
        "--to",
        "ros",
        "--pose",
        pose,
        "--cov",
        "1 2 3 4 5 6",
    )
    assert code == 0, err
    want = lb.convert_covariance(np.diag([1.0, 2, 3, 4, 5, 6]), T_POSE, "gtsam", "ros")
    np.testing.assert_allclose(_floats(out), want, rtol=1e-12, atol=1e-15)


# --------------------------------------------------------------------------- optimize


@pytest.fixture(scope="module")
def edge3_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The first 100 poses of sphere2500.txt: 149 EDGE3 lines, loop closures included."""
    lines = []
    for line in Path(SPHERE).read_text().splitlines():
        f = line.split()
        if f and f[0] == "EDGE3" and int(f[1]) < 100 and int(f[2]) < 100:
            lines.append(line)
    path = tmp_path_factory.mktemp("edge3") / "sphere100.txt"
    path.write_text("\n".join(lines) + "\n")
    return path


def _gtsam_lm(graph: Any, values: Any) -> tuple[float, Any]:
    p = gtsam.LevenbergMarquardtParams()
    res = gtsam.LevenbergMarquardtOptimizer(graph, values, p).optimize()
    return float(graph.error(res)), res


def test_optimize_gtsam_reading_equals_gtsams_own_pipeline() -> None:
    """``--information gtsam`` on pose3example.txt: what readG2o + GTSAM's LM give."""
    out = run("optimize", "pose3example.txt", "--information", "gtsam")
    assert out.returncode == 0, out.stderr
    graph, values = gtsam.readG2o(POSE3EXAMPLE, True)
    graph.add(
        gtsam.PriorFactorPose3(0, values.atPose3(0), gtsam.noiseModel.Isotropic.Sigma(6, 1e-4))
    )
    final, _ = _gtsam_lm(graph, values)
    assert float(_field(out.stdout, "initial error")) == pytest.approx(graph.error(values))
    assert float(_field(out.stdout, "final error")) == pytest.approx(final, rel=1e-6)
    assert int(_field(out.stdout, "iterations").split()[0]) >= 1
    assert "timings:" in out.stdout


def test_optimize_in_barfoot_matches_gtsam_and_writes_marginals_and_plot(
    edge3_file: Path, tmp_path: Path
) -> None:
    """Barfoot's conversion is exact: the same optimum as GTSAM's native graph; marginals in
    Barfoot's tangent are GTSAM's converted with P·Ad."""
    ref = run("optimize", str(edge3_file), "--marginals", str(tmp_path / "g.npy"))
    out = run(
        "optimize",
        str(edge3_file),
        "--convention",
        "barfoot",
        "--marginals",
        str(tmp_path / "b.npy"),
        "--plot",
        str(tmp_path / "traj.png"),
    )
    assert ref.returncode == 0 and out.returncode == 0, ref.stderr + out.stderr
    assert "graph: 100 poses, 149 edges" in out.stdout and "chained from the odometry" in out.stdout
    assert "native BetweenFactorPose3" in out.stdout
    assert float(_field(out.stdout, "final error")) == pytest.approx(
        float(_field(ref.stdout, "final error")), rel=1e-6
    )
    assert "iteration" in out.stderr  # progress
    g, b = np.load(tmp_path / "g.npy"), np.load(tmp_path / "b.npy")
    assert g.shape == b.shape == (100, 6, 6)
    # the optimum, in-process, as the default run builds it
    graph = lb.g2o.read(edge3_file)
    fg, values = graph.to_gtsam(prior=None)
    fg.add(gtsam.PriorFactorPose3(0, gtsam.Pose3(), gtsam.noiseModel.Isotropic.Sigma(6, 1e-4)))
    res = lb.factors.optimize(fg, values, progress=False)
    T = lb.gtsam_glue.from_values(res.values, graph.vertex_ids.tolist())
    want = lb.convert_covariance(g, T, "gtsam", "barfoot")
    scale = np.abs(want).max(axis=(1, 2), keepdims=True)
    assert (np.abs(b - want) / scale).max() < 1e-4
    naive = np.abs(b - g[:, [3, 4, 5, 0, 1, 2]][:, :, [3, 4, 5, 0, 1, 2]]) / scale
    assert naive[-1].max() > 0.1  # the reordered copy without the adjoint is far off
    png = tmp_path / "traj.png"
    assert png.is_file() and png.stat().st_size > 10_000


def test_optimize_custom_factor_convention(edge3_file: Path) -> None:
    """symforce's chart is not GTSAM's (world-frame translation): custom factors, its own
    objective — a different but nearby optimum (within 0.1 % of GTSAM's final error here)."""
    out = run("optimize", str(edge3_file), "--convention", "symforce", "--max-iterations", "50")
    ref = run("optimize", str(edge3_file), "--max-iterations", "50")
    assert out.returncode == 0 and ref.returncode == 0, out.stderr + ref.stderr
    assert "liebridge custom factors" in out.stdout
    assert "converged: yes" in out.stdout
    final, final_ref = (float(_field(o.stdout, "final error")) for o in (out, ref))
    assert final < 0.01 * float(_field(out.stdout, "initial error"))
    assert final == pytest.approx(final_ref, rel=1e-3)
    assert final != final_ref


def test_optimize_default_is_sphere2500_from_gtsam_data() -> None:
    out = run("optimize", "--dry-run")
    assert out.returncode == 0, out.stderr
    assert Path(_field(out.stdout, "file")) == Path(SPHERE)
    assert "graph: 2500 poses, 4949 edges" in out.stdout
    assert "dry run" in out.stdout


# --------------------------------------------------------------------------- g2o convert


def test_g2o_convert_makes_a_file_gtsam_reads_correctly(tmp_path: Path) -> None:
    out_file = tmp_path / "for_gtsam.g2o"
    out = run("g2o", "convert", POSE3EXAMPLE, str(out_file), "--information", "g2o:gtsam")
    assert out.returncode == 0, out.stderr
    assert "max |difference| 0" in out.stdout
    want = lb.g2o.read(POSE3EXAMPLE, information="g2o").information
    graph, _ = gtsam.readG2o(str(out_file), True)
    got = np.stack(
        [np.linalg.inv(graph.at(k).noiseModel().covariance()) for k in range(graph.size())]
    )
    np.testing.assert_allclose(got, want, rtol=1e-9)
    # and back: the original numbers' information, bit for bit
    back = tmp_path / "back.g2o"
    out = run("g2o", "convert", str(out_file), str(back), "--information", "gtsam:g2o")
    assert out.returncode == 0, out.stderr
    np.testing.assert_array_equal(lb.g2o.read(back, information="g2o").information, want)


# --------------------------------------------------------------------------- bad input


#: Bad input run as real processes (one per subcommand at least; the environment ones must be).
SUBPROCESS_CASES = {
    "conventions-unknown",
    "detect-not-installed",
    "convert-cov-not-spd",
    "optimize-bad-file",
    "optimize-no-matplotlib",
    "g2o-convert-pair",
}


def _bad_cases(tmp: Path) -> dict[str, tuple[list[str], str, dict[str, str] | None]]:
    """name -> (arguments, expected stderr fragment, environment)."""
    fake = tmp / "fake"
    for mod in ("matplotlib", "pinocchio"):
        (fake / mod).mkdir(parents=True, exist_ok=True)
        (fake / mod / "__init__.py").write_text(
            f'raise ModuleNotFoundError("No module named {mod!r}", name={mod!r})\n'
        )
    env = _env_without(fake)
    bad_file = tmp / "bad.g2o"
    info = " ".join(["1"] * 20 + ["oops"])
    bad_file.write_text(
        "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 1 0 0 0 0 0 1\n"
        f"EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 {info}\n"
    )
    disconnected = tmp / "disconnected.g2o"
    edge_info = " ".join(repr(float(x)) for x in np.eye(6)[np.triu_indices(6)])
    disconnected.write_text(
        "".join(f"VERTEX_SE3:QUAT {k} {k} 0 0 0 0 0 1\n" for k in range(4))
        + f"EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 {edge_info}\n"
        + f"EDGE_SE3:QUAT 2 3 1 0 0 0 0 0 1 {edge_info}\n"
    )
    not_spd = np.eye(6)
    not_spd[0, 0] = -1e-2
    pose = ["--pose", POSE_XYZQ, "--layout", "xyz_qxyzw"]
    cc = ["convert-cov", "--from", "gtsam", "--to", "sophus"]
    out = str(tmp / "o.g2o")
    return {
        "conventions-unknown": (
            ["conventions", "sophsu"],
            "NAME: unknown name 'sophsu'; did you mean 'sophus'?",
            None,
        ),
        "conventions-format": (["conventions", "--format", "xml"], "invalid choice: 'xml'", None),
        "detect-unknown": (["detect", "pinochio"], "unknown library 'pinochio'", None),
        "detect-no-library": (["detect"], "give a LIBRARY (or 'all')", None),
        "detect-not-installed": (
            ["detect", "pin"],
            "pinocchio is not installed (pip install pin)",
            env,
        ),
        "convert-cov-unknown-convention": (
            ["convert-cov", "--from", "gtsam", "--to", "rso", *pose, "--cov", "1 1 1 1 1 1"],
            "--to: unknown name 'rso'; did you mean 'ros'?",
            None,
        ),
        "convert-cov-not-spd": (
            [*cc, *pose, "--cov", _cov_text(not_spd)],
            "--cov: not positive semi-definite",
            None,
        ),
        "convert-cov-not-symmetric": (
            [*cc, *pose, "--cov", _cov_text(np.eye(6) + np.triu(np.ones((6, 6)), 1))],
            "--cov: not symmetric",
            None,
        ),
        "convert-cov-no-layout": (
            [*cc, "--pose", POSE_XYZQ, "--cov", "1 1 1 1 1 1"],
            "need --layout",
            None,
        ),
        "convert-cov-quaternion-norm": (
            [*cc, "--pose", "0 0 0 0 0 0.5 0.5", "--layout", "xyz_qxyzw", "--cov", "1 1 1 1 1 1"],
            "--pose (layout 'xyz_qxyzw'): quaternion norm off by",
            None,
        ),
        "convert-cov-not-a-rotation": (
            [*cc, "--pose", " ".join(["1"] * 12 + ["0", "0", "0", "1"]), "--cov", "1 1 1 1 1 1"],
            "--pose: not a rotation",
            None,
        ),
        "convert-cov-not-a-number": (
            [*cc, *pose, "--cov", "1 1 x 1 1 1"],
            "--cov: not a number: 'x'",
            None,
        ),
        "convert-cov-count": ([*cc, *pose, "--cov", "1 2 3 4"], "expected 36 numbers", None),
        "convert-cov-missing-file": (
            [*cc, "--pose", "missing.npy", "--cov", "1 1 1 1 1 1"],
            "--pose: no such file: missing.npy",
            None,
        ),
        "convert-cov-unscented-information": (
            [*cc, *pose, "--cov", "1 1 1 1 1 1", "--information", "--method", "unscented"],
            "--method unscented applies to covariances",
            None,
        ),
        "optimize-missing-file": (
            ["optimize", str(tmp / "nothere.g2o")],
            "no such file:",
            None,
        ),
        "optimize-bad-file": (["optimize", str(bad_file)], "bad.g2o:3: not a number: 'oops'", None),
        "optimize-disconnected": (
            ["optimize", str(disconnected), "--out-cov", str(tmp / "m.npy")],
            "the graph is not connected: 2 vertices (2, 3) have no path of edges",
            None,
        ),
        "optimize-unknown-convention": (
            ["optimize", "pose3example.txt", "--convention", "barfot"],
            "--convention: unknown name 'barfot'; did you mean 'barfoot'?",
            None,
        ),
        "optimize-no-matplotlib": (
            ["optimize", "pose3example.txt", "--plot", str(tmp / "x.png")],
            'plotting needs matplotlib, an optional extra: pip install ".[plot]" from the checkout',
            env,
        ),
        "optimize-plot-suffix": (
            ["optimize", "pose3example.txt", "--plot", str(tmp / "x.txt")],
            "--plot: unsupported file type '.txt'",
            None,
        ),
        "optimize-plot-directory": (
            ["optimize", "pose3example.txt", "--plot", str(tmp / "no" / "x.png")],
            "--plot: directory",
            None,
        ),
        "optimize-iterations": (
            ["optimize", "--max-iterations", "0"],
            "expected a positive integer, got 0",
            None,
        ),
        "g2o-convert-pair": (
            ["g2o", "convert", POSE3EXAMPLE, out, "--information", "g2o"],
            "expected FROM:TO",
            None,
        ),
        "g2o-convert-missing": (
            ["g2o", "convert", str(tmp / "none.g2o"), out, "--information", "g2o:gtsam"],
            "IN: no such file",
            None,
        ),
        "g2o-convert-bad-file": (
            ["g2o", "convert", str(bad_file), out, "--information", "g2o:gtsam"],
            "bad.g2o:3: not a number: 'oops'",
            None,
        ),
        "g2o-convert-same-file": (
            ["g2o", "convert", str(bad_file), str(bad_file), "--information", "g2o:gtsam"],
            "OUT is the input file",
            None,
        ),
        "g2o-no-subcommand": (["g2o"], "missing SUBCOMMAND", None),
    }


@pytest.fixture(scope="module")
def bad_tmp(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("bad")


@pytest.fixture(scope="module")
def subprocess_results(bad_tmp: Path) -> dict[str, tuple[int, str, str]]:
    """The subprocess cases, started together and collected (they are independent)."""
    cases = _bad_cases(bad_tmp)
    procs = {
        name: subprocess.Popen(
            [*CLI, *cases[name][0]],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=cases[name][2],
            cwd=bad_tmp,
        )
        for name in sorted(SUBPROCESS_CASES)
    }
    out = {}
    for name, p in procs.items():
        stdout, stderr = p.communicate(timeout=300)
        out[name] = (p.returncode, stdout, stderr)
    return out


def _case_names() -> list[str]:
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        return list(_bad_cases(Path(d)))


@pytest.mark.parametrize("name", _case_names())
def test_bad_input_is_one_line_and_nonzero_exit(
    name: str,
    bad_tmp: Path,
    subprocess_results: dict[str, tuple[int, str, str]],
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    args, fragment, _ = _bad_cases(bad_tmp)[name]
    if name in SUBPROCESS_CASES:
        code, stdout, stderr = subprocess_results[name]
        assert "Traceback" not in stderr
    else:
        monkeypatch.chdir(bad_tmp)
        code, stdout, stderr = call(capsys, *args)
    assert code == 2, (code, stdout, stderr)
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    assert lines[0].startswith("liebridge ") and ": error: " in lines[0], lines[0]
    assert fragment in lines[0], lines[0]
