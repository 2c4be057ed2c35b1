"""TUM and KITTI trajectory files."""

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from liebridge.io import trajectory as tio


def random_poses(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3] = Rotation.random(n, random_state=rng).as_matrix()
    T[:, :3, 3] = rng.normal(scale=100.0, size=(n, 3))
    return T


def test_tum_write_read_round_trip(tmp_path: Path) -> None:
    T = random_poses(50, 0)
    T[0, :3, 3] = [1234.5678901234567, -1e-300, 3.141592653589793]
    t = 1.3e9 + np.random.default_rng(1).random(50)
    p = tmp_path / "traj.txt"
    tio.write_tum(p, t, T)
    t2, T2 = tio.read_tum(p, check=False)  # random rotations: the order check would warn
    assert np.array_equal(t2, t)  # repr: timestamps bit for bit
    assert np.array_equal(T2[:, :3, 3], T[:, :3, 3])  # and translations
    assert np.allclose(T2, T, atol=1e-15, rtol=0)  # rotation through a quaternion
    # the file itself: one header comment, then 8 fields, quaternion xyzw with the one sign rule:
    # the first w >= 0, then each q_i . q_{i-1} >= 0 (hemisphere continuity)
    lines = p.read_text().splitlines()
    assert lines[0].startswith("#")
    fields = [ln.split() for ln in lines[1:]]
    assert all(len(f) == 8 for f in fields)
    q = np.array([[float(c) for c in f[4:8]] for f in fields])
    assert q[0, 3] >= 0
    assert (np.einsum("ij,ij->i", q[1:], q[:-1]) >= 0).all()
    R = Rotation.from_quat(q).as_matrix()  # scipy reads xyzw
    assert np.allclose(R, T[:, :3, :3], atol=1e-15, rtol=0)
    # writing what was read gives the same text
    p2 = tmp_path / "traj2.txt"
    tio.write_tum(p2, t2, T2)
    _, T3 = tio.read_tum(p2, check=False)
    assert np.allclose(T3, T2, atol=1e-15, rtol=0)


def test_tum_reads_benchmark_style_file(tmp_path: Path) -> None:
    # TUM RGB-D ground truth style: comments, 4-decimal quaternions (norm off by ~1e-4)
    text = (
        "# ground truth trajectory\n"
        "# timestamp tx ty tz qx qy qz qw\n"
        "1305031098.6659 1.3563 0.6305 1.6380 0.6132 0.5962 -0.3311 -0.3986\n"
        "\n"
        "1305031098.6758,1.3543,0.6306,1.6360,0.6129,0.5966,-0.3316,-0.3980  # commas\n"
        "1305031098.6858\t1.3524 0.6304 1.6345 0.6126 0.5971 -0.3321 -0.3970\n"
    )
    p = tmp_path / "groundtruth.txt"
    p.write_text(text)
    t, T = tio.read_tum(p)
    assert t.shape == (3,) and T.shape == (3, 4, 4)
    assert t[1] == 1305031098.6758
    q = np.array([0.6129, 0.5966, -0.3316, -0.3980])
    assert np.allclose(T[1, :3, :3], Rotation.from_quat(q / np.linalg.norm(q)).as_matrix())
    assert np.array_equal(T[1, :3, 3], [1.3543, 0.6306, 1.6360])
    R = T[:, :3, :3]
    assert np.allclose(np.swapaxes(R, 1, 2) @ R, np.eye(3), atol=1e-15, rtol=0)


@pytest.mark.parametrize(
    ("line", "match"),
    [
        ("1.0 1 2 3 0 0 0", "expected 8 numbers"),
        ("1.0 1 2 3 0 0 0 1 9", "expected 8 numbers"),
        ("1.0 1 2 x 0 0 0 1", "not a number: 'x'"),
        ("1.0 1 2 nan 0 0 0 1", "NaN or Inf"),
        ("1.0 1 2 3 1 1 0 0", "quaternion norm off by 0.414"),
        ("1.0 1 2 3 0 0 0 1.0100000", "quaternion norm off by 0.01"),
    ],
)
def test_tum_malformed_line_names_file_and_line(tmp_path: Path, line: str, match: str) -> None:
    p = tmp_path / "bad.txt"
    p.write_text(f"# header\n0.0 0 0 0 0 0 0 1\n{line}\n")
    with pytest.raises(ValueError, match=match) as exc:
        tio.read_tum(p)
    assert f"{p}:3:" in str(exc.value)


def test_tum_write_validates(tmp_path: Path) -> None:
    T = random_poses(3, 2)
    with pytest.raises(ValueError, match="match timestamps"):
        tio.write_tum(tmp_path / "x.txt", np.zeros(2), T)
    bad = T.copy()
    bad[1, 0, 0] += 0.01
    with pytest.raises(ValueError, match=r"batch index \(1,\)"):
        tio.write_tum(tmp_path / "x.txt", np.zeros(3), bad)


def test_kitti_round_trip_is_bit_exact(tmp_path: Path) -> None:
    T = random_poses(40, 3)
    p = tmp_path / "00.txt"
    tio.write_kitti(p, T)
    T2 = tio.read_kitti(p).T
    assert np.array_equal(T2, T)
    rows = [[float(c) for c in ln.split()] for ln in p.read_text().splitlines()]
    assert np.array_equal(np.array(rows), T[:, :3, :].reshape(-1, 12))  # row-major 3x4


def test_kitti_reads_six_digit_file(tmp_path: Path) -> None:
    # KITTI ground truth prints %e with 6 decimals; RᵀR − I is then ~1e-6, not 1e-15
    R = Rotation.from_euler("zyx", [0.3, -0.2, 0.1]).as_matrix()
    block = np.hstack([R, [[1.5], [-2.25], [1e3]]])
    line = " ".join(f"{c:e}" for c in block.ravel())
    p = tmp_path / "gt.txt"
    p.write_text(line + "\n" + line + "\n")
    T = tio.read_kitti(p).T
    assert T.shape == (2, 4, 4)
    assert np.allclose(T[0, :3, :3], R, atol=1e-6)
    assert np.array_equal(T[:, 3], np.tile([0, 0, 0, 1.0], (2, 1)))


@pytest.mark.parametrize(
    ("line", "match"),
    [
        ("1 0 0 0 0 1 0 0 0 0 1", "expected 12 numbers"),
        ("1 0 0 0 0 1 0 0 0 0 1 zz", "not a number: 'zz'"),
        ("1 0 0 0 0 1 0 0 0 0 1.01 0", "not a rotation"),
        ("1 0 0 0 0 1 0 0 0 0 -1 0", "det = -1"),
    ],
)
def test_kitti_malformed_line_names_file_and_line(tmp_path: Path, line: str, match: str) -> None:
    p = tmp_path / "bad.txt"
    p.write_text("1 0 0 0 0 1 0 0 0 0 1 0\n" + line + "\n")
    with pytest.raises(ValueError, match=match) as exc:
        tio.read_kitti(p)
    assert f"{p}:2:" in str(exc.value)


def test_empty_files(tmp_path: Path) -> None:
    p = tmp_path / "empty.txt"
    p.write_text("# nothing\n\n")
    t, T = tio.read_tum(p)
    assert t.shape == (0,) and T.shape == (0, 4, 4)
    assert tio.read_kitti(p).T.shape == (0, 4, 4)
