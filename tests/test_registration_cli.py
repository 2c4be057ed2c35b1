"""``liebridge registration info``: a saved result printed in any convention; one-line errors."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from liebridge import registration as reg
from liebridge.cli import main
from liebridge.lie import se3

T_TS = se3.exp(np.array([0.4, -0.7, 1.1, 3.0, -2.0, 30.0]))


def _blocks(out: str) -> dict[str, np.ndarray]:
    blocks: dict[str, list[list[float]]] = {}
    key = ""
    for line in out.splitlines():
        if line.startswith("#"):
            key = line.split()[1]
            blocks[key] = []
        elif line.strip():
            blocks[key].append([float(x) for x in line.split()])
    return {k: np.array(v) for k, v in blocks.items() if v}


@pytest.fixture
def o3d_file(tmp_path: Path) -> tuple[Path, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    p = rng.uniform(-5, 5, size=(50, 3))
    q = p @ T_TS[:3, :3].T + T_TS[:3, 3]
    info = reg.information(T_TS, p, q, sigma=1.0, convention="open3d").information
    f = tmp_path / "loop.npz"
    np.savez(f, T=T_TS, information=info, library="open3d", sigma=0.02)
    return f, p, q


def test_info_prints_the_information_in_the_requested_convention(o3d_file, capsys) -> None:
    f, p, q = o3d_file
    assert main(["registration", "info", str(f), "--to", "kiss_icp"]) == 0
    b = _blocks(capsys.readouterr().out)
    want = reg.information(T_TS, p, q, sigma=0.02, convention="kiss_icp")
    np.testing.assert_allclose(b["T_target_source"], T_TS, atol=1e-15)
    scale = np.abs(want.information).max()
    np.testing.assert_allclose(b["information"], want.information, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(
        b["covariance"], want.cov, rtol=0, atol=1e-12 * np.abs(want.cov).max()
    )


def test_small_gicp_H_is_used_as_stored_unless_sigma(tmp_path: Path, capsys) -> None:
    rng = np.random.default_rng(1)
    p = rng.uniform(-5, 5, size=(50, 3))
    q = p @ T_TS[:3, :3].T + T_TS[:3, 3]
    H = reg.information(T_TS, p, q, sigma=1.0, convention="small_gicp").information
    f = tmp_path / "sg.npz"
    np.savez(f, T=T_TS, H=H, library="small_gicp")
    assert main(["registration", "info", str(f)]) == 0
    b = _blocks(capsys.readouterr().out)
    np.testing.assert_allclose(b["information"], H, rtol=0, atol=1e-12 * np.abs(H).max())
    assert main(["registration", "info", str(f), "--sigma", "0.1"]) == 0
    b = _blocks(capsys.readouterr().out)
    np.testing.assert_allclose(b["information"], H / 0.01, rtol=0, atol=1e-10 * np.abs(H).max())


@pytest.mark.parametrize(
    "entries, args, message",
    [
        ({"information": np.eye(6), "library": "open3d"}, [], "no array 'T'"),
        ({"T": np.eye(4), "library": "open3d"}, [], "exactly one of 'H' or 'information'"),
        ({"T": np.eye(4), "H": np.eye(6)}, [], "no 'library' entry"),
        ({"T": np.eye(4), "H": np.eye(6), "library": "open3d"}, [], "--sigma: Open3D's"),
        ({"T": np.eye(4), "H": np.eye(6), "library": "opend3d"}, [], "did you mean 'open3d'"),
        ({"T": np.eye(4), "H": np.zeros((6, 6)), "library": "small_gicp"}, [], "singular"),
        ({"T": np.eye(4), "H": np.eye(6), "library": "small_gicp"}, ["--to", "x"], "--to: "),
    ],
)
def test_bad_files_get_one_line_and_status_2(tmp_path, capsys, entries, args, message) -> None:
    f = tmp_path / "bad.npz"
    np.savez(f, **entries)
    assert main(["registration", "info", str(f), *args]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err


def test_not_an_npz_and_missing_subcommand(tmp_path, capsys) -> None:
    f = tmp_path / "x.npz"
    f.write_text("hello")
    assert main(["registration", "info", str(f)]) == 2
    assert "not a readable .npz" in capsys.readouterr().err
    proc = subprocess.run(
        [sys.executable, "-m", "liebridge.cli", "registration"], capture_output=True, text=True
    )
    assert proc.returncode == 2 and "missing SUBCOMMAND (info)" in proc.stderr
