r"""Trajectory text files: TUM and KITTI, read and written at full float precision.

Old path: also reachable as ``lb.trajectory_io`` (earlier releases); new code writes ``lb.io``.

TUM (TUM RGB-D benchmark, Sturm et al. 2012; also the format of ``evo``)
    One pose per line, ``timestamp tx ty tz qx qy qz qw``: the translation and the Hamilton
    quaternion, scalar **last** (layout ``"xyz_qxyzw"`` in :mod:`liebridge.io.poses`), of
    ``T_world_body``. ``#`` starts a comment (a whole line or the rest of one); commas and tabs
    separate like spaces (as the benchmark's ``associate.py`` accepts); ``\n``, ``\r\n`` and
    old-Mac ``\r`` line ends all read; a UTF-8 byte-order mark is skipped. A first line of
    column **names** (every field a name such as ``timestamp tx ... qw``; with or without ``#``)
    is a header: skipped, and if it names ``qw`` before ``qx`` the quaternion order is taken as
    ``wxyz``. A first line with any number in it is data (``x1.0 0 0 0 0 0 0 1`` is an error
    naming field 1, never a silently skipped header).
KITTI (KITTI odometry ``poses/XX.txt``)
    One pose per line, 12 numbers: the top 3×4 block ``[R | t]`` of ``T_world_camera``,
    row-major (layout ``"kitti"``). No timestamps: the frame index is the stamp.

Every reader returns a :class:`Trajectory` (``stamps``, ``T``, ``cov``, ``frame_id``,
``child_frame_id``, ``source``), which unpacks as ``stamps, T = read_tum(path)``.

Reading validates every line: a wrong number of fields, a field that is not a number, NaN/Inf,
a quaternion off unit by more than ``quat_tolerance`` (default ``1e-3``), or a rotation block that
is not orthonormal raises ``ValueError`` naming the file and the 1-based line number. Real files
are read as they are (:mod:`liebridge.io.sanity`, one policy for every reader): quaternions off
unit within the tolerance are normalised, with an ``ImperfectFileWarning`` naming the worst
deviation when the precision the numbers were printed with
(:func:`liebridge.io.poses.text_quaternion_tol`) does not explain it (a 4-decimal TUM ground truth
reads silently; evo's ``%.18e`` prints of 5-decimal numbers, off by 8e-6, with the warning);
repeated timestamps keep the first of each run with a warning (``duplicates=``). KITTI rotation
blocks are held to :func:`~liebridge.io.poses.text_rotation_tol`. Quaternions are normalised;
KITTI rotation blocks are
returned exactly as printed (project with :func:`liebridge.lie.so3.project` if you need them
orthonormal to machine precision). A well-formed file is parsed in one ``numpy.loadtxt`` pass; a
second, per-line pass runs only to name a fault.

Writing uses ``repr`` of every float (the shortest text that reads back to the same double), so
KITTI files and TUM timestamps and translations round-trip bit for bit. **The one quaternion sign
rule** of every TUM writer (:func:`write_tum`, ``io.write_trajectory``, ``ros.write_tum``, ``bag
export --format tum``): the first quaternion has ``w ≥ 0`` and each next one the sign that makes
``q_i·q_{i−1} ≥ 0`` (hemisphere continuity), so component-wise interpolation and plots of the file
behave; it is a function of the rotations alone (never of the sign a source happened to store).
Tempting and false: "``w ≥ 0`` on every line" — that flips the sign wherever a trajectory turns
through π. Every writer goes through :func:`liebridge.io.atomic.atomic_write` (temporary file and
rename; never through a hard link, never renamed onto a device or FIFO).
"""

from __future__ import annotations

import io as _io
import math
import os
import re
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import IO, Any

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from . import poses as _layouts
from .atomic import atomic_write
from .sanity import (
    QUAT_TOLERANCE,
    QuaternionOrderConflictError,
    check_quaternions,
    hemisphere_continuous,
    repeated_stamps,
    unit_quaternions,
)

__all__ = [
    "Trajectory",
    "read_kitti",
    "read_tum",
    "stamp_text",
    "tum_header_order",
    "write_kitti",
    "write_tum",
    "write_tum_text",
]

PathLike = str | os.PathLike[str]


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A trajectory as read from a file or a bag: stamped poses, optional covariances, frames.

    Returned by :func:`read_tum`, :func:`read_kitti`, :func:`liebridge.io.read_euroc`,
    :func:`liebridge.io.read_trajectory` and :func:`liebridge.ros.read_trajectory`. It unpacks as
    ``stamps, T = trajectory`` (the two arrays earlier releases returned).

    Attributes
    ----------
    stamps : ndarray, shape (N,)
        Seconds (a KITTI file's frame index, as float).
    T : ndarray, shape (N, 4, 4)
        ``T_{frame_id}_{child_frame_id}``: poses of the child frame in the parent frame, rotation
        blocks orthonormal to the precision the source printed.
    cov : ndarray, shape (N, 6, 6), or None
        Pose covariances in the convention named by ``convention`` (files carry none).
    frame_id, child_frame_id : str
        The parent (world) and child (body) frames; ``"world"`` and ``"body"`` when the source
        does not say.
    source : str
        Where it came from: the file path, or ``"BAG:TOPIC"``.
    convention : str or None
        The preset ``cov`` is in (None when ``cov`` is None).
    extra : ndarray, shape (N, K), or None
        Columns after the pose (EuRoC ground truth: velocity, gyroscope and accelerometer biases,
        ``K = 9``); None for formats without them.
    """

    stamps: FloatArray
    T: FloatArray
    cov: FloatArray | None = None
    frame_id: str = "world"
    child_frame_id: str = "body"
    source: str = ""
    convention: str | None = None
    extra: FloatArray | None = None

    def __post_init__(self) -> None:
        n = self.stamps.shape[0] if self.stamps.ndim == 1 else -1
        if n < 0:
            raise ValueError(f"stamps: expected shape (N,), got {self.stamps.shape}")
        if self.T.shape != (n, 4, 4):
            raise ValueError(f"T: expected shape ({n}, 4, 4) to match stamps, got {self.T.shape}")
        if self.cov is not None and self.cov.shape != (n, 6, 6):
            raise ValueError(f"cov: expected shape ({n}, 6, 6), got {self.cov.shape}")
        if self.extra is not None and (self.extra.ndim != 2 or self.extra.shape[0] != n):
            raise ValueError(f"extra: expected shape ({n}, K), got {self.extra.shape}")
        for name in ("frame_id", "child_frame_id", "source"):
            if not isinstance(getattr(self, name), str):
                raise TypeError(f"{name}: expected str, got {type(getattr(self, name)).__name__}")

    def __len__(self) -> int:
        return int(self.stamps.shape[0])

    def __iter__(self) -> Iterator[FloatArray]:
        """``stamps, T = trajectory``."""
        return iter((self.stamps, self.T))

    def __repr__(self) -> str:
        cov = "" if self.cov is None else f", cov in {self.convention!r}"
        return (
            f"Trajectory({len(self)} poses T_{self.frame_id}_{self.child_frame_id}{cov}, "
            f"source={self.source!r})"
        )


def text_lines(path: PathLike) -> Iterator[tuple[int, str]]:
    """Yield ``(line_number, line)`` of a UTF-8 text file (1-based).

    A byte sequence that is not UTF-8 raises ``ValueError`` naming the file and the line that
    holds it (found by a binary re-scan, since text decoding runs ahead in chunks).
    """
    lineno = 0
    try:
        with open_text(path, "r") as fh:
            for lineno, line in enumerate(fh, start=1):
                yield lineno, line
    except UnicodeDecodeError as exc:
        bad = lineno + 1
        if not isinstance(path, int):  # a descriptor cannot be re-read from the start
            with open(path, "rb") as fb:
                for k, raw in enumerate(fb, start=1):
                    try:
                        raw.decode("utf-8")
                    except UnicodeDecodeError:
                        bad = k
                        break
        raise ValueError(f"{path}:{bad}: not UTF-8 text ({exc.reason})") from None


@contextmanager
def open_text(path: PathLike | int, mode: str) -> Iterator[IO[str]]:
    """Open ``path`` as UTF-8 text for reading (``"r"``) or writing (``"w"``).

    Reading: a file descriptor (int) is used and left open for the caller. Writing goes through
    :func:`liebridge.io.atomic.atomic_write` (a temporary file renamed over ``path`` when
    complete; a hard link is replaced, never written through; a FIFO or character device is
    written directly, never replaced; a descriptor is left open).
    """
    if isinstance(path, bool):
        raise TypeError(f"path: expected a path or a file descriptor, got {path!r}")
    if mode == "w":
        with atomic_write(path, "w") as fh:
            yield fh
        return
    if mode != "r":
        raise ValueError(f"mode: expected 'r' or 'w', got {mode!r}")
    if isinstance(path, int):
        with open(path, encoding="utf-8", closefd=False) as fh:
            yield fh
        return
    with open(path, encoding="utf-8") as fh:
        yield fh


def _data_lines(path: PathLike) -> list[tuple[int, list[str]]]:
    """Non-empty, non-comment lines of ``path`` as ``(line_number, fields)``."""
    out = []
    for lineno, line in text_lines(path):
        body = line.split("#", 1)[0].replace(",", " ")
        fields = body.split()
        if fields:
            out.append((lineno, fields))
    return out


def field_numbers(
    fields: list[str], names: list[str], tag: str = ""
) -> tuple[list[float], str | None]:
    """Parse ``fields`` as finite floats; return them, or a message naming the first bad field.

    ``names`` names each field (``"qx"``, ``"information[0, 1]"``); the message is
    ``"not a number: 'abc' in field 5 (qx)"`` or ``"NaN or Inf in field 5 (qx): 'nan'"``, with
    `` (TAG)`` after the kind of fault when ``tag`` is given. Fields count from 1 within
    ``fields``.
    """
    vals: list[float] = []
    t = f" ({tag})" if tag else ""
    for k, (f, name) in enumerate(zip(fields, names, strict=True)):
        try:
            x = float(f)
        except ValueError:
            return vals, f"not a number: {f!r}{t} in field {k + 1} ({name})"
        if not math.isfinite(x):
            return vals, f"NaN or Inf{t} in field {k + 1} ({name}): {f!r}"
        vals.append(x)
    return vals, None


def _numbers(
    path: PathLike | int, lineno: int, fields: list[str], n: int, what: str
) -> list[float]:
    if len(fields) != n:
        raise ValueError(f"{path}:{lineno}: expected {n} numbers ({what}), got {len(fields)}")
    names = what.split() if len(what.split()) == n else [f"{what} [{k}]" for k in range(n)]
    vals, bad = field_numbers(fields, names)
    if bad is not None:
        raise ValueError(f"{path}:{lineno}: {bad}")
    return vals


def _fmt(x: float) -> str:
    return repr(float(x))


_NAME = re.compile(r"^[A-Za-z_\[\]]")
_TUM_WHAT = "timestamp tx ty tz qx qy qz qw"


def _is_names(fields: Sequence[str]) -> bool:
    """Whether every field is a column name (name-like and not a number: ``nan`` is a number)."""
    if not fields:
        return False
    for f in fields:
        if not _NAME.match(f):
            return False
        try:
            float(f)
        except ValueError:
            continue
        return False
    return True


def _header_order(fields: Sequence[str]) -> str | None:
    """``"wxyz"``/``"xyzw"`` from column names (``qw``, ``q_w``, ``q_RS_w`` ...), else None."""
    names = [n.lower() for n in fields]

    def pos(axis: str) -> int:
        return next((i for i, n in enumerate(names) if n.startswith("q") and n.endswith(axis)), -1)

    iw, ix = pos("w"), pos("x")
    if iw < 0 or ix < 0:
        return None
    return "wxyz" if iw < ix else "xyzw"


def tum_header_order(path: PathLike) -> str | None:
    """Return the quaternion order a TUM file's header names (``"xyzw"``/``"wxyz"``), else None.

    The header is any line of column names before the first data line (``#`` comment lines, as
    the TUM RGB-D ground truths start ``# ground truth trajectory``, ``# file: ...``,
    ``# timestamp tx ty tz qx qy qz qw``; or a first line of names without ``#``) that names
    the quaternion columns; ``qw`` before ``qx`` is ``wxyz``. :func:`read_tum` reads in this
    order unless told another (then it raises), else ``"xyzw"``.
    """
    with open(path, "rb") as fh:
        head = fh.read(1 << 16)
    if head.startswith(b"\xef\xbb\xbf"):
        head = head[3:]
    for line in head.replace(b"\r\n", b"\n").replace(b"\r", b"\n").split(b"\n")[:-1]:
        s = line.strip()
        if not s:
            continue
        try:
            fields = _fields(s.lstrip(b"#"))
        except UnicodeDecodeError:
            return None
        names = _is_names(fields)
        order = _header_order(fields) if names else None
        if order is not None:
            return order
        if not s.startswith(b"#") and not names:
            return None  # the first data line: no header above it names the order
    return None


def read_text_bytes(path: PathLike | int) -> bytes:
    r"""Read a UTF-8 text file as bytes with ``\n`` line ends (``\r\n`` and ``\r`` converted).

    A leading byte-order mark is dropped. A byte sequence that is not UTF-8 raises ``ValueError``
    naming the file and the line that holds it. An int is a file descriptor, read and left open.
    """
    if isinstance(path, bool):
        raise TypeError(f"path: expected a path or a file descriptor, got {path!r}")
    if isinstance(path, int):
        with open(path, "rb", closefd=False) as fh:
            raw = fh.read()
    else:
        with open(path, "rb") as fh:
            raw = fh.read()
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]
    if b"\r" in raw:
        raw = raw.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    if not raw.isascii():
        try:
            raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            line = raw.count(b"\n", 0, exc.start) + 1
            raise ValueError(f"{path}:{line}: not UTF-8 text ({exc.reason})") from None
    return raw


def _first_line(raw: bytes) -> tuple[int, int]:
    """Start and end offsets of the first non-blank line of ``raw`` (``(0, 0)`` if none)."""
    pos = 0
    while pos < len(raw):
        nl = raw.find(b"\n", pos)
        end = len(raw) if nl < 0 else nl
        if raw[pos:end].strip():
            return pos, end
        pos = end + 1
    return 0, 0


def _fields(line: bytes) -> list[str]:
    """Split one line into fields before any ``#``, commas and tabs separating like spaces."""
    body = line.split(b"#", 1)[0].replace(b",", b" ").replace(b"\t", b" ")
    return [f.decode() for f in body.split()]


def read_tum(
    path: PathLike | int,
    *,
    quat_order: str | None = None,
    check: bool = True,
    duplicates: str = "first",
    quat_tolerance: float = QUAT_TOLERANCE,
) -> Trajectory:
    """Read a TUM trajectory file.

    Parameters
    ----------
    path : str, os.PathLike or int
        Text file with lines ``timestamp tx ty tz qx qy qz qw`` (see the module docstring for
        comments, separators, line ends and the header rule). An int is a file descriptor, read
        and left open.
    quat_order : {"xyzw", "wxyz"}, optional
        Storage order of the quaternion columns; default: from the header if it names them, else
        ``"xyzw"`` (TUM's). A header that names the other order wins:
        :class:`~liebridge.io.sanity.QuaternionOrderConflictError`, never a silent misreading.
    check : bool
        Run :func:`liebridge.io.sanity.check_quaternions` with the positions (a
        :class:`~liebridge.io.sanity.QuaternionOrderWarning` saying how sure it is, never an
        error): the order check weighs ``xyzw`` against ``wxyz`` by the direction of travel.
    duplicates : {"first", "last", "error"}
        Repeated timestamps (equal consecutive stamps, as TUM ``fr2/desk`` ground truth has):
        keep the first of each run and warn with the count
        (:class:`~liebridge.io.sanity.ImperfectFileWarning`), keep the last, or raise
        :class:`~liebridge.io.sanity.RepeatedStampError`.
    quat_tolerance : float
        Quaternions off unit by at most this (default ``1e-3``) are normalised, with a warning
        naming the worst deviation when the printed precision does not explain it; beyond it
        :class:`~liebridge.io.sanity.QuaternionNormError` names the file, line and deviation.

    Returns
    -------
    Trajectory
        ``stamps`` (N,) seconds and ``T`` (N, 4, 4) ``T_world_body`` with the quaternions
        normalised; ``cov`` None. An empty file (comments only) gives N = 0.

    Raises
    ------
    ValueError
        On a malformed line, naming the file and line number: wrong number of fields, a field
        that is not a number (a first line mixing names and numbers included), NaN/Inf, a
        quaternion norm off by more than ``quat_tolerance``; not UTF-8; a header order
        contradicting ``quat_order``; a repeated stamp under ``duplicates="error"``.
    """
    if quat_order is not None and quat_order not in ("xyzw", "wxyz"):
        raise ValueError(f"quat_order: expected 'xyzw' or 'wxyz', got {quat_order!r}")
    data, raw, header_order = _tum_fast(path)
    if data is None:  # anything unusual: the bytes, cleaned, and a line-by-line diagnosis
        raw = read_text_bytes(path)
        lo, hi = _first_line(raw)
        header_order = None
        if hi > lo:
            first = raw[lo:hi].strip()
            commented = first.startswith(b"#")
            fields = _fields(first.lstrip(b"#") if commented else first)
            if _is_names(fields):
                header_order = _header_order(fields)
                if not commented:  # a header without '#': made a comment, line numbers kept
                    raw = raw[:lo] + b"#" + raw[lo:]
        if b"," in raw or b"\t" in raw:
            raw = raw.replace(b",", b" ").replace(b"\t", b" ")
        data = _loadtxt(raw, 8)
        if data is None:
            _tum_locate(path, raw)
    assert data is not None
    if header_order is None and not isinstance(path, int) and len(data):
        header_order = tum_header_order(path)  # a names line below other comment lines
    if quat_order is not None and header_order is not None and quat_order != header_order:
        names = "qw qx qy qz" if header_order == "wxyz" else "qx qy qz qw"
        raise QuaternionOrderConflictError(
            f"{path}: the header names the quaternion columns {names} ({header_order}), "
            f"contradicting the order asked for, {quat_order}",
            "the header wins: drop quat_order (or fix the header)",
        )
    order = quat_order or header_order or "xyzw"
    text: list[bytes | None] = [raw]

    def rows(rs: list[int]) -> dict[int, tuple[int, list[str]]]:
        if text[0] is None:
            text[0] = read_text_bytes(path).replace(b",", b" ").replace(b"\t", b" ")
        return _rows_text(text[0] or b"", rs)

    def line_of(r: int) -> int:
        return rows([r])[r][0]

    def explained(r: int) -> float:
        return _layouts.text_quaternion_tol(rows([r])[r][1][4:8])

    q = unit_quaternions(
        data[:, 4:8], quat_tolerance, source=str(path), lines=line_of, explained=explained
    )
    keep = repeated_stamps(data[:, 0], duplicates, source=str(path), lines=line_of)
    del raw
    text[0] = None  # the bytes are not needed past here
    if keep.size != data.shape[0]:
        data, q = data[keep], q[keep]
    data[:, 4:8] = q
    t = np.ascontiguousarray(data[:, 0])
    if check and len(t):
        check_quaternions(q, order, t, source=str(path), positions=data[:, 1:4])
    return Trajectory(t, _tum_poses(data, order), source=str(path))


def _tum_fast(path: PathLike | int) -> tuple[FloatArray | None, bytes | None, str | None]:
    """One ``numpy.loadtxt`` pass over the file itself, when its start looks plain.

    Returns ``(table or None, None, header order)``: None when the file is a descriptor, starts
    with a byte-order mark or a header without ``#``, or is anything but well formed (commas, a
    bad field, NaN/Inf, not UTF-8): the caller then reads the bytes. Memory ≈ the table.
    """
    if isinstance(path, int):
        return None, None, None
    with open(path, "rb") as fh:
        head = fh.read(1 << 16)
    if head.startswith(b"\xef\xbb\xbf"):
        return None, None, None
    head = head.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    lo, hi = _first_line(head)
    order = None
    if hi > lo:
        first = head[lo:hi].strip()
        commented = first.startswith(b"#")
        try:
            fields = _fields(first.lstrip(b"#") if commented else first)
        except UnicodeDecodeError:
            return None, None, None
        if _is_names(fields):
            if not commented:
                return None, None, None
            order = _header_order(fields)
    with warnings.catch_warnings():  # "input contained no data": an empty table is fine
        warnings.simplefilter("ignore", UserWarning)
        try:
            data = np.loadtxt(path, comments="#", ndmin=2, dtype=np.float64, encoding="utf-8")
        except (ValueError, UnicodeDecodeError):
            return None, None, None
    if data.size == 0:
        data = data.reshape(0, 8)
    if data.shape[1] != 8 or not np.isfinite(data).all():
        return None, None, None
    return data, None, order


def _loadtxt(text: bytes, ncols: int) -> FloatArray | None:
    """All data lines of ``text`` as an ``(N, ncols)`` finite table, or None if any is not."""
    with warnings.catch_warnings():  # "input contained no data": an empty table is fine
        warnings.simplefilter("ignore", UserWarning)
        try:
            data = np.loadtxt(_io.BytesIO(text), comments="#", ndmin=2, dtype=np.float64)
        except ValueError:
            return None
    if data.size == 0:
        data = data.reshape(0, ncols)
    if data.shape[1] != ncols or not np.isfinite(data).all():
        return None
    return data


def _tum_locate(path: PathLike | int, text: bytes) -> None:
    """Name the first malformed data line of ``text`` (the slow path, on failure only)."""
    for k, line in enumerate(text.split(b"\n"), start=1):
        fields = [f.decode() for f in line.split(b"#", 1)[0].split()]
        if fields:
            _numbers(path, k, fields, 8, _TUM_WHAT)
    raise ValueError(f"{path}: cannot parse as a TUM trajectory ({_TUM_WHAT})")


def _rows_text(text: bytes, rows: list[int]) -> dict[int, tuple[int, list[str]]]:
    """``(line_number, fields)`` of the data lines numbered ``rows`` (0-based) of ``text``."""
    wanted = set(rows)
    out: dict[int, tuple[int, list[str]]] = {}
    if not wanted:
        return out
    r = 0
    for k, line in enumerate(text.split(b"\n"), start=1):
        fields = line.split(b"#", 1)[0].split()
        if not fields:
            continue
        if r in wanted:
            out[r] = (k, [f.decode() for f in fields])
            if len(out) == len(wanted):
                break
        r += 1
    return out


#: Rows converted per pass from quaternions to matrices (bounds the temporaries).
_POSE_CHUNK = 1 << 16


def _tum_poses(data: FloatArray, order: str = "xyzw") -> FloatArray:
    T = np.empty((data.shape[0], 4, 4))
    layout = "xyz_qxyzw" if order == "xyzw" else "xyz_qwxyz"
    for lo in range(0, max(data.shape[0], 1), _POSE_CHUNK):
        d = data[lo : lo + _POSE_CHUNK]
        q = d[:, 4:8] / np.linalg.norm(d[:, 4:8], axis=-1, keepdims=True)
        x = np.concatenate([d[:, 1:4], q], axis=-1)
        T[lo : lo + _POSE_CHUNK] = _layouts.to_matrix(x, layout=layout)
    return T


def stamp_text(sec: Any, nanosec: Any) -> list[str]:
    """Exact decimal seconds of integer ``(sec, nanosec)`` stamps, nine decimals, sign-correct.

    ``sec + nanosec·1e-9`` is formed in integers: ``(-2, 500000000)`` (−1.5 s, as ROS stores it
    with a non-negative ``nanosec``) gives ``"-1.500000000"``. Tempting and false:
    ``f"{sec}.{nanosec:09d}"``, which prints ``-2.500000000``.
    """
    s = np.asarray(sec).reshape(-1)
    ns = np.asarray(nanosec).reshape(-1)
    if s.shape != ns.shape:
        raise ValueError(f"nanosec: expected shape {s.shape} to match sec, got {ns.shape}")
    out = []
    for a, b in zip(s.tolist(), ns.tolist(), strict=True):
        total = int(a) * 1_000_000_000 + int(b)
        m = abs(total)
        out.append(f"{'-' if total < 0 else ''}{m // 1_000_000_000}.{m % 1_000_000_000:09d}")
    return out


def tum_quaternions(q_xyzw: Any) -> FloatArray:
    """Apply the one sign rule of the TUM writers: first ``w ≥ 0``, then ``q_i·q_{i−1} ≥ 0``.

    Only signs change (negation is exact), so the stored doubles are kept bit for bit up to sign.
    """
    q = hemisphere_continuous(q_xyzw)
    if len(q) and q[0, 3] < 0:
        q = -q
    return q


#: Rows formatted per write call (bounds the text held at once).
_WRITE_CHUNK = 1 << 15


def write_tum_text(
    path: PathLike | int,
    stamps: Sequence[str],
    xyz: Any,
    q_xyzw: Any,
    *,
    quat_order: str = "xyzw",
    comment: str | None = None,
) -> None:
    """Write a TUM file from stamp texts, positions and quaternions: the one TUM writer.

    :func:`write_tum` (float seconds, poses as matrices) and :func:`liebridge.ros.write_tum`
    (exact ROS stamps via :func:`stamp_text`, the messages' doubles, streamed in batches through
    :func:`write_tum_chunks`) both end here. Positions and quaternions are written with
    ``repr``; quaternions follow :func:`tum_quaternions`.

    Parameters
    ----------
    path : str, os.PathLike or int
        Written through :func:`liebridge.io.atomic.atomic_write`.
    stamps : sequence of str, length N
        The stamp column as it should read.
    xyz : array_like, shape (N, 3)
    q_xyzw : array_like, shape (N, 4)
        Unit quaternions, scalar last.
    quat_order : {"xyzw", "wxyz"}
        Column order in the file; ``"wxyz"`` writes a header that says so (read back by
        :func:`read_tum`).
    comment : str, optional
        Appended to the header line (e.g. the frames).
    """
    write_tum_chunks(path, [(stamps, xyz, q_xyzw)], quat_order=quat_order, comment=comment)


def write_tum_chunks(
    path: PathLike | int,
    chunks: Any,
    *,
    quat_order: str = "xyzw",
    comment: str | None = None,
) -> None:
    """Write a TUM file from an iterable of ``(stamps, xyz, q_xyzw)`` chunks, as they come.

    The same file as :func:`write_tum_text` of the concatenated chunks (the one quaternion sign
    rule carried across chunk boundaries), in memory of one chunk: a bag of any size streams
    through it. Nothing is left at ``path`` if a chunk raises.
    """
    if quat_order not in ("xyzw", "wxyz"):
        raise ValueError(f"quat_order: expected 'xyzw' or 'wxyz', got {quat_order!r}")
    names = "qx qy qz qw" if quat_order == "xyzw" else "qw qx qy qz"
    head = f"# timestamp tx ty tz {names}" + (f"  ({comment})" if comment else "") + "\n"
    if "\n" in head[:-1] or "\r" in head:
        raise ValueError(f"comment: must be one line, got {comment!r}")
    r = repr
    prev: FloatArray | None = None  # the last quaternion written (sign continuity)
    with atomic_write(path, "w") as fh:
        fh.write(head)
        for stamps, xyz, q_xyzw in chunks:
            p = validate.as_float_array(xyz, "xyz")
            n = len(stamps)
            if p.shape != (n, 3):
                raise ValueError(f"xyz: expected shape ({n}, 3) to match stamps, got {p.shape}")
            q = validate.as_float_array(q_xyzw, "q_xyzw")
            if q.shape != (n, 4):
                raise ValueError(f"q_xyzw: expected shape ({n}, 4) to match stamps, got {q.shape}")
            if n == 0:
                continue
            validate.check_finite(p, "xyz", core_ndim=1)
            validate.check_finite(q, "q_xyzw", core_ndim=1)
            q = tum_quaternions(q) if prev is None else hemisphere_continuous(q)
            if prev is not None and float(q[0] @ prev) < 0.0:
                q = -q  # continuity with the previous chunk (negation is exact)
            prev = np.array(q[-1])
            if quat_order == "wxyz":
                q = q[:, [3, 0, 1, 2]]
            for lo in range(0, n, _WRITE_CHUNK):
                fh.writelines(
                    f"{st} {r(a)} {r(b)} {r(c)} {r(d)} {r(e)} {r(f)} {r(g)}\n"
                    for st, (a, b, c), (d, e, f, g) in zip(
                        stamps[lo : lo + _WRITE_CHUNK],
                        p[lo : lo + _WRITE_CHUNK].tolist(),
                        q[lo : lo + _WRITE_CHUNK].tolist(),
                        strict=True,
                    )
                )


def write_tum(
    path: PathLike | int,
    timestamps: Any,
    poses: Any = None,
    *,
    quat_order: str = "xyzw",
    comment: str | None = None,
) -> None:
    """Write a TUM trajectory file (``repr`` precision, the one quaternion sign rule).

    Parameters
    ----------
    path : str, os.PathLike or int
        Written through :func:`liebridge.io.atomic.atomic_write`.
    timestamps : array_like, shape (N,), or Trajectory
        Seconds, written with ``repr`` (−1.5 is ``-1.5``). A :class:`Trajectory` supplies both
        columns (``poses`` then omitted) and its frames as the header comment.
    poses : array_like, shape (N, 4, 4)
        ``T_world_body``; rotation blocks must be orthonormal within
        :data:`liebridge.io.poses.ROTATION_TOL`.
    quat_order : {"xyzw", "wxyz"}
        Column order (TUM's is ``xyzw``; ``wxyz`` is said in the header).
    comment : str, optional
        Appended to the header line.
    """
    if isinstance(timestamps, Trajectory):
        if poses is not None:
            raise TypeError("poses: omit it when passing a Trajectory")
        traj = timestamps
        timestamps, poses = traj.stamps, traj.T
        if comment is None:
            comment = f"T_{traj.frame_id}_{traj.child_frame_id}"
    if poses is None:
        raise TypeError("poses: required (an (N, 4, 4) array) unless timestamps is a Trajectory")
    t = validate.as_float_array(timestamps, "timestamps")
    if t.ndim != 1:
        raise ValueError(f"timestamps: expected shape (N,), got {t.shape}")
    validate.check_finite(t, "timestamps")
    T = validate.pose(poses, "poses")
    if T.ndim != 3 or T.shape[0] != t.shape[0]:
        raise ValueError(
            f"poses: expected shape ({t.shape[0]}, 4, 4) to match timestamps, got {T.shape}"
        )
    x = _layouts.from_matrix(T, layout="xyz_qxyzw")
    stamps = [repr(v) for v in t.tolist()]
    write_tum_text(path, stamps, x[:, :3], x[:, 3:], quat_order=quat_order, comment=comment)


def read_kitti(path: PathLike | int) -> Trajectory:
    """Read a KITTI odometry pose file.

    Parameters
    ----------
    path : str, os.PathLike or int
        Text file with 12 numbers per line, the 3×4 block ``[R | t]`` row-major (``#`` comments,
        commas and tabs, any line ends, as for TUM). An int is a file descriptor, left open.

    Returns
    -------
    Trajectory
        ``T`` (N, 4, 4) ``T_world_camera``, the numbers exactly as printed (rotation not
        projected); ``stamps`` the frame index ``0, 1, ...`` as float (KITTI has no stamps);
        ``child_frame_id`` ``"camera"``.

    Raises
    ------
    ValueError
        On a malformed line (wrong count, not a number, rotation not orthonormal within the
        printed precision), naming the file and line number.
    """
    what = "r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz"  # the 3x4 [R | t], row-major
    raw = read_text_bytes(path)
    if b"," in raw or b"\t" in raw:
        raw = raw.replace(b",", b" ").replace(b"\t", b" ")
    data = _loadtxt(raw, 12)
    if data is None:
        for k, line in enumerate(raw.split(b"\n"), start=1):
            fields = [f.decode() for f in line.split(b"#", 1)[0].split()]
            if fields:
                _numbers(path, k, fields, 12, what)
        raise ValueError(f"{path}: cannot parse as a KITTI pose file ({what})")
    errs, dets = _rotation_errors(data.reshape(-1, 3, 4)[:, :, :3])
    suspect = np.flatnonzero((errs > _layouts.ROTATION_TOL) | (dets < 0)).tolist()
    for r, (lineno, fields) in sorted(_rows_text(raw, suspect).items()):
        tol = _layouts.text_rotation_tol([fields[i] for i in (0, 1, 2, 4, 5, 6, 8, 9, 10)])
        if errs[r] > tol or dets[r] < 0:
            raise ValueError(
                f"{path}:{lineno}: rotation block is not a rotation: max|RᵀR − I| = "
                f"{errs[r]:.3g} (tolerance {tol:g}), det = {float(dets[r]):.3g}"
            )
    del raw
    T = _kitti_poses(data)
    stamps = np.arange(T.shape[0], dtype=np.float64)
    return Trajectory(stamps, T, child_frame_id="camera", source=str(path))


def _rotation_errors(R: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``max|RᵀR − I|`` and ``det R`` per row of ``R`` (N, 3, 3), in bounded-memory chunks."""
    err, det = np.zeros(R.shape[0]), np.zeros(R.shape[0])
    for lo in range(0, R.shape[0], _POSE_CHUNK):
        Rc = R[lo : lo + _POSE_CHUNK]
        G = np.einsum("nki,nkj->nij", Rc, Rc) - np.eye(3)
        err[lo : lo + _POSE_CHUNK] = np.abs(G).max(axis=(-1, -2))
        det[lo : lo + _POSE_CHUNK] = np.linalg.det(Rc)
    return err, det


def _kitti_poses(data: FloatArray) -> FloatArray:
    T = np.zeros((data.shape[0], 4, 4))
    T[:, :3, :] = data.reshape(-1, 3, 4)
    T[:, 3, 3] = 1.0
    return T


def write_kitti(path: PathLike | int, poses: Any) -> None:
    """Write a KITTI odometry pose file (12 numbers per line, ``repr`` precision).

    Parameters
    ----------
    path : str, os.PathLike or int
        Written through :func:`liebridge.io.atomic.atomic_write`.
    poses : array_like, shape (N, 4, 4), or Trajectory
        Rotation blocks must be orthonormal within :data:`liebridge.io.poses.ROTATION_TOL`.
    """
    if isinstance(poses, Trajectory):
        poses = poses.T
    T = validate.pose(poses, "poses")
    if T.ndim != 3:
        raise ValueError(f"poses: expected shape (N, 4, 4), got {T.shape}")
    x = _layouts.from_matrix(T, layout="kitti")
    with atomic_write(path, "w") as fh:
        for lo in range(0, x.shape[0], _WRITE_CHUNK):
            fh.writelines(
                " ".join(map(repr, xi)) + "\n" for xi in x[lo : lo + _WRITE_CHUNK].tolist()
            )
