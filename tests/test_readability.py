"""A newcomer's first hour: option values, short reprs, exact zeros, help texts."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import liebridge as lb
from liebridge.lie import quaternion as Q
from liebridge.lie import se3

ROOT = Path(__file__).resolve().parents[1]


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "liebridge.cli", *args],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"},
        timeout=300,
    )


G2O_TEXT = (
    "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n"
    "VERTEX_SE3:QUAT 1 1 0 0 0 0 0.0998334 0.9950042\n"
    "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0.0998334 0.9950042 "
    "100 0 0 0 0 0 100 0 0 0 0 100 0 0 0 400 0 0 400 0 400\n"
)


# ------------------------------------------------------------------- one rule for string options
def test_every_string_option_ignores_case_and_surrounding_spaces(tmp_path: Path) -> None:
    f = tmp_path / "g.g2o"
    f.write_text(G2O_TEXT)
    ref = lb.g2o.read(f, information="gtsam").information
    np.testing.assert_array_equal(lb.g2o.read(f, information=" GTSAM ").information, ref)  # type: ignore[arg-type]
    X, C = se3.exp(np.full(6, 0.2)), np.diag([1e-2] * 6)
    np.testing.assert_array_equal(
        lb.convert_covariance(C, X, "gtsam", "g2o", method="Unscented"),  # type: ignore[arg-type]
        lb.convert_covariance(C, X, "gtsam", "g2o", method="unscented"),
    )
    np.testing.assert_array_equal(
        lb.convert_covariance(C, X, " GTSAM", "Sophus ", method=" LINEAR"),  # type: ignore[arg-type]
        lb.convert_covariance(C, X, "gtsam", "sophus"),
    )
    np.testing.assert_array_equal(
        Q.from_matrix(X[:3, :3], order="XYZW"), Q.from_matrix(X[:3, :3], order="xyzw")
    )  # type: ignore[arg-type]
    x = np.array([1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0])
    np.testing.assert_array_equal(
        lb.poses.to_matrix(x, layout="XYZ_QXYZW"), lb.poses.to_matrix(x, layout="xyz_qxyzw")
    )
    # what is not a value still fails, naming the option
    with pytest.raises(ValueError, match=r"information: expected 'g2o' or 'gtsam', got 'gtsam2'"):
        lb.g2o.read(f, information="gtsam2")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"method: expected 'linear' or 'unscented', got 3"):
        lb.convert_covariance(C, X, "gtsam", "g2o", method=3)  # type: ignore[arg-type]


def test_command_line_option_values_ignore_case(tmp_path: Path) -> None:
    f = tmp_path / "g.g2o"
    f.write_text(G2O_TEXT)
    out = cli("g2o", "convert", str(f), str(tmp_path / "o.g2o"), "--information", "G2O:GTSAM")
    assert out.returncode == 0, out.stderr
    out = cli("optimize", str(f), "--information", "GTSAM", "--dry-run")
    assert out.returncode == 0 and "read as 'gtsam'" in out.stdout, out.stderr
    out = cli("conventions", "ros", "--format", "JSON")
    assert out.returncode == 0 and out.stdout.lstrip().startswith(("{", "[")), out.stderr
    out = cli("optimize", str(f), "--information", "gtsam2", "--dry-run")
    assert out.returncode == 2 and "invalid choice: 'gtsam2'" in out.stderr


# ------------------------------------------------------------------- liebridge optimize
def test_optimize_says_which_information_semantics_and_how_to_get_gtsams(tmp_path: Path) -> None:
    f = tmp_path / "g.g2o"
    f.write_text(G2O_TEXT)
    fmt = cli("optimize", str(f))
    assert fmt.returncode == 0, fmt.stderr
    line = next(s for s in fmt.stdout.splitlines() if s.startswith("semantics:"))
    assert "format's own information" in line and "--information gtsam" in line
    gt = cli("optimize", str(f), "--information", "gtsam")
    line = next(s for s in gt.stdout.splitlines() if s.startswith("semantics:"))
    assert "gtsam.readG2o" in line and "--information g2o" in line


def test_optimize_plot_has_units_and_the_marginals(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from liebridge.cli import optimize as opt

    g = lb.g2o.read(_write(tmp_path))
    poses = g.poses
    cov = np.stack([np.diag([1e-4] * 3 + [4e-2, 9e-2, 1e-2])] * poses.shape[0])
    sigma = opt.position_sigma(cov, poses, lb.conventions.get("gtsam"))
    # √trace of the world-frame position block; a rotation keeps the trace: √(0.04+0.09+0.01)
    np.testing.assert_allclose(sigma, np.sqrt(0.14), rtol=1e-12)
    captured: dict[str, object] = {}
    real_savefig = plt.Figure.savefig

    def keep(fig: object, *a: object, **k: object) -> None:
        captured["fig"] = fig
        real_savefig(fig, *a, **k)  # type: ignore[arg-type]

    plt.Figure.savefig = keep  # type: ignore[method-assign]
    try:
        opt.plot_trajectories(poses, poses, tmp_path / "p.png", "t", plt=plt, sigma=sigma)
    finally:
        plt.Figure.savefig = real_savefig  # type: ignore[method-assign]
    fig = captured["fig"]
    labels = [ax.get_xlabel() for ax in fig.axes] + [ax.get_ylabel() for ax in fig.axes]  # type: ignore[attr-defined]
    assert "x [m]" in labels and any("position σ [m]" in s for s in labels)
    assert (tmp_path / "p.png").stat().st_size > 10_000


def _write(tmp_path: Path) -> Path:
    f = tmp_path / "g.g2o"
    f.write_text(G2O_TEXT)
    return f


def test_optimize_with_marginals_and_plot_end_to_end(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    f = _write(tmp_path)
    out = cli(
        "optimize",
        str(f),
        "--convention",
        "sophus",
        "--marginals",
        str(tmp_path / "m.npy"),
        "--plot",
        str(tmp_path / "p.png"),
    )
    assert out.returncode == 0, out.stderr
    assert (tmp_path / "p.png").stat().st_size > 10_000
    assert np.load(tmp_path / "m.npy").shape == (2, 6, 6)


# ------------------------------------------------------------------- short reprs
def test_g2o_graph_and_optimize_result_have_short_reprs(tmp_path: Path) -> None:
    gtsam = pytest.importorskip("gtsam")
    g = lb.g2o.read(gtsam.findExampleDataFile("sphere2500.txt"))
    r = repr(g)
    assert r == (
        "G2OGraph(2500 vertices, 4949 edges, information_reading='g2o', "
        "vertices chained from odometry)"
    )
    graph, values = lb.g2o.read(_write(tmp_path)).to_gtsam(prior=None)
    graph.add(gtsam.PriorFactorPose3(0, values.atPose3(0), gtsam.noiseModel.Isotropic.Sigma(6, 1)))
    res = lb.factors.optimize(graph, values)
    text = repr(res)
    assert "\n" not in text and len(text) < 200
    assert text.startswith("OptimizeResult(error ") and "<gtsam.Values, 2 variables>" in text


# ------------------------------------------------------------------- convert-cov
def test_convert_cov_prints_exact_zeros_as_zeros() -> None:
    out = cli(
        "convert-cov",
        "--from",
        "gtsam",
        "--to",
        "ros",
        "--pose",
        "1 2 3 0 0 0.3826834 0.9238795",
        "--layout",
        "xyz_qxyzw",
        "--cov",
        "1e-4 1e-4 1e-4 0.01 0.01 0.01",
    )
    assert out.returncode == 0, out.stderr
    rows = [r for r in out.stdout.splitlines() if not r.startswith("#")]
    M = np.array([[float(x) for x in r.split()] for r in rows])
    # [[0, R], [R, 0]] with isotropic blocks: diagonal, every off-diagonal entry exactly 0
    assert np.count_nonzero(M - np.diag(np.diag(M))) == 0
    assert "printed as 0" in out.stdout
    assert not any("e-1" in x and abs(float(x)) < 1e-15 for r in rows for x in r.split())


def test_convert_cov_header_names_one_method() -> None:
    args = ["convert-cov", "--from", "gtsam", "--to", "g2o", "--pose", "0 0 0 0 0 0 1",
            "--layout", "xyz_qxyzw", "--cov", "1e-2 1e-2 1e-2 1 1 1"]  # fmt: skip
    lin = cli(*args).stdout
    uns = cli(*args, "--method", "unscented").stdout
    how_lin = next(s for s in lin.splitlines() if s.startswith("# conversion:"))
    how_uns = next(s for s in uns.splitlines() if s.startswith("# conversion:"))
    assert "first order" in how_lin and "unscented" in how_lin  # the hint to try it
    assert "unscented" in how_uns and "first order" not in how_uns


# ------------------------------------------------------------------- help, markdown, files
def test_demo_is_documented() -> None:
    top = cli("--help").stdout
    assert "demo" in top and "self-check" in top
    h = cli("demo", "--help")
    assert h.returncode == 0 and "gtsam.Pose3.Expmap" in h.stdout
    d = cli("demo")
    assert d.returncode == 0 and "max |diff|" in d.stdout


def test_conventions_name_markdown_differs_from_table() -> None:
    md = cli("conventions", "ros", "--format", "markdown").stdout
    table = cli("conventions", "ros").stdout
    assert md != table
    assert md.startswith("### `ros`")
    assert "| `ros` | `left` | `trans_first` | `so3xr3_world` |" in md
    assert "- **source**: S geometry_msgs/PoseWithCovariance.msg" in md


def test_g2o_convert_finds_gtsams_example_files_by_name(tmp_path: Path) -> None:
    out = cli("g2o", "convert", "sphere2500.txt", str(tmp_path / "s.g2o"), "--information",
              "g2o:gtsam")  # fmt: skip
    assert out.returncode == 0, out.stderr
    assert "2500 vertices, 4949 edges" in out.stdout
    missing = cli("g2o", "convert", "nosuch.g2o", str(tmp_path / "x.g2o"), "--information",
                  "g2o:gtsam")  # fmt: skip
    assert missing.returncode == 2
    assert "IN: no such file: nosuch.g2o (nor in GTSAM's example data)" in missing.stderr
