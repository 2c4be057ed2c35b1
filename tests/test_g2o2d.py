"""2-D g2o / TORO files: GTSAM's reading, both EDGE2 orders, bit-exact round trips, bad input."""

from __future__ import annotations

from pathlib import Path

import gtsam
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from liebridge.io import g2o, g2o2d

G2O_ORDER_FILES = ["pose2example.txt", "noisyToyGraph.txt", "w100_30.g2o"]
TORO_ORDER_FILES = ["w100.graph"]


def data(name: str) -> str:
    return gtsam.findExampleDataFile(name)


@pytest.mark.parametrize("name", G2O_ORDER_FILES)
def test_factors_and_values_equal_gtsams_readg2o(name: str) -> None:
    ref_graph, ref_values = gtsam.readG2o(data(name), False)
    graph, values = g2o2d.read(data(name)).to_gtsam(prior=None)
    assert graph.size() == ref_graph.size() and values.size() == ref_values.size()
    for k in range(graph.size()):
        a, b = graph.at(k), ref_graph.at(k)
        assert list(a.keys()) == list(b.keys())
        assert a.measured().equals(b.measured(), 1e-15)
        np.testing.assert_allclose(
            a.noiseModel().information(), b.noiseModel().information(), rtol=1e-14, atol=0
        )
    for key in ref_values.keys():
        assert values.atPose2(key).equals(ref_values.atPose2(key), 1e-15)
    assert graph.error(values) == pytest.approx(ref_graph.error(ref_values), rel=1e-14)


@pytest.mark.parametrize("name", TORO_ORDER_FILES)
def test_toro_order_is_detected_where_gtsam_refuses(name: str) -> None:
    with pytest.raises(RuntimeError, match="not G2O matrix order"):
        gtsam.readG2o(data(name), False)
    g = g2o2d.read(data(name))
    assert g.edge2_order == "toro"
    assert all(np.linalg.eigvalsh(g.information).min(axis=-1) > 0)
    assert dict(g.skipped).get("EQUIV", 0) > 0


def _write(tmp_path: Path, text: str, name: str = "g.g2o") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_the_two_edge2_orders_put_the_same_numbers_in_different_places(tmp_path: Path) -> None:
    head = "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\n"
    # TORO: Ixx Ixy Iyy Itt Ixt Iyt; read in g2o's order (I11 I12 I13 I22 I23 I33) it is indefinite
    toro = _write(tmp_path, head + "EDGE2 0 1 1 0 0 5 1 4 3 0.5 0.25\n", "toro.graph")
    np.testing.assert_array_equal(
        g2o2d.read(toro, edge2="toro").information[0], [[5, 1, 0.5], [1, 4, 0.25], [0.5, 0.25, 3]]
    )
    assert g2o2d.read(toro).edge2_order == "toro"
    with pytest.raises(ValueError, match=r"toro\.graph:3: information: not positive semi-definite"):
        g2o2d.read(toro, edge2="g2o")
    # g2o's order: positive definite as written, so auto keeps it
    g2o_file = _write(tmp_path, head + "EDGE2 0 1 1 0 0 5 1 0.4 4 0.25 3\n", "g2o.graph")
    auto = g2o2d.read(g2o_file)
    assert auto.edge2_order == "g2o"
    np.testing.assert_array_equal(auto.information[0], [[5, 1, 0.4], [1, 4, 0.25], [0.4, 0.25, 3]])


@pytest.mark.parametrize("name", [*G2O_ORDER_FILES, *TORO_ORDER_FILES])
def test_read_write_read_is_bit_exact(tmp_path: Path, name: str) -> None:
    a = g2o2d.read(data(name))
    g2o2d.write(tmp_path / "out.g2o", a)
    b = g2o2d.read(tmp_path / "out.g2o")
    for field in ("vertex_ids", "vertex_xytheta", "edges", "measured_xytheta", "information"):
        x, y = getattr(a, field), getattr(b, field)
        assert x.dtype == y.dtype and x.shape == y.shape
        assert x.tobytes() == y.tobytes(), field  # parsing and repr: no arithmetic
    assert a.fixed == b.fixed


finite = st.floats(-1e6, 1e6, allow_nan=False, allow_subnormal=False)


@settings(max_examples=40)
@given(
    poses=st.lists(st.tuples(finite, finite, finite), min_size=2, max_size=6),
    diag=st.tuples(*(st.floats(1e-3, 1e6),) * 3),
    off=st.tuples(*(st.floats(-1e-4, 1e-4),) * 3),
)
def test_generated_files_round_trip_bit_exact(poses, diag, off) -> None:  # type: ignore[no-untyped-def]
    import tempfile

    info = f"{diag[0]!r} {off[0]!r} {off[1]!r} {diag[1]!r} {off[2]!r} {diag[2]!r}"
    lines = [f"VERTEX_SE2 {k} {x!r} {y!r} {t!r}" for k, (x, y, t) in enumerate(poses)]
    lines += [f"EDGE_SE2 {k} {k + 1} -0.0 1.5 0.25 {info}" for k in range(len(poses) - 1)]
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "h.g2o"
        p.write_text("\n".join(lines) + "\n")
        a = g2o2d.read(p)
        g2o2d.write(Path(d) / "o.g2o", a)
        b = g2o2d.read(Path(d) / "o.g2o")
    assert a.vertex_xytheta.tobytes() == b.vertex_xytheta.tobytes()
    assert a.measured_xytheta.tobytes() == b.measured_xytheta.tobytes()
    assert np.signbit(b.measured_xytheta[:, 0]).all()  # -0.0 stays -0.0
    assert a.information.tobytes() == b.information.tobytes()


def test_without_vertices_poses_are_chained_from_odometry(tmp_path: Path) -> None:
    text = "EDGE_SE2 0 1 1 0 1.5707963267948966 1 0 0 1 0 1\nEDGE_SE2 1 2 1 0 0 1 0 0 1 0 1\n"
    g = g2o2d.read(_write(tmp_path, text))
    assert g.vertices_from_odometry
    np.testing.assert_allclose(g.vertex_xytheta[2], [1.0, 1.0, np.pi / 2], atol=1e-15)


BAD = [
    ("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n", r"g\.g2o:1: 3-D type VERTEX_SE3:QUAT in a 2-D file"),
    ("VERTEX_SE2 0 0 0\n", r"g\.g2o:1: VERTEX_SE2 expects 3 values"),
    ("VERTEX_SE2 0 0 zero 0\n", r"g\.g2o:1: not a number: 'zero'"),
    ("VERTEX_SE2 0 0 0 nan\n", r"g\.g2o:1: NaN or Inf"),
    ("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 0 1 1 1\n", r"g\.g2o:2: vertex 0 already defined on line 1"),
    (
        "VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n",
        r"g\.g2o:2: edge refers to vertex 1, which has no VERTEX line",
    ),
    (
        "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 -1 0 1\n",
        r"g\.g2o:3: information: not positive semi-definite",
    ),
    (
        "VERTEX2 0 0 0 0\nVERTEX2 1 0 0 0\nEDGE2 0 1 1 0 0 1 2 3 -4 5 6\n",
        r"g\.g2o:3: EDGE2 information is not positive definite in g2o's order",
    ),
    ("ROBOTLASER1 0 0\n", r"g\.g2o:1: unsupported tag 'ROBOTLASER1'"),
    ("VERTEX_SE2 -3 0 0 0\n", r"g\.g2o:1: vertex id -3 is outside \[0, 2\*\*64 - 2\]"),
]


@pytest.mark.parametrize("text, match", BAD, ids=[b[1][:40] for b in BAD])
def test_bad_2d_files_are_one_clear_error(tmp_path: Path, text: str, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        g2o2d.read(_write(tmp_path, text))


def test_a_2d_file_given_to_the_3d_reader_says_which_reader_to_use() -> None:
    with pytest.raises(ValueError, match=r":1: 2-D type VERTEX_SE2 in a 3-D file: read it with"):
        g2o.read(data("pose2example.txt"))


def test_is_2d_tells_the_shipped_files_apart() -> None:
    assert g2o2d.is_2d(data("pose2example.txt")) and g2o2d.is_2d(data("w100.graph"))
    assert not g2o2d.is_2d(data("sphere2500.txt")) and not g2o2d.is_2d(data("toyExample.g2o"))


def test_pose2_matrix_and_params_are_inverse_and_match_gtsam() -> None:
    rng = np.random.default_rng(3)
    p = np.c_[rng.uniform(-30, 30, (20, 2)), rng.uniform(-np.pi, np.pi, 20)]
    T = g2o2d.pose2_matrix(p)
    for pk, Tk in zip(p, T, strict=True):
        np.testing.assert_allclose(Tk, gtsam.Pose2(*pk).matrix(), atol=1e-15)
    np.testing.assert_allclose(g2o2d.pose2_params(T), p, atol=1e-14)
