"""Trajectory files by format: TUM, KITTI, EuRoC, read into one :class:`Trajectory` type.

:func:`read_trajectory` returns a :class:`~liebridge.io.trajectory.Trajectory` (unpacking as
``stamps, T``) for

* ``"tum"`` — :func:`liebridge.io.trajectory.read_tum` (the one TUM reader; header, comments,
  separators, line ends and quaternion order as its module says; ``read_tum_file`` is the same
  function under its earlier name);
* ``"kitti"`` — :func:`liebridge.io.trajectory.read_kitti` (the frame index is the stamp, so
  association pairs frames by index);
* ``"euroc"`` — :func:`liebridge.io.euroc.read_euroc`;
* ``"auto"`` — by content: comma-separated integer nanosecond stamps → EuRoC; 12 numbers a
  line → KITTI; else TUM.

A file without data lines is an error here (a trajectory to evaluate must have poses). Every
reader checks the quaternions with :func:`liebridge.io.sanity.check_quaternions` (a
:class:`~liebridge.io.sanity.QuaternionOrderWarning`, never an error; the order judged by the
direction of travel, saying how sure it is) unless ``check=False``, and applies one policy to
imperfect real files (``duplicates=``, ``quat_tolerance=``; :mod:`liebridge.io.sanity`).
:func:`write_trajectory` writes TUM (:func:`~liebridge.io.trajectory.write_tum`: ``repr``
precision and the one quaternion sign rule), EuRoC or KITTI, every one through
:func:`liebridge.io.atomic.atomic_write`.
"""

from __future__ import annotations

import os
import re
from typing import Any, Literal

from .euroc import read_euroc, write_euroc
from .sanity import QUAT_TOLERANCE, QuaternionOrderConflictError
from .trajectory import Trajectory, read_kitti, read_tum, write_kitti, write_tum

__all__ = [
    "FORMATS",
    "Trajectory",
    "detect_format",
    "read_trajectory",
    "read_tum_file",
    "write_trajectory",
]

PathLike = str | os.PathLike[str]
Format = Literal["auto", "tum", "kitti", "euroc"]
#: File formats by name.
FORMATS: tuple[str, ...] = ("tum", "kitti", "euroc")

#: The one TUM reader under its earlier name.
read_tum_file = read_tum

_NAME = re.compile(rb"^[A-Za-z_\[\]]")


def _is_names(line: bytes) -> bool:
    """Tell whether a line holds only column names (no field is a number)."""
    fields = [f for f in re.split(rb"[\s,]+", line.lstrip(b"# \t").strip()) if f]
    if not fields:
        return False
    for f in fields:
        if not _NAME.match(f):
            return False
        try:
            float(f)  # "nan", "inf": data (rejected later as such), not a header
        except ValueError:
            continue
        return False
    return True


def _first_data_lines(path: PathLike, k: int = 3) -> list[bytes]:
    out: list[bytes] = []
    with open(path, "rb") as fh:
        head = fh.read(1 << 16)
    for line in head.replace(b"\r\n", b"\n").replace(b"\r", b"\n").split(b"\n"):
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


def read_trajectory(
    path: PathLike,
    format: Format | str = "auto",
    *,
    quat_order: str | None = None,
    check: bool = True,
    duplicates: str = "first",
    quat_tolerance: float = QUAT_TOLERANCE,
) -> Trajectory:
    """Read a trajectory file into a :class:`~liebridge.io.trajectory.Trajectory`.

    See the module docstring for the formats. ``quat_order`` applies to TUM files (a header that
    names the other order wins: :class:`~liebridge.io.sanity.QuaternionOrderConflictError`);
    EuRoC is ``wxyz`` by its header, so ``"xyzw"`` there is the same error; KITTI has rotation
    matrices and ignores it. ``duplicates`` and ``quat_tolerance`` are the imperfect-file policy
    of :mod:`liebridge.io.sanity` (repeated stamps: keep the first and warn; quaternions off
    unit by ≤ 1e-3: normalise and warn with the worst deviation), the same for TUM and EuRoC
    (KITTI has neither stamps nor quaternions). Raises ``ValueError`` for a missing file, an
    unknown format, a malformed line (naming file and line) and a file without data lines.
    """
    if not os.path.isfile(path):
        raise ValueError(f"{path}: no such file")
    if format not in ("auto", *FORMATS):
        raise ValueError(f"format: expected 'auto' or one of {', '.join(FORMATS)}, got {format!r}")
    fmt = detect_format(path) if format == "auto" else format
    policy: dict[str, Any] = {"duplicates": duplicates, "quat_tolerance": quat_tolerance}
    if fmt == "tum":
        traj = read_tum(path, quat_order=quat_order, check=check, **policy)
    elif fmt == "euroc":
        if quat_order not in (None, "wxyz"):
            raise QuaternionOrderConflictError(
                f"{path}: a EuRoC file stores its quaternion w x y z (header q_RS_w, q_RS_x, "
                f"...), contradicting the order asked for, {quat_order}",
                "the header wins: drop quat_order",
            )
        traj = read_euroc(path, check=check, **policy)
    else:
        traj = read_kitti(path)
    if len(traj) == 0:
        raise ValueError(f"{path}: no data lines (empty, or comments only)")
    return traj


def write_trajectory(
    path: PathLike | int,
    timestamps: Any,
    poses: Any = None,
    format: Format | str = "tum",
    *,
    quat_order: str = "xyzw",
) -> None:
    """Write a trajectory file (``repr`` precision; TUM and EuRoC with the one sign rule).

    Parameters
    ----------
    path : str, os.PathLike or int
    timestamps : array_like, shape (N,), or Trajectory
        Seconds (ignored for KITTI); a Trajectory supplies the poses too.
    poses : array_like, shape (N, 4, 4)
    format : {"tum", "euroc", "kitti"}
    quat_order : {"xyzw", "wxyz"}
        TUM only; ``"wxyz"`` writes a header that says so (read back by ``read_tum``).
    """
    if isinstance(timestamps, Trajectory) and poses is None:
        timestamps, poses = timestamps.stamps, timestamps.T
    if format == "kitti":
        write_kitti(path, poses)
        return
    if format == "euroc":
        write_euroc(path, timestamps, poses)
        return
    if format != "tum":
        raise ValueError(f"format: expected one of {', '.join(FORMATS)}, got {format!r}")
    write_tum(path, timestamps, poses, quat_order=quat_order)
