"""The g2o readers parse well-formed files with ``numpy.loadtxt``, one pass per tag.

The fast path (``_read_tables``) must return what the line-by-line reader (``_read_lines``, the
reference) returns — values, order, information matrices, FIX ids — and any file it cannot take
must reach the line reader, so that errors keep their words and line numbers. Each malformed
input below names the line the test itself corrupted (not a line number taken from the code).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gtsam
import numpy as np
import pytest

from liebridge.io import g2o, g2o2d

FIELDS_3D = ("vertex_ids", "vertex_xyz_qxyzw", "edges", "measured_xyz_qxyzw", "information")
FIELDS_2D = ("vertex_ids", "vertex_xytheta", "edges", "measured_xytheta", "information")


def _data(name: str) -> str:
    return gtsam.findExampleDataFile(name)


def _same_3d(a: g2o.G2OGraph, b: g2o.G2OGraph, euler: bool = False) -> None:
    """Same graph: bitwise, except what goes through other arithmetic on the two paths.

    With ``euler`` (``EDGE3`` lines): the information ``Eᵀ Λ E`` (matmul there, entry by entry
    in the batched ``EDGE3`` path) and the measured quaternions (from the matrix there, in
    closed form here), to rounding relative to the largest entry. Without vertex lines: the
    chained poses (one product per vertex there, a blocked scan here), likewise.
    """
    for f in FIELDS_3D:
        x, y = getattr(a, f), getattr(b, f)
        assert x.dtype == y.dtype and x.shape == y.shape, f
        rounded = euler and f in ("information", "measured_xyz_qxyzw")
        rounded |= b.vertices_from_odometry and f == "vertex_xyz_qxyzw"
        if rounded:
            scale = max(1.0, float(np.abs(y).max())) if y.size else 1.0
            tol = 1e-13 if f == "vertex_xyz_qxyzw" else 4e-16
            np.testing.assert_allclose(x, y, rtol=0, atol=tol * scale, err_msg=f)
        else:  # parsed numbers, normalised quaternions, gathered and scaled by 2^-k: exact
            assert x.tobytes() == y.tobytes(), f
    assert a.fixed == b.fixed
    assert a.vertices_from_odometry == b.vertices_from_odometry
    assert a.information_reading == b.information_reading


def _fast_equals_slow_3d(path: Path | str, **kw: Any) -> g2o.G2OGraph:
    information = kw.get("information", "g2o")
    edge3 = kw.get("edge3", "sqrt_information")
    fast = g2o._read_tables(path, information, edge3)
    assert fast is not None, "the fast path refused a well-formed file"
    slow = g2o._read_lines(path, information, edge3)
    _same_3d(fast, slow, euler=bool(slow.edges.size and _has_euler(path)))
    _same_3d(g2o.read(path, information, edge3=edge3), slow, euler=True)
    return fast


def _has_euler(path: Path | str) -> bool:
    return "EDGE3 " in Path(path).read_text()


def _error(fn: Any) -> str:
    with pytest.raises(ValueError) as exc:
        fn()
    return str(exc.value)


# ----------------------------------------------------------------------------- 3-D: same graph
@pytest.mark.parametrize(
    "name", ["pose3example.txt", "pose3example-offdiagonal.txt", "sphere2500.txt"]
)
@pytest.mark.parametrize("information", ["g2o", "gtsam"])
def test_gtsam_example_files_fast_equals_line_reader(name: str, information: str) -> None:
    _fast_equals_slow_3d(_data(name), information=information)


def test_edge3_as_information_fast_equals_line_reader() -> None:
    _fast_equals_slow_3d(_data("sphere2500.txt"), edge3="information")


def _vertex(k: int, rng: np.random.Generator, fmt: Any = repr) -> str:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    nums = [*(rng.normal(size=3) * 30), *q]
    return f"VERTEX_SE3:QUAT {k} " + " ".join(fmt(float(x)) for x in nums)


def _edge(i: int, j: int, rng: np.random.Generator, fmt: Any = repr) -> str:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    A = rng.normal(size=(6, 6))
    lam = A @ A.T + 6 * np.eye(6)
    nums = [*rng.normal(size=3), *q, *lam[np.triu_indices(6)]]
    return f"EDGE_SE3:QUAT {i} {j} " + " ".join(fmt(float(x)) for x in nums)


def _graph_lines(n: int, seed: int = 0, fmt: Any = repr, ids: list[int] | None = None) -> list[str]:
    rng = np.random.default_rng(seed)
    ids = list(range(n)) if ids is None else ids
    lines = [_vertex(k, rng, fmt) for k in ids]
    lines += [_edge(ids[k], ids[k + 1], rng, fmt) for k in range(n - 1)]
    lines += [_edge(ids[0], ids[-1], rng, fmt)]
    return lines


def _write(tmp_path: Path, lines: list[str], name: str = "g.g2o", end: str = "\n") -> Path:
    p = tmp_path / name
    p.write_bytes((end.join(lines) + end).encode())
    return p


def test_comments_blank_lines_crlf_and_fix_take_the_fast_path(tmp_path: Path) -> None:
    lines = _graph_lines(12)
    lines.insert(0, "# a pose graph")
    lines.insert(3, "")
    lines.insert(5, "   # indented comment")
    lines[8] += "  # trailing comment"
    lines.append("FIX 0 3")
    lines.append("FIX 5")
    for end in ("\n", "\r\n"):
        path = _write(tmp_path, lines, end=end)
        g = _fast_equals_slow_3d(path)
        assert g.fixed == (0, 3, 5)
        assert g.vertex_ids.shape == (12,) and g.edges.shape == (12, 2)


def test_tabs_and_indented_lines_give_the_same_graph(tmp_path: Path) -> None:
    lines = _graph_lines(6)
    lines[1] = lines[1].replace(" ", "\t")
    lines[7] = "  " + lines[7]
    path = _write(tmp_path, lines)
    _fast_equals_slow_3d(path)


def test_mixed_line_types_keep_file_order(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    lines = []
    for k in range(8):  # VERTEX3 and VERTEX_SE3:QUAT, EDGE3 and EDGE_SE3:QUAT interleaved
        if k % 3 == 0:
            lines.append(f"VERTEX3 {k} " + " ".join(repr(float(x)) for x in rng.normal(size=6)))
        else:
            lines.append(_vertex(k, rng))
    for k in range(7):
        if k % 2:
            rpy = rng.normal(size=3) * 0.5
            S = np.triu(rng.normal(size=(6, 6))) + 5 * np.eye(6)
            nums = [*rng.normal(size=3), *rpy, *S[np.triu_indices(6)]]
            lines.append(f"EDGE3 {k} {k + 1} " + " ".join(repr(float(x)) for x in nums))
        else:
            lines.append(_edge(k, k + 1, rng))
        if k == 3:
            lines.append(_vertex(100, rng))  # a vertex after edges
    lines.append(_edge(100, 0, rng))
    path = _write(tmp_path, lines)
    for information in ("g2o", "gtsam"):
        for edge3 in ("sqrt_information", "information"):
            g = _fast_equals_slow_3d(path, information=information, edge3=edge3)
            assert g.vertex_ids.tolist() == [*range(8), 100]
            assert g.edges[:, 0].tolist() == [*range(7), 100]


def test_gtsam_keys_above_2_63_are_exact(tmp_path: Path) -> None:
    ids = [int(gtsam.symbol("x", k)) for k in range(5)] + [2**64 - 2]
    path = _write(tmp_path, _graph_lines(6, ids=ids))
    g = _fast_equals_slow_3d(path)
    assert g.vertex_ids.tolist() == ids  # not through float64


def test_no_vertex_lines_chains_the_odometry_on_both_paths(tmp_path: Path) -> None:
    lines = [ln for ln in _graph_lines(7) if ln.startswith("EDGE")]
    g = _fast_equals_slow_3d(_write(tmp_path, lines))
    assert g.vertices_from_odometry


def test_chunk_boundaries(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """Chunked conversions and checks give the unchunked result: chunks of 7 rows."""
    whole = g2o.read(_data("sphere2500.txt"))
    path = _write(tmp_path, _graph_lines(40))
    ref = g2o._read_lines(path, "g2o", "sqrt_information")
    monkeypatch.setattr(g2o, "_CHUNK", 7)
    _same_3d(g2o.read(path), ref)
    _same_3d(g2o.read(_data("sphere2500.txt")), whole, euler=True)
    _fast_equals_slow_3d(path, information="gtsam")


# ------------------------------------------------------------ quaternion precision tolerance
def test_low_precision_quaternions_are_judged_by_their_text(tmp_path: Path) -> None:
    """6 significant digits (GTSAM's writeG2o): norms off by up to ~1e-6, tolerance 2e-6."""
    lines = _graph_lines(30, fmt=lambda x: f"{x:.6g}")
    path = _write(tmp_path, lines)
    g = _fast_equals_slow_3d(path)
    q = np.array([ln.split()[5:9] for ln in lines[:30]], dtype=float)
    err = np.abs(np.linalg.norm(q, axis=-1) - 1)
    assert err.max() > 1e-7  # the text check ran on real rounding, not on exact unit norms
    np.testing.assert_allclose(np.linalg.norm(g.vertex_xyz_qxyzw[:, 3:], axis=-1), 1, atol=1e-15)


@pytest.mark.parametrize(
    ("quat", "tol"),
    [
        ("0.0 0.0 0.0 1.0000123456789012", "1e-06"),  # full precision: off by 1.2e-5 > 1e-6
        ("0.0 0.0 0.0 0.9990", "0.0002"),  # 4 decimals: off by 1e-3 > 2e-4
    ],
)
@pytest.mark.parametrize("row", ["vertex", "edge"])
def test_quaternion_off_beyond_its_printed_precision_names_its_line(
    tmp_path: Path, quat: str, tol: str, row: str
) -> None:
    lines = ["# header", *_graph_lines(5)]
    k = 3 if row == "vertex" else 7  # 0-based index in lines: file line k + 1
    f = lines[k].split()
    start = 5 if row == "vertex" else 6
    f[start : start + 4] = quat.split()
    lines[k] = " ".join(f)
    path = _write(tmp_path, lines)
    assert g2o._read_tables(path, "g2o", "sqrt_information") is None
    msg = _error(lambda: g2o.read(path))
    assert msg.startswith(f"{path}:{k + 1}: quaternion norm off by ")
    assert f"(tolerance {tol} for numbers printed with this precision)" in msg
    assert msg == _error(lambda: g2o._read_lines(path, "g2o", "sqrt_information"))


def test_quaternion_within_its_printed_precision_is_accepted(tmp_path: Path) -> None:
    lines = _graph_lines(4)
    f = lines[2].split()
    f[5:9] = ["0.0", "0.0", "0.0", "1.0001"]  # 4 decimals: off by 1e-4 ≤ 2e-4
    lines[2] = " ".join(f)
    g = _fast_equals_slow_3d(_write(tmp_path, lines))
    assert g.vertex_xyz_qxyzw[2, 3:].tolist() == [0.0, 0.0, 0.0, 1.0]


# ----------------------------------------------------------- malformed input: same errors
def _corrupt(lines: list[str], k: int, what: str) -> list[str]:
    out = list(lines)
    f = out[k].split()
    if what == "count":
        f = f[:-1]
    elif what == "word":
        f[4] = "abc"
    elif what == "nan":
        f[4] = "nan"
    elif what == "inf":
        f[-1] = "1e400"
    elif what == "id_float":
        f[1] = "1.0"
    elif what == "id_negative":
        f[1] = "-1"
    elif what == "id_2_64":
        f[1] = str(2**64 - 1)
    elif what == "underscore":  # Python's float() reads 1_0.5, numpy's loadtxt does not
        f[4] = "1_0.5"
    elif what == "tag":
        f[0] = "EDGE_SE3:QUATERNION"
    elif what == "tag2d":
        f[0] = "VERTEX_SE2"
    elif what == "self":
        f[2] = f[1]
    elif what == "missing":
        f[2] = "999"
    elif what == "duplicate":
        f[1] = "0"
    elif what == "indefinite":
        f[10] = "-50.0"  # I11 of the file's (t, qvec) information
    out[k] = " ".join(f)
    return out


VERTEX_FAULTS = ["count", "word", "nan", "inf", "id_float", "id_negative", "id_2_64", "duplicate"]
EDGE_FAULTS = ["count", "word", "nan", "inf", "tag", "tag2d", "self", "missing", "id_2_64"]


@pytest.mark.parametrize(
    ("k", "what"), [(4, w) for w in VERTEX_FAULTS] + [(9, w) for w in EDGE_FAULTS]
)
def test_malformed_line_gives_the_line_readers_error_with_its_line(
    tmp_path: Path, k: int, what: str
) -> None:
    lines = ["# comment", "", *_graph_lines(6)]  # vertices on lines 3-8, edges on 9-14
    path = _write(tmp_path, _corrupt(lines, k, what))
    msg = _error(lambda: g2o.read(path))
    assert msg == _error(lambda: g2o._read_lines(path, "g2o", "sqrt_information"))
    assert msg.startswith(f"{path}:{k + 1}: "), msg


def test_underscore_number_is_read_as_python_reads_it(tmp_path: Path) -> None:
    """``float("1_0.5") == 10.5``: numpy's parser refuses it, so the line reader decides."""
    lines = _graph_lines(3)
    f = lines[0].split()
    f[2] = "1_0.5"
    lines[0] = " ".join(f)
    path = _write(tmp_path, lines)
    assert g2o._read_tables(path, "g2o", "sqrt_information") is None
    assert g2o.read(path).vertex_xyz_qxyzw[0, 0] == 10.5


def test_indefinite_information_names_its_line(tmp_path: Path) -> None:
    path = _write(tmp_path, _corrupt(_graph_lines(4), 5, "indefinite"))
    msg = _error(lambda: g2o.read(path))
    assert msg == _error(lambda: g2o._read_lines(path, "g2o", "sqrt_information"))
    assert msg.startswith(f"{path}:6: information: not positive semi-definite")


def test_fix_errors_and_not_utf8_are_the_line_readers(tmp_path: Path) -> None:
    lines = _graph_lines(4)
    for extra, match in (
        ("FIX", r":9: FIX without an id"),
        ("FIX 1 x", r":9: vertex id 'x' is not an integer"),
        ("FIX 77", r"FIX refers to vertex 77, which does not exist"),
    ):
        path = _write(tmp_path, [*lines, extra])
        msg = _error(lambda p=path: g2o.read(p))
        assert msg == _error(lambda p=path: g2o._read_lines(p, "g2o", "sqrt_information"))
        assert match.replace("\\", "") in msg
    path = tmp_path / "latin1.g2o"
    path.write_bytes(("\n".join(lines[:3]) + "\n# caf\xe9\n").encode("latin-1"))
    msg = _error(lambda: g2o.read(path))
    assert msg.startswith(f"{path}:4: not UTF-8 text")


def test_gimbal_locked_edge3_names_its_line(tmp_path: Path) -> None:
    nums = " ".join(repr(float(x)) for x in np.eye(6)[np.triu_indices(6)])
    lines = [
        f"EDGE3 0 1 1 0 0 0 0.1 0 {nums}",
        f"EDGE3 1 2 1 0 0 0 {np.pi / 2!r} 0 {nums}",
    ]
    path = _write(tmp_path, lines)
    msg = _error(lambda: g2o.read(path))
    assert msg == _error(lambda: g2o._read_lines(path, "g2o", "sqrt_information"))
    assert msg.startswith(f"{path}:2: ")
    g = g2o.read(path, "gtsam")  # kept as numbers: no chart involved
    assert g.edges.shape == (2, 2)


def test_graph_arrays_from_the_fast_path_are_read_only_and_owned(tmp_path: Path) -> None:
    g = g2o.read(_write(tmp_path, _graph_lines(5)))
    g3 = g2o.read(_write(tmp_path, _edge3_graph("reversed", 70), "e3.txt"))  # EDGE3 only
    for f in FIELDS_3D:
        for a in (getattr(g, f), getattr(g3, f)):
            assert not a.flags.writeable
            assert a.dtype.names is None and a.flags.c_contiguous  # not a view of a table
    # the public constructor still copies what the caller passes
    info = np.array(g.information)
    h = g2o.G2OGraph(
        g.vertex_ids, g.vertex_xyz_qxyzw, g.edges, g.measured_xyz_qxyzw, info, fixed=()
    )
    info[0, 0, 0] = 1e6
    assert h.information[0, 0, 0] == g.information[0, 0, 0]


# ----------------------------------------------------------------------------------- 2-D
def _same_2d(a: g2o2d.G2OGraph2D, b: g2o2d.G2OGraph2D) -> None:
    for f in FIELDS_2D:
        x, y = getattr(a, f), getattr(b, f)
        assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), f
    assert (a.fixed, a.edge2_order, a.skipped, a.vertices_from_odometry) == (
        b.fixed,
        b.edge2_order,
        b.skipped,
        b.vertices_from_odometry,
    )


@pytest.mark.parametrize("name", ["w100.graph", "w10000.graph", "noisyToyGraph.txt"])
@pytest.mark.parametrize("edge2", ["auto", "toro"])
def test_2d_gtsam_files_fast_equals_line_reader(name: str, edge2: str) -> None:
    path = _data(name)
    fast = g2o2d._read_tables(path, edge2)  # type: ignore[arg-type]
    assert fast is not None
    _same_2d(fast, g2o2d._read_lines(path, edge2))  # type: ignore[arg-type]


def _lines_2d(seed: int = 0) -> list[str]:
    rng = np.random.default_rng(seed)
    lines = ["# 2-D", ""]
    for k in range(6):
        tag = "VERTEX2" if k % 2 else "VERTEX_SE2"
        lines.append(f"{tag} {k} " + " ".join(repr(float(x)) for x in rng.normal(size=3)))
    for k in range(5):
        tag = "EDGE2" if k % 2 else "EDGE_SE2"
        A = rng.normal(size=(3, 3))
        lam = A @ A.T + 3 * np.eye(3)
        nums = [*rng.normal(size=3), *lam[np.triu_indices(3)]]
        lines.append(f"{tag} {k} {k + 1} " + " ".join(repr(float(x)) for x in nums))
    lines += ["EQUIV 1 2", "FIX 0   # first", "EQUIV 3 4"]
    return lines


def test_2d_mixed_types_comments_equiv_and_fix(tmp_path: Path) -> None:
    path = _write(tmp_path, _lines_2d())
    fast = g2o2d._read_tables(path, "auto")
    assert fast is not None
    _same_2d(fast, g2o2d._read_lines(path, "auto"))
    assert fast.skipped == (("EQUIV", 2),) and fast.fixed == (0,)
    assert fast.vertex_ids.tolist() == list(range(6))


@pytest.mark.parametrize(
    ("k", "what"),
    [(3, "count"), (4, "word"), (5, "duplicate"), (9, "nan"), (10, "self"), (11, "missing")],
)
def test_2d_malformed_line_gives_the_line_readers_error(tmp_path: Path, k: int, what: str) -> None:
    path = _write(tmp_path, _corrupt(_lines_2d(), k, what))
    msg = _error(lambda: g2o2d.read(path))
    assert msg == _error(lambda: g2o2d._read_lines(path, "auto"))
    assert msg.startswith(f"{path}:{k + 1}: "), msg


def test_2d_and_3d_lines_are_refused_by_the_other_reader(tmp_path: Path) -> None:
    p3 = _write(tmp_path, _graph_lines(3), "three.g2o")
    p2 = _write(tmp_path, _lines_2d(), "two.g2o")
    assert "read it with liebridge.io.g2o.read" in _error(lambda: g2o2d.read(p3))
    assert "read it with liebridge.io.g2o2d.read" in _error(lambda: g2o.read(p2))


def test_missing_file_and_directory_raise_as_the_line_reader_does(tmp_path: Path) -> None:
    for path in (tmp_path / "absent.g2o", tmp_path):
        with pytest.raises(OSError) as fast:
            g2o.read(path)
        with pytest.raises(OSError) as slow:
            g2o._read_lines(path, "g2o", "sqrt_information")
        assert type(fast.value) is type(slow.value) and str(fast.value) == str(slow.value)


@pytest.mark.parametrize("text", ["", "# only a comment\n\n"])
def test_empty_and_comment_only_files_give_empty_graphs_on_both_paths(
    tmp_path: Path, text: str
) -> None:
    path = tmp_path / "e.g2o"
    path.write_text(text)
    fast3 = g2o._read_tables(path, "g2o", "sqrt_information")
    assert fast3 is not None
    _same_3d(fast3, g2o._read_lines(path, "g2o", "sqrt_information"))
    assert fast3.vertex_ids.shape == (0,) and fast3.information.shape == (0, 6, 6)
    fast2 = g2o2d._read_tables(path, "auto")
    assert fast2 is not None
    _same_2d(fast2, g2o2d._read_lines(path, "auto"))


# ----------------------------------------------- EDGE3 only (TORO / iSAM layout)
def _edge3(i: int, j: int, rng: np.random.Generator, S: Any = None, big: bool = False) -> str:
    """An ``EDGE3`` line: translation, roll pitch yaw (pitch away from ±π/2), 21 numbers."""
    rpy = rng.uniform(-np.pi, np.pi, size=3) * (1.0 if big else 0.2)
    rpy[1] = np.clip(rpy[1], -1.4, 1.4)
    if S is None:
        # diagonally dominant: positive definite read as S (SᵀS) or as the information itself
        S = np.triu(rng.uniform(-0.8, 0.8, size=(6, 6)), 1) + np.diag(rng.uniform(5, 50, 6))
    nums = [*rng.normal(size=3) * 3, *rpy, *np.asarray(S)[np.triu_indices(6)]]
    return f"EDGE3 {i} {j} " + " ".join(repr(float(x)) for x in nums)


def _edge3_graph(layout: str, n: int, seed: int = 0, first: int = 0) -> list[str]:
    """EDGE3-only files: odometry in several shapes, loop closures, varied or shared numbers."""
    rng = np.random.default_rng(seed)
    shared = np.diag([10.0, 10.0, 10.0, 100.0, 100.0, 25.0])  # sphere2500's numbers
    S = shared if layout == "shared" else None
    ids = [first + k for k in range(n)]
    lines = [_edge3(ids[k], ids[k + 1], rng, S, big=layout == "big") for k in range(n - 1)]
    for _ in range(n // 3):  # loop closures: not odometry
        a, b = sorted(int(x) for x in rng.choice(n, 2, replace=False))
        if b > a + 1:
            lines.append(_edge3(ids[a], ids[b], rng, S))
    if layout == "reversed":  # (k, k-1) edges, some alone (inverted), some besides (k-1, k)
        for k in range(1, n, 3):
            lines[k - 1] = _edge3(ids[k], ids[k - 1], rng)  # alone: the last of them is used
            lines.append(_edge3(ids[k], ids[k - 1], rng))
        for k in range(2, n, 5):
            lines.append(_edge3(ids[k], ids[k - 1], rng))  # a (k-1, k) exists: ignored
            lines.insert(0, _edge3(ids[k - 1], ids[k], rng))  # two (k-1, k): the first wins
    if layout in ("shuffled", "reversed"):
        order = rng.permutation(len(lines))
        lines = [lines[k] for k in order]
    return lines


@pytest.mark.parametrize("layout", ["chain", "shared", "big", "shuffled", "reversed"])
@pytest.mark.parametrize(
    ("information", "edge3"),
    [("g2o", "sqrt_information"), ("g2o", "information"), ("gtsam", "sqrt_information")],
)
def test_edge3_only_fast_equals_line_reader(
    tmp_path: Path, layout: str, information: str, edge3: str
) -> None:
    """1,100 vertices: the blocked scan runs two levels of blocks and a tail."""
    path = _write(tmp_path, _edge3_graph(layout, 1100, first=7))
    g = _fast_equals_slow_3d(path, information=information, edge3=edge3)
    assert g.vertices_from_odometry
    assert g.vertex_ids.tolist() == list(range(7, 1107))


def test_edge3_near_2_64_and_small_chains(tmp_path: Path) -> None:
    for n, first in ((2, 0), (3, 5), (33, 0), (40, 2**64 - 41)):
        path = _write(tmp_path, _edge3_graph("reversed", n, seed=n, first=first))
        g = _fast_equals_slow_3d(path)
        assert g.vertex_ids.tolist() == list(range(first, first + n))


def test_edge3_chunk_boundaries(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    path = _write(tmp_path, ["# TORO", *_edge3_graph("shuffled", 50), "# end"])
    monkeypatch.setattr(g2o, "_CHUNK", 7)
    monkeypatch.setattr(g2o, "_STREAM_ROWS", 6)  # rows parsed and converted 6 at a time
    _fast_equals_slow_3d(path)
    _fast_equals_slow_3d(path, information="gtsam")


@pytest.mark.parametrize(
    ("drop", "message"),
    [
        ("gap", "no vertex lines and no odometry edge 10 -> 11"),  # ids 0..9 and 11..
        ("no_odometry", "no vertex lines and no odometry edge 4 -> 5"),  # 5 only in a loop
    ],
)
def test_edge3_chain_gaps_name_the_missing_edge(tmp_path: Path, drop: str, message: str) -> None:
    rng = np.random.default_rng(1)
    if drop == "gap":
        lines = [_edge3(k, k + 1, rng) for k in range(19) if k not in (9, 10)]  # 10 absent
    else:
        lines = [_edge3(k, k + 1, rng) for k in range(10) if k != 4]
        lines.append(_edge3(2, 5, rng))
    path = _write(tmp_path, lines)
    msg = _error(lambda: g2o.read(path))
    assert msg == _error(lambda: g2o._read_lines(path, "g2o", "sqrt_information"))
    assert message in msg, msg


@pytest.mark.parametrize("header", [True, False])  # False: the file starts with EDGE3
@pytest.mark.parametrize(
    "what", ["count", "word", "nan", "inf", "self", "id_negative", "id_2_64", "tag"]
)
def test_malformed_edge3_line_keeps_its_message_and_line(
    tmp_path: Path, what: str, header: bool
) -> None:
    lines = ["# TORO"] * header + _edge3_graph("chain", 12)
    k = 6  # line 7 of the file
    path = _write(tmp_path, _corrupt(lines, k, what))
    msg = _error(lambda: g2o.read(path))
    assert msg == _error(lambda: g2o._read_lines(path, "g2o", "sqrt_information"))
    assert msg.startswith(f"{path}:{k + 1}: "), msg


def test_edge3_information_overflow_names_its_line(tmp_path: Path) -> None:
    rng = np.random.default_rng(2)
    lines = [_edge3(k, k + 1, rng) for k in range(6)]
    lines[3] = _edge3(3, 4, rng, S=np.diag([1e200, 1.0, 1.0, 1.0, 1.0, 1.0]))  # SᵀS: inf
    path = _write(tmp_path, lines)
    assert g2o._read_tables(path, "g2o", "sqrt_information") is None
    msg = _error(lambda: g2o.read(path))
    assert msg == _error(lambda: g2o._read_lines(path, "g2o", "sqrt_information"))
    assert msg.startswith(f"{path}:4: "), msg


@pytest.mark.parametrize("seed", range(3))
def test_closed_form_euler_quaternion_matches_the_matrix_route(seed: int) -> None:
    from liebridge.conventions.rotation_coords import euler_to_matrix
    from liebridge.lie import quaternion as quat

    rng = np.random.default_rng(seed)
    rpy = rng.uniform(-np.pi, np.pi, size=(500, 3))
    rpy[:, 1] /= 2.0
    rpy[:5] = [[0, 0, 0], [np.pi, 0, 0], [0, 0, np.pi], [1e-12, -1e-12, 3.0], [3.1, 1.5, -3.1]]
    q = g2o._rpy_quaternion(rpy)
    ref = quat.from_matrix(euler_to_matrix(rpy, "euler_rpy"), order="xyzw")
    sign = np.where(np.sum(q * ref, axis=-1) < 0, -1.0, 1.0)  # w = 0 exactly: either sign
    np.testing.assert_allclose(q, sign[:, None] * ref, rtol=0, atol=1e-15)
    assert (q[:, 3] >= 0).all()
    np.testing.assert_allclose(
        quat.to_matrix(q, order="xyzw"), euler_to_matrix(rpy, "euler_rpy"), rtol=0, atol=1e-15
    )


@pytest.mark.parametrize("n", [1, 2, 32, 33, 1025, 1100])
def test_prefix_compose_equals_the_left_to_right_product(n: int) -> None:
    from liebridge.lie import quaternion as quat

    rng = np.random.default_rng(n)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    t = rng.normal(size=(n, 3)) * 10
    Q, T = g2o._prefix_compose(q, t)
    M = np.eye(4)
    for k in range(n):
        S = np.eye(4)
        S[:3, :3], S[:3, 3] = quat.to_matrix(q[k], order="xyzw"), t[k]
        M = M @ S
        np.testing.assert_allclose(quat.to_matrix(Q[k], order="xyzw"), M[:3, :3], atol=1e-12)
        np.testing.assert_allclose(T[k], M[:3, 3], atol=1e-12 * max(1.0, np.abs(M).max()))


@pytest.mark.parametrize(
    "variant",
    ["plain", "no_final_newline", "crlf", "comment", "blank", "fix", "vertex", "tab", "bare_cr"],
)
def test_edge3_first_files_take_the_shortcut_or_fall_back(tmp_path: Path, variant: str) -> None:
    """A file starting with ``EDGE3`` is read without the tag pass when it is nothing else."""
    lines = _edge3_graph("chain", 40)
    end, tail = "\n", ""
    if variant == "crlf":
        end = "\r\n"
    elif variant == "comment":
        lines.insert(20, "# a comment")
    elif variant == "blank":
        lines.insert(20, "")
    elif variant == "fix":
        lines.append("FIX 0")
    elif variant == "vertex":
        lines.append("VERTEX3 0 0 0 0 0 0 0")
    elif variant == "tab":
        lines[5] = lines[5].replace(" ", "\t", 3)
    text = end.join(lines) + end
    if variant == "no_final_newline":
        text = text[:-1]
    if variant == "bare_cr":  # a lone carriage return: two lines for Python, one for the count
        text = text.replace("\n", "\r", 1)
    path = tmp_path / "g.g2o"
    path.write_bytes((text + tail).encode())
    shortcut = g2o._read_edge3_only(path, {"EDGE3": (2, 27)}, g2o._Edge3Sink("g2o", "information"))
    assert (shortcut is not None) == (variant not in ("fix", "vertex"))
    if variant == "vertex":  # vertex lines: every edge's vertices need one
        msg = _error(lambda: g2o.read(path))
        assert msg == _error(lambda: g2o._read_lines(path, "g2o", "sqrt_information"))
        assert "which has no VERTEX line" in msg
        return
    g = _fast_equals_slow_3d(path)
    assert g.edges.shape[0] == sum(ln.startswith("EDGE3") for ln in lines)
    assert g.fixed == ((0,) if variant == "fix" else ())


def test_edge3_underscore_number_is_read_as_python_reads_it(tmp_path: Path) -> None:
    lines = _edge3_graph("chain", 5)
    path = _write(tmp_path, _corrupt(lines, 2, "underscore"))  # field 4 (y) = "1_0.5"
    assert g2o._read_tables(path, "g2o", "sqrt_information") is None
    assert g2o.read(path).measured_xyz_qxyzw[2, 1] == 10.5


def test_edge3_shortcut_estimates_grows_and_refuses_comment_blocks(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """Rows sized from the first chunk's bytes: longer lines later make the arrays grow."""
    monkeypatch.setattr(g2o, "_STREAM_ROWS", 4)
    monkeypatch.setattr(g2o, "_EDGE3_SLACK_ROWS", 0)
    sizes: list[int] = []
    resize = g2o._Edge3Sink.resize

    def spy(self: g2o._Edge3Sink, n: int, keep: int) -> None:
        sizes.append(n)
        resize(self, n, keep)

    monkeypatch.setattr(g2o._Edge3Sink, "resize", spy)
    lines = _edge3_graph("chain", 60)
    lines[:8] = [" ".join(ln.split()[:3] + ["0"] * 27) for ln in lines[:8]]  # short lines first
    lines[8:20] = [ln.replace(" ", "   ") for ln in lines[8:20]]  # then long ones
    path = _write(tmp_path, lines)
    sink = g2o._Edge3Sink("g2o", "sqrt_information")
    assert g2o._read_edge3_only(path, {"EDGE3": (2, 27)}, sink) is not None
    assert sink.info.shape[0] == len(lines)
    assert len(sizes) > 2 and sizes[-2] > sizes[0]  # grown at least once, then trimmed
    _fast_equals_slow_3d(path)
    lines = _edge3_graph("chain", 20)
    path = _write(tmp_path, [*lines[:8], *["# c"] * 4, *lines[8:]])  # a chunk of comments only
    sink = g2o._Edge3Sink("g2o", "sqrt_information")
    assert g2o._read_edge3_only(path, {"EDGE3": (2, 27)}, sink) is None
    _fast_equals_slow_3d(path)
