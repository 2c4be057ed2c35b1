"""``read_tum``/``read_kitti`` parse in one ``numpy.loadtxt`` pass.

The fast path must give what the line-by-line reader gives (an oracle parsed here with
``float()`` per field), keep the precision-aware tolerances (quaternion norms, rotation blocks
judged by the precision they were printed with) and name the same line in the same words.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from liebridge.io import trajectory as tio


def _oracle_tum(path: Path) -> tuple[np.ndarray, np.ndarray]:
    rows = []
    for line in path.read_text().splitlines():
        body = line.split("#", 1)[0].replace(",", " ").split()
        if body:
            rows.append([float(f) for f in body])
    d = np.array(rows)
    T = np.tile(np.eye(4), (len(d), 1, 1))
    T[:, :3, :3] = Rotation.from_quat(d[:, 4:8]).as_matrix()  # normalises, scalar last
    T[:, :3, 3] = d[:, 1:4]
    return d[:, 0], T


def _tum_lines(n: int, digits: int | None, seed: int = 0) -> list[str]:
    rng = np.random.default_rng(seed)
    q = Rotation.random(n, random_state=seed).as_quat()
    p = rng.normal(size=(n, 3)) * 30
    fmt = repr if digits is None else (lambda x: f"{x:.{digits}f}")
    return [" ".join(fmt(float(v)) for v in (0.1 * k, *p[k], *q[k])) for k in range(n)]


@pytest.mark.parametrize("digits", [None, 4, 6])
@pytest.mark.parametrize("sep", [" ", ",", "\t"])
def test_tum_equals_oracle(tmp_path: Path, digits: int | None, sep: str) -> None:
    lines = _tum_lines(50, digits)
    body = ["# timestamp tx ty tz qx qy qz qw", ""] + [ln.replace(" ", sep) for ln in lines]
    body.insert(10, "   # a comment in the middle")
    path = tmp_path / "t.txt"
    path.write_text("\n".join(body) + "\n")
    t, T = tio.read_tum(path, check=False)
    t0, T0 = _oracle_tum(path)
    np.testing.assert_array_equal(t, t0)
    np.testing.assert_allclose(T, T0, atol=1e-14)


def test_low_precision_quaternion_off_names_its_line(tmp_path: Path) -> None:
    lines = ["# header", *_tum_lines(6, 4)]
    lines.insert(3, "")  # a blank line: line numbers count it
    lines[5] = "0.5 1 2 3 0.0 0.0 0.0 0.9990"  # 4 decimals, norm off by 1e-3 > 2e-4
    path = tmp_path / "t.txt"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ValueError, match=r"t\.txt:6: quaternion norm off by 0\.001 \(tolerance"):
        tio.read_tum(path, check=False)


def test_low_precision_within_its_tolerance_is_accepted(tmp_path: Path) -> None:
    path = tmp_path / "t.txt"
    path.write_text("0 1 2 3 0.0 0.0 0.0 0.9999\n1 0 0 0 0 0 0 1\n")  # off 1e-4 ≤ 2e-4
    _, T = tio.read_tum(path, check=False)
    assert T.shape == (2, 4, 4)
    np.testing.assert_allclose(T[0, :3, :3], np.eye(3), atol=1e-15)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("timestamp tx ty tz qx qy qz qw\n0 0 0 0 0 0 0 1\nx 0 0 0 0 0 0 1\n", r":3: not a number"),
        ("x1.0 0 0 0 0 0 0 1\n0 0 0 0 0 0 0 1\n", r":1: not a number: 'x1.0'"),
        ("0 0 0 0 0 0 0 1\n0 0 0 0 0 0 1\n", r":2: expected 8 numbers"),
        ("0 0 0 0 0 0 0 1\n0 nan 0 0 0 0 0 1\n", r":2: NaN or Inf"),
        ("0 0 0 0 0 0 0 1\n0 0 0 x 0 0 0 1\n", r":2: not a number: 'x'"),
    ],
)
def test_bad_tum_lines_keep_their_messages(tmp_path: Path, text: str, match: str) -> None:
    path = tmp_path / "t.txt"
    path.write_text(text)
    with pytest.raises(ValueError, match=match):
        tio.read_tum(path, check=False)


def _kitti_line(R: np.ndarray, t: np.ndarray, fmt: str = "{:.6e}") -> str:
    M = np.concatenate([R, t[:, None]], axis=1)
    return " ".join(fmt.format(v) for v in M.ravel())


def test_kitti_equals_oracle_and_names_bad_rotation_line(tmp_path: Path) -> None:
    Rs = Rotation.random(20, random_state=1).as_matrix()
    ts = np.random.default_rng(1).normal(size=(20, 3)) * 100
    lines = [_kitti_line(R, t) for R, t in zip(Rs, ts, strict=True)]
    path = tmp_path / "k.txt"
    path.write_text("\n".join(lines) + "\n")
    T = tio.read_kitti(path).T
    want = np.array([[float(f) for f in ln.split()] for ln in lines]).reshape(-1, 3, 4)
    np.testing.assert_array_equal(T[:, :3, :], want)
    np.testing.assert_array_equal(T[:, 3], np.tile([0.0, 0, 0, 1], (20, 1)))
    bad = lines.copy()
    bad[7] = _kitti_line(Rs[7] * 1.001, ts[7])  # off by 2e-3 > 2e-6
    path.write_text("\n".join(["", *bad]) + "\n")
    with pytest.raises(ValueError, match=r"k\.txt:9: rotation block is not a rotation"):
        tio.read_kitti(path)
    bad[7] = _kitti_line(-Rs[7], ts[7])  # a reflection: det −1
    path.write_text("\n".join(bad) + "\n")
    with pytest.raises(ValueError, match=r"k\.txt:8: .*det = -1"):
        tio.read_kitti(path)


def test_empty_files(tmp_path: Path) -> None:
    path = tmp_path / "e.txt"
    path.write_text("# only a comment\n\n")
    t, T = tio.read_tum(path, check=False)
    assert t.shape == (0,) and T.shape == (0, 4, 4)
    assert tio.read_kitti(path).T.shape == (0, 4, 4)
