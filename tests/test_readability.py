"""A newcomer's first hour (issue 22): option values, short reprs, exact zeros, help texts."""

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
