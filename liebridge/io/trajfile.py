"""Trajectory files by format, fast: TUM (header and comments detected), KITTI, EuRoC.

:func:`read_trajectory` returns ``(timestamps [s], T_world_body (N, 4, 4))`` for

* ``"tum"`` — ``timestamp tx ty tz qx qy qz qw`` (quaternion ``xyzw`` unless ``quat_order``
  says otherwise). ``#`` starts a comment (whole line or the rest of it); commas and tabs
  separate like spaces; a first line of names (``timestamp tx ty ...``, with or without ``#``) is
  a **header**: detected, skipped, and if it names ``qw`` before ``qx`` the order is taken as
  ``wxyz``. Parsed in one ``numpy.loadtxt`` call (a 10⁶-line file in 2–4 s on the
  development machine), validated with vectorised checks; a bad line is then located and
  named (``file:line: ...``) by a second, per-line pass that runs only on failure.
* ``"kitti"`` — 12 numbers ``[R | t]`` row-major per line, no timestamps: the frame index is
  returned as the timestamp (so association pairs frames by index), read by
  :func:`liebridge.io.trajectory.read_kitti`.
* ``"euroc"`` — :func:`liebridge.io.euroc.read_euroc`.
* ``"auto"`` — by extension and content: ``.csv`` with comma-separated integer nanosecond
  stamps → EuRoC; 12 numbers a line → KITTI; else TUM.

Every reader checks the quaternions with :func:`liebridge.io.sanity.check_quaternions` (a
:class:`~liebridge.io.sanity.QuaternionOrderWarning`, never an error) unless ``check=False``.
:func:`write_trajectory` writes TUM or EuRoC with hemisphere continuity (consecutive quaternions
``q_i·q_{i−1} ≥ 0``) and ``repr`` precision, and KITTI via
:func:`liebridge.io.trajectory.write_kitti`.
"""

from __future__ import annotations

import io as _io
import os
import re
import warnings
from pathlib import Path
from typing import Any, Literal

import numpy as np

from .._validate import FloatArray
from . import poses as _layouts
from .euroc import read_euroc, write_euroc
from .sanity import check_quaternions, hemisphere_continuous
from .trajectory import read_kitti, write_kitti

__all__ = ["FORMATS", "detect_format", "read_trajectory", "read_tum_file", "write_trajectory"]

PathLike = str | os.PathLike[str]
Format = Literal["auto", "tum", "kitti", "euroc"]
#: File formats by name.
FORMATS: tuple[str, ...] = ("tum", "kitti", "euroc")

_NAME = re.compile(rb"^[A-Za-z_\[\]]")


def _is_names(line: bytes) -> bool:
    """Tell whether a line holds column names (first field name-like and not a number)."""
    fields = re.split(rb"[\s,]+", line.lstrip(b"# \t").strip())
    if not fields or not fields[0] or not _NAME.match(fields[0]):
        return False
    try:
        float(fields[0])  # "nan", "inf": data (rejected later as such), not a header
    except ValueError:
        return True
    return False


def _first_data_lines(path: PathLike, k: int = 3) -> list[bytes]:
    out: list[bytes] = []
    with open(path, "rb") as fh:
        for line in fh:
            s = line.strip()
            if s:
                out.append(s)
            if len(out) >= k:
                break
    return out


def detect_format(path: PathLike) -> str:
    """Guess ``"tum"``, ``"kitti"`` or ``"euroc"`` from the extension and the first lines."""
    lines = [ln for ln in _first_data_lines(path, 4)]
    data = [ln for ln in lines if not ln.startswith(b"#") and not _is_names(ln)]
    if not data:
        raise ValueError(f"{path}: no data lines (empty, or comments only)")
    first = data[0]
    fields = re.split(rb"[\s,]+", first.split(b"#", 1)[0].strip())
    if b"," in first and re.fullmatch(rb"\d{15,}", fields[0]) is not None:
        return "euroc"
    if len(fields) == 12:
        return "kitti"
    return "tum"


def _header_order(line: bytes) -> str | None:
    """``"wxyz"``/``"xyzw"`` from column names (``qw``, ``q_w``, ``q_RS_w`` ...), else None."""
    names = [n.lower() for n in re.split(rb"[\s,#]+", line) if n]

    def pos(axis: bytes) -> int:
        return next((i for i, n in enumerate(names) if n.startswith(b"q") and n.endswith(axis)), -1)

    iw, ix = pos(b"w"), pos(b"x")
    if iw < 0 or ix < 0:
        return None
    return "wxyz" if iw < ix else "xyzw"


def read_tum_file(
    path: PathLike, *, quat_order: str | None = None, check: bool = True
) -> tuple[FloatArray, FloatArray]:
    """Read a TUM file fast (see the module docstring for the header and comment rules).

    Parameters
    ----------
    path : str or os.PathLike
    quat_order : {"xyzw", "wxyz"}, optional
        Storage order of the quaternion columns; default: from the header if it names them,
        else ``"xyzw"`` (TUM's).
    check : bool
        Run the quaternion sanity check (a warning).

    Raises
    ------
    ValueError
        Naming the file and line: wrong number of fields, not a number, NaN/Inf, a quaternion
        norm off beyond the precision it was printed with; also no data lines.
    """
    with open(path, "rb") as fh:
        raw = fh.read()
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]
    head, _, _ = raw.lstrip().partition(b"\n")
    header_order = None
    skip = 0
    if head and _is_names(head):
        header_order = _header_order(head)
        if not head.startswith(b"#"):
            skip = 1  # a header without '#': skip the first non-blank line
    order = quat_order or header_order or "xyzw"
    if order not in ("xyzw", "wxyz"):
        raise ValueError(f"quat_order: expected 'xyzw' or 'wxyz', got {quat_order!r}")
    text = raw.replace(b",", b" ").replace(b"\t", b" ")
    if skip:
        text = text.lstrip()
        text = text[text.find(b"\n") + 1 :] if b"\n" in text else b""
    try:
        with warnings.catch_warnings():  # numpy's "input contained no data": reported below
            warnings.simplefilter("ignore", UserWarning)
            data = np.loadtxt(_io.BytesIO(text), comments="#", ndmin=2, dtype=np.float64)
    except ValueError:
        _locate_bad_line(path, raw, skip)
        raise  # pragma: no cover - _locate_bad_line raises
    if data.size == 0:
        raise ValueError(f"{path}: no data lines (empty, or comments only)")
    if data.shape[1] != 8:
        _locate_bad_line(path, raw, skip)
    if not np.isfinite(data).all():
        _locate_bad_line(path, raw, skip)
    q = data[:, 4:8]
    err = np.abs(np.linalg.norm(q, axis=-1) - 1.0)
    suspect = np.flatnonzero(err > _layouts.QUATERNION_TOL)
    if suspect.size:
        _check_text_norms(path, raw, skip, suspect, err)
    t = np.ascontiguousarray(data[:, 0])
    if check:
        check_quaternions(q, order, t, source=str(path))
    qn = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x = np.concatenate([data[:, 1:4], qn], axis=-1)
    return t, _layouts.to_matrix(x, layout="xyz_qxyzw" if order == "xyzw" else "xyz_qwxyz")


def _numbered_data_lines(raw: bytes, skip: int) -> list[tuple[int, list[bytes]]]:
    out = []
    skipped = 0
    for k, line in enumerate(raw.split(b"\n"), start=1):
        fields = line.split(b"#", 1)[0].replace(b",", b" ").split()
        if not fields:
            continue
        if skipped < skip:
            skipped += 1
            continue
        out.append((k, fields))
    return out


def _locate_bad_line(path: PathLike, raw: bytes, skip: int) -> None:
    """Find and name the first malformed data line (the slow path, on failure only)."""
    what = "timestamp tx ty tz qx qy qz qw"
    for k, fields in _numbered_data_lines(raw, skip):
        if len(fields) != 8:
            raise ValueError(f"{path}:{k}: expected 8 numbers ({what}), got {len(fields)}")
        for f in fields:
            try:
                x = float(f)
            except ValueError:
                raise ValueError(
                    f"{path}:{k}: not a number: {f.decode(errors='replace')!r}"
                ) from None
            if not np.isfinite(x):
                raise ValueError(f"{path}:{k}: NaN or Inf ({what})")
    raise ValueError(f"{path}: cannot parse as a TUM trajectory ({what})")


def _check_text_norms(
    path: PathLike, raw: bytes, skip: int, rows: np.ndarray[Any, Any], err: FloatArray
) -> None:
    """Quaternion norms off by more than full precision allows: judge each by its text."""
    lines = _numbered_data_lines(raw, skip)
    for r in rows.tolist():
        k, fields = lines[r]
        tol = _layouts.text_quaternion_tol([f.decode() for f in fields[4:8]])
        if err[r] > tol:
            raise ValueError(
                f"{path}:{k}: quaternion norm off by {err[r]:.3g} (tolerance {tol:g} for "
                f"numbers printed with this precision)"
            )


def read_trajectory(
    path: PathLike,
    format: Format | str = "auto",
    *,
    quat_order: str | None = None,
    check: bool = True,
) -> tuple[FloatArray, FloatArray]:
    """Read a trajectory file: ``(timestamps [s] (N,), T_world_body (N, 4, 4))``.

    See the module docstring for the formats. ``quat_order`` applies to TUM files only (EuRoC
    is ``wxyz``, KITTI has rotation matrices).
    """
    if not Path(path).is_file():
        raise ValueError(f"{path}: no such file")
    fmt = detect_format(path) if format == "auto" else format
    if fmt == "tum":
        return read_tum_file(path, quat_order=quat_order, check=check)
    if fmt == "euroc":
        t, T, _ = read_euroc(path, check=check)
        return t, T
    if fmt == "kitti":
        T = read_kitti(path)
        return np.arange(T.shape[0], dtype=np.float64), T
    raise ValueError(f"format: expected 'auto' or one of {', '.join(FORMATS)}, got {format!r}")


def write_trajectory(
    path: PathLike,
    timestamps: Any,
    poses: Any,
    format: Format | str = "tum",
    *,
    quat_order: str = "xyzw",
) -> None:
    """Write a trajectory file with hemisphere-continuous quaternions and ``repr`` precision.

    Parameters
    ----------
    timestamps : array_like, shape (N,)
        Seconds (ignored for KITTI).
    poses : array_like, shape (N, 4, 4)
    format : {"tum", "euroc", "kitti"}
    quat_order : {"xyzw", "wxyz"}
        TUM only; ``"wxyz"`` writes a header that says so (read back by :func:`read_tum_file`).
    """
    if format == "kitti":
        write_kitti(path, poses)
        return
    if format == "euroc":
        write_euroc(path, timestamps, poses)
        return
    if format != "tum":
        raise ValueError(f"format: expected one of {', '.join(FORMATS)}, got {format!r}")
    if quat_order not in ("xyzw", "wxyz"):
        raise ValueError(f"quat_order: expected 'xyzw' or 'wxyz', got {quat_order!r}")
    t, T = _layouts.stamped_poses(timestamps, poses)
    layout = "xyz_qxyzw" if quat_order == "xyzw" else "xyz_qwxyz"
    x = _layouts.from_matrix(T, layout=layout)
    x[:, 3:] = hemisphere_continuous(x[:, 3:])
    names = "qx qy qz qw" if quat_order == "xyzw" else "qw qx qy qz"
    data = np.concatenate([t[:, None], x], axis=-1)
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(f"# timestamp tx ty tz {names}\n")
        np.savetxt(fh, data, fmt="%.17g")
