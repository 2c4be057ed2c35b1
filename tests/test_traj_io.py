"""Trajectory files: TUM header/comment detection, EuRoC, KITTI, hemisphere continuity, the
quaternion sanity warnings, and one clear error per bad file."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from _traj_data import sphere_poses

from liebridge.io import euroc, sanity, trajfile
from liebridge.io import trajectory as old_io
from liebridge.lie import quaternion as quat
from liebridge.lie import se3


def _poses(n=50):
    return sphere_poses()[:n]


def test_tum_roundtrip_with_header_variants(tmp_path):
    T = _poses()
    t = 1.5e9 + 0.05 * np.arange(len(T))
    p = tmp_path / "a.txt"
    trajfile.write_trajectory(p, t, T)
    t2, T2 = trajfile.read_trajectory(p)
    np.testing.assert_array_equal(t2, t)
    np.testing.assert_allclose(T2, T, atol=1e-15)
    # same numbers as the existing per-line reader
    t3, T3 = old_io.read_tum(p)
    np.testing.assert_array_equal(t3, t2)
    np.testing.assert_allclose(T3, T2, atol=1e-15)
    body = p.read_text().splitlines()[1:]
    variants = {
        "plain header": "timestamp tx ty tz qx qy qz qw\n" + "\n".join(body),
        "comments": "# hello\n\n" + "\n".join(b + "  # c" for b in body),
        "commas": "#timestamp,tx,ty,tz,qx,qy,qz,qw\n"
        + "\n".join(b.replace(" ", ",") for b in body),
    }
    for name, text in variants.items():
        q = tmp_path / f"{name.replace(' ', '_')}.txt"
        q.write_text(text + "\n")
        tq, Tq = trajfile.read_trajectory(q)
        np.testing.assert_array_equal(tq, t, err_msg=name)
        np.testing.assert_allclose(Tq, T, atol=1e-15, err_msg=name)


def test_tum_wxyz_header_sets_the_order(tmp_path):
    T = _poses()
    t = np.arange(len(T), dtype=float)
    p = tmp_path / "w.txt"
    trajfile.write_trajectory(p, t, T, quat_order="wxyz")
    assert "qw qx qy qz" in p.read_text().splitlines()[0]
    _, T2 = trajfile.read_trajectory(p)
    np.testing.assert_allclose(T2, T, atol=1e-15)


def test_writers_keep_hemisphere_continuity(tmp_path):
    # a rotation turning through 2π: canonical w ≥ 0 storage would flip at the half turn
    T = se3.exp(np.column_stack([np.zeros((80, 2)), np.linspace(0, 6, 80), np.zeros((80, 3))]))
    t = np.arange(80.0)
    for fmt in ("tum", "euroc"):
        p = tmp_path / f"h.{fmt}"
        trajfile.write_trajectory(p, t, T, fmt)
        rows = [ln for ln in p.read_text().splitlines() if not ln.startswith("#")]
        vals = np.array([[float(x) for x in ln.replace(",", " ").split()] for ln in rows])
        q = vals[:, 4:8]
        assert (np.einsum("ij,ij->i", q[1:], q[:-1]) > 0).all(), fmt
        _, T2 = trajfile.read_trajectory(p, fmt)
        np.testing.assert_allclose(T2, T, atol=1e-12)


@pytest.mark.filterwarnings("ignore::liebridge.io.sanity.QuaternionOrderWarning")  # fast poses
def test_euroc_groundtruth(tmp_path):
    T = _poses(30)
    q = quat.from_matrix(T[:, :3, :3], order="wxyz")
    ns = 1403636579758555392 + 5_000_000 * np.arange(30, dtype=np.int64)
    extra = np.random.default_rng(0).normal(size=(30, 9))
    lines = [
        "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], "
        "q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1],"
        " b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], "
        "b_a_RS_S_z [m s^-2]"
    ]
    for k in range(30):
        nums = [*T[k, :3, 3], *q[k], *extra[k]]
        lines.append(f"{ns[k]}," + ",".join(repr(float(x)) for x in nums))
    p = tmp_path / "data.csv"
    p.write_text("\n".join(lines) + "\n")
    assert trajfile.detect_format(p) == "euroc"
    r = euroc.read_euroc(p)
    t, T2, ex = r.stamps, r.T, r.extra
    np.testing.assert_allclose(T2, T, atol=1e-14)
    np.testing.assert_allclose(ex, extra)
    assert t[1] - t[0] == pytest.approx(0.005, abs=5e-7)  # float64 at 1.4e9 s: 2.4e-7 s apart
    assert t[0] == pytest.approx(1403636579.758555392, abs=1e-6)


def test_kitti_by_detection(tmp_path):
    T = _poses(12)
    p = tmp_path / "00.txt"
    old_io.write_kitti(p, T)
    assert trajfile.detect_format(p) == "kitti"
    t, T2 = trajfile.read_trajectory(p)
    np.testing.assert_array_equal(t, np.arange(12.0))
    np.testing.assert_allclose(T2, T)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("0 1 2 3 0 0 0 1\n1 1 2 3 0 0 1\n", r":2: expected 8 numbers"),
        ("0 1 2 3 0 0 0 1\n1 1 2 x 0 0 0 1\n", r":2: not a number: 'x'"),
        ("0 1 2 3 0 0 0 1\n1 1 2 nan 0 0 0 1\n", r":2: NaN or Inf"),
        ("# c\n0 1 2 3 0 0 0 1\n1 1 2 3 0 0 0.5 1\n", r":3: quaternion norm off by"),
        ("# only a comment\n", "no data lines"),
        ("nan 1 2 3 0 0 0 1\n1 1 2 3 0 0 0 1\n", r":1: NaN or Inf"),
    ],
)
def test_tum_bad_files_one_clear_error(tmp_path, text, match):
    p = tmp_path / "bad.txt"
    p.write_text(text)
    with pytest.raises(ValueError, match=match):
        trajfile.read_trajectory(p, "tum")


def test_four_decimal_tum_ground_truth_loads(tmp_path):
    T = _poses(20)
    x = np.concatenate([T[:, :3, 3], quat.from_matrix(T[:, :3, :3], order="xyzw")], axis=-1)
    p = tmp_path / "gt.txt"
    np.savetxt(p, np.column_stack([np.arange(20.0), x]), fmt="%.4f")
    _, T2 = trajfile.read_trajectory(p)
    np.testing.assert_allclose(T2[:, :3, 3], T[:, :3, 3], atol=1e-4)


# ------------------------------------------------------------------------- sanity


def _turning(n=200, rate=1.0, dt=0.05):
    w = np.column_stack([0.3 * np.ones(n), 0.2 * np.ones(n), np.ones(n)]) * np.arange(n)[:, None]
    w = w * rate * dt
    from liebridge.lie import so3

    return quat.canonical(quat.from_matrix(so3.exp(w), order="xyzw"), order="xyzw"), dt * np.arange(
        n
    )


def test_sanity_clean_input_is_quiet():
    q, t = _turning()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = sanity.check_quaternions(q, "xyzw", t)
    assert r.ok and r.suggested_order is None


def test_sanity_flags_a_wrong_order():
    q, t = _turning()  # written w ≥ 0 (canonical), read as wxyz
    with pytest.warns(sanity.QuaternionOrderWarning, match="likely 'xyzw'"):
        r = sanity.check_quaternions(q, "wxyz", t)
    assert r.suggested_order == "xyzw"


def test_sanity_flags_norms_and_rate():
    q, t = _turning()
    bad = q.copy()
    bad[17] *= 1.2
    with pytest.warns(sanity.QuaternionOrderWarning, match="1 of 200 quaternions are not unit"):
        r = sanity.check_quaternions(bad, "xyzw", t)
    assert r.first_bad_norm == 17
    with pytest.warns(sanity.QuaternionOrderWarning, match="faster than 30 rad/s"):
        r = sanity.check_quaternions(q, "xyzw", t * 1e-3)  # stamps in ms read as s
    assert r.too_fast > 100


def test_sanity_vectorised_on_a_million():
    import time

    q = np.tile(np.array([0.0, 0.0, 0.0, 1.0]), (1_000_000, 1))
    t0 = time.perf_counter()
    sanity.check_quaternions(q, "xyzw", np.arange(1_000_000) * 0.01)
    assert time.perf_counter() - t0 < 5.0


def test_reader_warns_on_wrong_order(tmp_path):
    q, t = _turning()
    x = np.column_stack([t, np.zeros((len(t), 3)), q])
    p = tmp_path / "q.txt"
    np.savetxt(p, x, fmt="%.17g")
    with pytest.warns(sanity.QuaternionOrderWarning, match="likely 'xyzw'"):
        trajfile.read_trajectory(p, quat_order="wxyz")


@pytest.mark.parametrize(
    ("header", "order"),
    [
        ("# timestamp tx ty tz qx qy qz qw", "xyzw"),
        ("timestamp,x,y,z,q_w,q_x,q_y,q_z", "wxyz"),
        ("#t p_RS_R_x p_RS_R_y p_RS_R_z q_RS_w q_RS_x q_RS_y q_RS_z", "wxyz"),
        ("# time x y z", None),
    ],
)
def test_header_names_the_order(header, order):
    from liebridge.io import trajectory

    fields = header.lstrip("#").replace(",", " ").split()
    assert trajectory._header_order(fields) == order


def test_euroc_writer_keeps_nanoseconds(tmp_path):
    T = _poses(3)
    t = np.array([1403636579.758555392, 1403636579.763555392, 1403636579.768555392])
    p = tmp_path / "w.csv"
    euroc.write_euroc(p, t, T)
    ns = [int(ln.split(",")[0]) for ln in p.read_text().splitlines()[1:]]
    from decimal import Decimal

    exact = [round(Decimal(float(x)) * 10**9) for x in t]  # the nanoseconds the doubles hold
    assert max(abs(a - b) for a, b in zip(ns, exact, strict=True)) <= 1
    assert abs(round(float(t[0]) * 1e9) - exact[0]) > 1  # the one-float product would not
