"""Trajectory text files: TUM and KITTI, read and written at full float precision.

Old path: also reachable as ``lb.trajectory_io`` (earlier releases); new code writes ``lb.io``.

TUM (TUM RGB-D benchmark, Sturm et al. 2012; also the format of ``evo``)
    One pose per line, ``timestamp tx ty tz qx qy qz qw``: the translation and the Hamilton
    quaternion, scalar **last** (layout ``"xyz_qxyzw"`` in :mod:`liebridge.io.poses`), of
    ``T_world_body``. Lines starting with ``#`` (and anything after a ``#``) are comments; commas
    and tabs separate like spaces (as the benchmark's ``associate.py`` accepts).
KITTI (KITTI odometry ``poses/XX.txt``)
    One pose per line, 12 numbers: the top 3×4 block ``[R | t]`` of ``T_world_camera``,
    row-major (layout ``"kitti"``). No timestamps.

Reading validates every line: a wrong number of fields, a field that is not a number, NaN/Inf,
a quaternion whose norm is off, or a rotation block that is not orthonormal raises ``ValueError``
naming the file and the 1-based line number. The tolerances follow the precision the numbers were
printed with (:func:`liebridge.io.poses.text_quaternion_tol`,
:func:`~liebridge.io.poses.text_rotation_tol`): a 4-decimal TUM ground truth loads, a
``repr``-precision file is held to ``1e-6``. Quaternions are normalised; KITTI rotation blocks are
returned exactly as printed (project with :func:`liebridge.lie.so3.project` if you need them
orthonormal to machine precision).

Writing uses ``repr`` of every float (the shortest text that reads back to the same double), so
KITTI files and TUM timestamps and translations round-trip bit for bit; TUM quaternions are
written with ``w ≥ 0``.
"""

from __future__ import annotations

import io as _io
import math
import os
import secrets
import shutil
import warnings
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from typing import IO, Any

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from . import poses as _layouts

__all__ = ["read_kitti", "read_tum", "write_kitti", "write_tum"]

PathLike = str | os.PathLike[str]


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

    * A file descriptor (int) is used and left open for the caller (``open(fd)`` would close
      it on exit).
    * Writing a path that is a regular file or does not exist goes to a temporary file in the
      same directory, renamed over ``path`` when complete: a failed write leaves ``path`` as it
      was, and a hard link to another file (an input) is replaced, never written through
      (class 10). Other paths (``/dev/null``, a pipe) are written directly.
    """
    if isinstance(path, bool):
        raise TypeError(f"path: expected a path or a file descriptor, got {path!r}")
    if isinstance(path, int):
        with open(path, mode, encoding="utf-8", closefd=False) as fh:
            yield fh
        return
    if mode != "w" or (os.path.exists(path) and not os.path.isfile(path)):
        with open(path, mode, encoding="utf-8") as fh:
            yield fh
        return
    target = os.fspath(path)
    tmp = os.path.join(
        os.path.dirname(os.path.abspath(target)), f".liebridge-{secrets.token_hex(8)}.tmp"
    )
    # a new file: created with mode 0o666 minus the umask, as open(path, "w") would do
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with open(fd, "w", encoding="utf-8") as fh:
            yield fh
        if os.path.exists(target):
            shutil.copymode(target, tmp)
        os.replace(tmp, target)
    except BaseException:
        with suppress(OSError):
            os.unlink(tmp)
        raise


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


def _numbers(path: PathLike, lineno: int, fields: list[str], n: int, what: str) -> list[float]:
    if len(fields) != n:
        raise ValueError(f"{path}:{lineno}: expected {n} numbers ({what}), got {len(fields)}")
    names = what.split() if len(what.split()) == n else [f"{what} [{k}]" for k in range(n)]
    vals, bad = field_numbers(fields, names)
    if bad is not None:
        raise ValueError(f"{path}:{lineno}: {bad}")
    return vals


def _fmt(x: float) -> str:
    return repr(float(x))


def _fast_table(path: PathLike, ncols: int) -> FloatArray | None:
    """All data lines of ``path`` as a ``(N, ncols)`` table in one ``numpy.loadtxt`` pass.

    Returns ``None`` whenever the file is anything but well formed UTF-8 with ``ncols`` finite
    numbers on every data line (a header without ``#``, a bad field, a wrong count, NaN/Inf):
    the caller then runs its line-by-line reader, which names the line and the fault exactly.
    Memory: the file's bytes, one cleaned copy and the table (1.7 GB for a 10⁶-line
    TUM file read line by line).
    """
    if isinstance(path, int):
        return None
    with warnings.catch_warnings():  # "input contained no data": an empty table is fine
        warnings.simplefilter("ignore", UserWarning)
        try:  # the file itself, read in chunks by numpy: memory ≈ the table
            data = np.loadtxt(path, comments="#", ndmin=2, dtype=np.float64, encoding="utf-8")
        except ValueError:  # commas, tabs, a BOM, not UTF-8 or a bad line: bytes, cleaned
            with open(path, "rb") as fh:
                raw = fh.read()
            try:
                raw.decode("utf-8")
            except UnicodeDecodeError:
                return None
            if raw.startswith(b"\xef\xbb\xbf"):
                raw = raw[3:]
            text = raw.replace(b",", b" ").replace(b"\t", b" ")
            del raw
            try:
                data = np.loadtxt(_io.BytesIO(text), comments="#", ndmin=2, dtype=np.float64)
            except ValueError:
                return None
    if data.size == 0:
        data = data.reshape(0, ncols)
    if data.shape[1] != ncols or not np.isfinite(data).all():
        return None
    return data


def _data_line_text(path: PathLike, rows: list[int]) -> dict[int, tuple[int, list[str]]]:
    """``(line_number, fields)`` of the data lines numbered ``rows`` (0-based) of ``path``."""
    wanted = set(rows)
    out: dict[int, tuple[int, list[str]]] = {}
    if not wanted:
        return out
    with open(path, "rb") as fh:
        raw = fh.read()
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]
    r = 0
    for k, line in enumerate(raw.split(b"\n"), start=1):
        fields = line.split(b"#", 1)[0].replace(b",", b" ").split()
        if not fields:
            continue
        if r in wanted:
            out[r] = (k, [f.decode() for f in fields])
            if len(out) == len(wanted):
                break
        r += 1
    return out


def read_tum(path: PathLike) -> tuple[FloatArray, FloatArray]:
    """Read a TUM trajectory file.

    Parameters
    ----------
    path : str or os.PathLike
        Text file with lines ``timestamp tx ty tz qx qy qz qw``.

    Returns
    -------
    timestamps : ndarray, shape (N,)
    poses : ndarray, shape (N, 4, 4)
        ``T_world_body`` with the quaternion normalised.

    Raises
    ------
    ValueError
        On a malformed line, naming the file and line number.
    """
    what = "timestamp tx ty tz qx qy qz qw"
    fast = _fast_table(path, 8)
    if fast is not None:  # one loadtxt pass; quaternions judged by their text below
        data = fast
        err = np.abs(np.linalg.norm(data[:, 4:8], axis=-1) - 1.0)
        suspect = np.flatnonzero(err > _layouts.QUATERNION_TOL).tolist()
        for r, (lineno, fields) in sorted(_data_line_text(path, suspect).items()):
            tol = _layouts.text_quaternion_tol(fields[4:8])
            if err[r] > tol:
                raise ValueError(
                    f"{path}:{lineno}: quaternion norm off by {err[r]:.3g} (tolerance {tol:g} "
                    f"for numbers printed with this precision)"
                )
        return _tum_poses(data)
    rows, linenos = [], []
    for lineno, fields in _data_lines(path):
        vals = _numbers(path, lineno, fields, 8, what)
        q = np.array(vals[4:8])
        err = abs(float(np.linalg.norm(q)) - 1.0)
        tol = _layouts.text_quaternion_tol(fields[4:8])
        if err > tol:
            raise ValueError(
                f"{path}:{lineno}: quaternion norm off by {err:.3g} (tolerance {tol:g} for "
                f"numbers printed with this precision)"
            )
        rows.append(vals)
        linenos.append(lineno)
    return _tum_poses(np.array(rows, dtype=np.float64).reshape(-1, 8))


#: Rows converted per pass from quaternions to matrices (bounds the temporaries).
_POSE_CHUNK = 1 << 16


def _tum_poses(data: FloatArray) -> tuple[FloatArray, FloatArray]:
    T = np.empty((data.shape[0], 4, 4))
    for lo in range(0, max(data.shape[0], 1), _POSE_CHUNK):
        d = data[lo : lo + _POSE_CHUNK]
        q = d[:, 4:8] / np.linalg.norm(d[:, 4:8], axis=-1, keepdims=True)
        x = np.concatenate([d[:, 1:4], q], axis=-1)
        T[lo : lo + _POSE_CHUNK] = _layouts.to_matrix(x, layout="xyz_qxyzw")
    return data[:, 0].copy(), T


def write_tum(path: PathLike, timestamps: Any, poses: Any) -> None:
    """Write a TUM trajectory file (``repr`` precision, quaternion ``w ≥ 0``).

    Parameters
    ----------
    path : str or os.PathLike
    timestamps : array_like, shape (N,)
    poses : array_like, shape (N, 4, 4)
        ``T_world_body``; rotation blocks must be orthonormal within
        :data:`liebridge.io.poses.ROTATION_TOL`.
    """
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
    lines = ["# timestamp tx ty tz qx qy qz qw\n"]
    lines += [" ".join(map(_fmt, (ti, *xi))) + "\n" for ti, xi in zip(t, x, strict=True)]
    with open_text(path, "w") as fh:
        fh.writelines(lines)


def read_kitti(path: PathLike) -> FloatArray:
    """Read a KITTI odometry pose file.

    Parameters
    ----------
    path : str or os.PathLike
        Text file with 12 numbers per line, the 3×4 block ``[R | t]`` row-major.

    Returns
    -------
    ndarray, shape (N, 4, 4)
        ``T_world_camera``, the numbers exactly as printed (rotation not projected).

    Raises
    ------
    ValueError
        On a malformed line (wrong count, not a number, rotation not orthonormal within the
        printed precision), naming the file and line number.
    """
    what = "r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz"  # the 3x4 [R | t], row-major
    fast = _fast_table(path, 12)
    if fast is not None:  # one loadtxt pass; rotations judged by their text below
        errs, dets = _rotation_errors(fast.reshape(-1, 3, 4)[:, :, :3])
        suspect = np.flatnonzero((errs > _layouts.ROTATION_TOL) | (dets < 0)).tolist()
        for r, (lineno, fields) in sorted(_data_line_text(path, suspect).items()):
            tol = _layouts.text_rotation_tol([fields[i] for i in (0, 1, 2, 4, 5, 6, 8, 9, 10)])
            if errs[r] > tol or dets[r] < 0:
                raise ValueError(
                    f"{path}:{lineno}: rotation block is not a rotation: max|RᵀR − I| = "
                    f"{errs[r]:.3g} (tolerance {tol:g}), det = {float(dets[r]):.3g}"
                )
        return _kitti_poses(fast)
    rows = []
    for lineno, fields in _data_lines(path):
        vals = _numbers(path, lineno, fields, 12, what)
        R = np.array(vals).reshape(3, 4)[:, :3]
        tol = _layouts.text_rotation_tol([fields[i] for i in (0, 1, 2, 4, 5, 6, 8, 9, 10)])
        err = float(np.abs(R.T @ R - np.eye(3)).max())
        if err > tol or np.linalg.det(R) < 0:
            raise ValueError(
                f"{path}:{lineno}: rotation block is not a rotation: max|RᵀR − I| = {err:.3g} "
                f"(tolerance {tol:g}), det = {float(np.linalg.det(R)):.3g}"
            )
        rows.append(vals)
    return _kitti_poses(np.array(rows, dtype=np.float64).reshape(-1, 12))


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


def write_kitti(path: PathLike, poses: Any) -> None:
    """Write a KITTI odometry pose file (12 numbers per line, ``repr`` precision).

    Parameters
    ----------
    path : str or os.PathLike
    poses : array_like, shape (N, 4, 4)
        Rotation blocks must be orthonormal within :data:`liebridge.io.poses.ROTATION_TOL`.
    """
    T = validate.pose(poses, "poses")
    if T.ndim != 3:
        raise ValueError(f"poses: expected shape (N, 4, 4), got {T.shape}")
    x = _layouts.from_matrix(T, layout="kitti")
    with open_text(path, "w") as fh:
        fh.writelines(" ".join(map(_fmt, xi)) + "\n" for xi in x)
