"""Property tests (hypothesis) over every file reader and the command line's number parsers.

Valid files are generated with numbers anywhere in float64's finite range (``-0.0``,
subnormals, 1e308, several exact spellings), ids up to ``2**64 − 2`` and quaternions off unit
norm by up to 1e-9; each is parsed, written and parsed again, and the two parses must agree
**bit for bit** (g2o: every array; KITTI: the matrices; TUM: timestamps and translations bit for
bit, rotations to 4e-15 — a matrix → quaternion → matrix cycle is not an exact bijection in
floating point). Corrupted files (one field replaced by NaN/Inf/a word, a field dropped or added)
must raise one ``ValueError`` of one line that names the file, the 1-based line and the field.
The command line's number parser must read back any ``repr``-printed vector exactly, keep a file's
shape, and refuse a bad token in one line naming the option and the token.
"""

from __future__ import annotations

import argparse
import math
import re
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from liebridge._validate import MAX_KEY
from liebridge.cli._common import MAX_INT, CLIError, array_argument, positive_int
from liebridge.io import g2o
from liebridge.io import trajectory as tio

FINITE = st.floats(allow_nan=False, allow_infinity=False)
SPELLINGS = [repr, lambda x: f"{x:.17g}", lambda x: f"{x:.17e}", lambda x: f"{x!r}".upper()]
BAD_TOKENS = ["nan", "inf", "-inf", "NaN", "abc", "1.0.0", "0x10", "--1"]


def bits(a: np.ndarray) -> bytes:
    return np.ascontiguousarray(a).tobytes()


def spell(x: float, how: int) -> str:
    if x == 0.0 and how == 3:
        return "-0e400" if math.copysign(1.0, x) < 0 else "0e400"  # finite: 0.0
    return SPELLINGS[how % len(SPELLINGS)](x)


def unit_quaternion(rng: np.random.Generator, scale: float) -> list[float]:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    if rng.random() < 0.3:
        q[int(rng.integers(0, 4))] = 0.0
        q /= np.linalg.norm(q)
        q[q == 0.0] = -0.0
    return (q * scale).tolist()


# --------------------------------------------------------------------------- g2o
@st.composite
def g2o_files(draw: st.DrawFn) -> tuple[str, int]:
    """A valid VERTEX_SE3:QUAT / EDGE_SE3:QUAT / FIX file and the number of edges."""
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    n = draw(st.integers(2, 4))
    ids = draw(
        st.lists(
            st.integers(0, 50) | st.integers(2**63 - 2, MAX_KEY) | st.just(MAX_KEY),
            min_size=n,
            max_size=n,
            unique=True,
        )
    )
    how = draw(st.integers(0, 3))
    lines = []
    for k in ids:
        xyz = [draw(FINITE) for _ in range(3)]
        q = unit_quaternion(rng, 1.0 + draw(st.floats(-1e-9, 1e-9)))
        lines.append(f"VERTEX_SE3:QUAT {k} " + " ".join(spell(x, how) for x in xyz + q))
    m = draw(st.integers(0, 3))
    for _ in range(m):
        i, j = rng.choice(len(ids), size=2, replace=False)
        xyz = [draw(FINITE) for _ in range(3)]
        q = unit_quaternion(rng, 1.0)
        s = draw(st.sampled_from([1e-150, 1e-3, 1.0, 1e150, 1e300]))
        B = rng.uniform(-0.5, 0.5, size=(6, 6))
        info = s * (6.0 * np.eye(6) + 0.5 * (B + B.T))
        if rng.random() < 0.3:
            info = np.diag(np.diag(info))
            info[np.triu_indices(6, 1)] = -0.0
        nums = xyz + q + info[np.triu_indices(6)].tolist()
        lines.append(f"EDGE_SE3:QUAT {ids[i]} {ids[j]} " + " ".join(spell(x, how) for x in nums))
    if draw(st.booleans()):
        lines.append(f"FIX {ids[0]}")
    return "\n".join(lines) + "\n", m


def _same_graph(a: g2o.G2OGraph, b: g2o.G2OGraph) -> None:
    for name in ("vertex_ids", "edges", "vertex_xyz_qxyzw", "measured_xyz_qxyzw", "information"):
        assert bits(getattr(a, name)) == bits(getattr(b, name)), name
    assert a.fixed == b.fixed


@given(g2o_files(), st.sampled_from(["g2o", "gtsam"]))
def test_g2o_parse_write_parse_is_bit_exact(case: tuple[str, int], reading: str) -> None:
    text, _ = case
    with tempfile.TemporaryDirectory() as d:
        p, out = Path(d) / "in.g2o", Path(d) / "out.g2o"
        p.write_text(text)
        g1 = g2o.read(p, reading)  # type: ignore[arg-type]
        # the poses' numbers are kept as written (quaternions off unit norm are normalised)
        first = text.splitlines()[0].split()
        assert bits(g1.vertex_xyz_qxyzw[0, :3]) == bits(np.array([float(f) for f in first[2:5]]))
        g2o.write(out, g1)
        g2 = g2o.read(out, reading)  # type: ignore[arg-type]
        _same_graph(g1, g2)
        g2o.write(out, g2)
        _same_graph(g2, g2o.read(out, reading))  # type: ignore[arg-type]


def _corrupt(
    draw: st.DrawFn, text: str, first_numeric: dict[str, int]
) -> tuple[str, int, int | None]:
    """Corrupt one field of one line: (new text, 1-based line, 1-based field or None)."""
    lines = text.splitlines()
    k = draw(st.integers(0, len(lines) - 1))
    fields = lines[k].split()
    lo = first_numeric.get(fields[0], 0)
    if lo >= len(fields):
        lo = len(fields) - 1
    kind = draw(st.sampled_from(["token", "drop", "add"]))
    field: int | None = None
    if kind == "token":
        f = draw(st.integers(lo, len(fields) - 1))
        fields[f] = draw(st.sampled_from(BAD_TOKENS))
        field = f + 1
    elif kind == "drop":
        del fields[draw(st.integers(max(lo, 1), len(fields) - 1))]
    else:
        fields.append("1.0")
    lines[k] = " ".join(fields)
    return "\n".join(lines) + "\n", k + 1, field


def _assert_one_clear_line(exc: Exception, path: Path, line: int, field: int | None) -> None:
    msg = str(exc)
    assert "\n" not in msg, msg
    assert msg.startswith(f"{path}:{line}: "), msg
    if field is not None:
        assert re.search(rf"field {field}\b|vertex id|id .* (is not an integer|outside)", msg), msg


@given(st.data())
def test_g2o_corrupted_file_is_one_line_naming_file_line_and_field(data: st.DataObject) -> None:
    text, _ = data.draw(g2o_files())
    if text.splitlines()[-1].startswith("FIX"):
        text = "\n".join(text.splitlines()[:-1]) + "\n"
    bad, line, field = _corrupt(data.draw, text, {"VERTEX_SE3:QUAT": 2, "EDGE_SE3:QUAT": 3})
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "bad.g2o"
        p.write_text(bad)
        with pytest.raises(ValueError) as info:
            g2o.read(p)
        _assert_one_clear_line(info.value, p, line, field)


def test_g2o_corrupted_id_field_names_the_id(tmp_path: Path) -> None:
    p = tmp_path / "bad.g2o"
    p.write_text("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT x 0 0 0 0 0 0 1\n")
    with pytest.raises(ValueError, match=r"bad\.g2o:2: vertex id 'x' is not an integer"):
        g2o.read(p)


# --------------------------------------------------------------------------- TUM and KITTI
@st.composite
def tum_files(draw: st.DrawFn) -> str:
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    how = draw(st.integers(0, 3))
    rows = []
    for _ in range(draw(st.integers(1, 4))):
        t = draw(FINITE)
        xyz = [draw(FINITE) for _ in range(3)]
        q = unit_quaternion(rng, 1.0 + draw(st.floats(-1e-9, 1e-9)))
        rows.append(" ".join(spell(x, how) for x in [t, *xyz, *q]))
    return "\n".join(rows) + "\n"


@st.composite
def kitti_files(draw: st.DrawFn) -> str:
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    how = draw(st.integers(0, 3))
    rows = []
    for _ in range(draw(st.integers(1, 4))):
        R = Rotation.from_rotvec(rng.normal(size=3)).as_matrix()
        M = np.hstack([R, np.array([[draw(FINITE)] for _ in range(3)])])
        rows.append(" ".join(spell(x, how) for x in M.reshape(-1).tolist()))
    return "\n".join(rows) + "\n"


@given(tum_files())
def test_tum_parse_write_parse(text: str) -> None:
    with tempfile.TemporaryDirectory() as d:
        p, out = Path(d) / "in.txt", Path(d) / "out.txt"
        p.write_text(text)
        t1, T1 = tio.read_tum(p, check=False)
        tio.write_tum(out, t1, T1)
        t2, T2 = tio.read_tum(out, check=False)
        assert bits(t2) == bits(t1)
        assert bits(T2[:, :3, 3]) == bits(T1[:, :3, 3])
        assert np.abs(T2[:, :3, :3] - T1[:, :3, :3]).max() <= 4e-15  # a few ulps (1.1e-15 seen)


@given(kitti_files())
def test_kitti_parse_write_parse_is_bit_exact(text: str) -> None:
    with tempfile.TemporaryDirectory() as d:
        p, out = Path(d) / "in.txt", Path(d) / "out.txt"
        p.write_text(text)
        T1 = tio.read_kitti(p).T
        first = np.array([float(f) for f in text.splitlines()[0].split()]).reshape(3, 4)
        assert bits(T1[0, :3]) == bits(first)  # as printed
        tio.write_kitti(out, T1)
        assert bits(tio.read_kitti(out).T) == bits(T1)


@given(st.data(), st.sampled_from(["tum", "kitti"]))
def test_trajectory_corrupted_file_is_one_line_naming_file_line_and_field(
    data: st.DataObject, fmt: str
) -> None:
    text = data.draw(tum_files() if fmt == "tum" else kitti_files())
    bad, line, field = _corrupt(data.draw, text, {})
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / f"bad.{fmt}"
        p.write_text(bad)
        with pytest.raises(ValueError) as info:
            tio.read_tum(p, check=False) if fmt == "tum" else tio.read_kitti(p)
        _assert_one_clear_line(info.value, p, line, field)


# --------------------------------------------------------------------------- command line
SEPARATORS = [" ", ",", ", ", ";", "\t", " ,  "]


@given(
    st.lists(FINITE, min_size=1, max_size=40),
    st.sampled_from(SEPARATORS),
    st.booleans(),
)
def test_number_argument_reads_back_bit_exact(xs: list[float], sep: str, brackets: bool) -> None:
    text = sep.join(repr(x) for x in xs)
    if brackets:
        text = f"[{text}]"
    arr, from_file = array_argument(text, "--cov")
    assert not from_file
    assert bits(arr) == bits(np.array(xs, dtype=np.float64))


@given(
    st.lists(FINITE, min_size=1, max_size=12),
    st.integers(0, 10),
    st.sampled_from(BAD_TOKENS),
)
def test_number_argument_with_a_bad_token_is_one_line(
    xs: list[float], where: int, token: str
) -> None:
    words = [repr(x) for x in xs]
    words.insert(min(where, len(words)), token)
    with pytest.raises(CLIError) as info:
        array_argument(" ".join(words), "--cov")
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith("--cov: ")
    assert repr(token) in msg or "NaN or Inf" in msg, msg


@given(
    st.lists(FINITE, min_size=1, max_size=36),
    st.sampled_from([".npy", ".txt", ".csv"]),
)
def test_array_file_argument_reads_back_bit_exact(xs: list[float], suffix: str) -> None:
    a = np.array(xs, dtype=np.float64)
    if a.size % 6 == 0:
        a = a.reshape(-1, 6)
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / f"a{suffix}"
        if suffix == ".npy":
            np.save(p, a)
        else:
            np.savetxt(p, np.atleast_2d(a), fmt="%.17g", delimiter="," if suffix == ".csv" else " ")
        arr, from_file = array_argument(str(p), "--cov")
    assert from_file
    assert bits(arr.reshape(-1)) == bits(a.reshape(-1))


@given(st.integers(-(2**70), 2**70) | st.sampled_from([0, 1, MAX_INT, MAX_INT + 1]))
def test_positive_int_accepts_exactly_its_range(n: int) -> None:
    if 1 <= n <= MAX_INT:
        assert positive_int(str(n)) == n
    else:
        with pytest.raises(argparse.ArgumentTypeError) as info:
            positive_int(str(n))
        assert "\n" not in str(info.value)
