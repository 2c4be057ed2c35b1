r"""EuRoC MAV ground truth (``state_groundtruth_estimate0/data.csv``), read and written.

Comma-separated, one state per line, a ``#`` header line::

    #timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m],
    q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z [],
    v_RS_R_x [m s^-1], ..., b_w_RS_S_x [rad s^-1], ..., b_a_RS_S_x [m s^-2], ...

The timestamp is an integer in **nanoseconds**; ``p_RS_R`` and ``q_RS`` are the pose of the body
(sensor ``S``) in the world (``R``): ``T_world_body``, quaternion Hamilton, scalar **first**
(``wxyz``). Files with 8 columns (pose only, same order) are read too. Source: the EuRoC MAV
dataset (Burri et al., IJRR 2016) and its ``state_groundtruth_estimate0`` files; evo 1.38 reads
the same columns (``evo/tools/file_interface.py::read_euroc_csv_trajectory``).

The integer nanoseconds are parsed exactly and converted to seconds as
``ns // 10⁹ + (ns mod 10⁹)·1e-9``; a stamp beyond int64 nanoseconds (|t| ≥ 2⁶³ ns ≈ 9.22e9 s,
the year 2262) is refused, in reading and in writing, never wrapped. Velocities and biases are
returned as they are (``Trajectory.extra``). ``\n``, ``\r\n`` and ``\r`` line ends all read.
Writing goes through :func:`liebridge.io.atomic.atomic_write` with the TUM writers' quaternion
sign rule (:func:`liebridge.io.trajectory.tum_quaternions`).
"""

from __future__ import annotations

import io as _io
import os
from typing import Any

import numpy as np

from .._validate import FloatArray
from . import poses as _layouts
from .atomic import atomic_write
from .sanity import QUAT_TOLERANCE, check_quaternions, repeated_stamps, unit_quaternions
from .trajectory import Trajectory, read_text_bytes, tum_quaternions

__all__ = ["HEADER", "read_euroc", "write_euroc"]

PathLike = str | os.PathLike[str]

#: The header line of a pose-only file written by :func:`write_euroc`.
HEADER = (
    "#timestamp [ns],p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],q_RS_w [],q_RS_x [],q_RS_y [],q_RS_z []"
)


def _seconds(ns: np.ndarray[Any, np.dtype[np.int64]]) -> FloatArray:
    return np.asarray((ns // 10**9).astype(np.float64) + (ns % 10**9) * 1e-9, dtype=np.float64)


#: Largest magnitude of an int64 nanosecond stamp.
_INT64_MAX = 2**63 - 1


def read_euroc(
    path: PathLike | int,
    *,
    check: bool = True,
    duplicates: str = "first",
    quat_tolerance: float = QUAT_TOLERANCE,
) -> Trajectory:
    """Read a EuRoC ground-truth CSV.

    Parameters
    ----------
    path : str, os.PathLike or int
    check : bool
        Run :func:`liebridge.io.sanity.check_quaternions` with the positions (a warning).
    duplicates : {"first", "last", "error"}
        Repeated nanosecond stamps: keep the first of each run (warning with the count), the
        last, or raise (:func:`liebridge.io.sanity.repeated_stamps`).
    quat_tolerance : float
        Quaternions off unit by at most this (default ``1e-3``; EuRoC ground truth is off by up
        to ~1.5e-4) are normalised, with a warning naming the worst deviation; beyond it an
        error naming the file, line and deviation (:func:`liebridge.io.sanity.unit_quaternions`).

    Returns
    -------
    Trajectory
        ``stamps`` (N,) seconds; ``T`` (N, 4, 4) ``T_world_body`` (quaternion normalised);
        ``extra`` (N, K): the columns after the quaternion (velocity, gyro and accelerometer
        biases: K = 9), K = 0 for a pose-only file. Unpacks as ``stamps, T``.

    Raises
    ------
    ValueError
        Fewer than 8 columns, a field that is not a number, a stamp that is not an integer or
        lies beyond int64 nanoseconds, a quaternion norm off by more than ``quat_tolerance``,
        a repeated stamp under ``duplicates="error"``, naming the file and line.
    """
    raw = read_text_bytes(path)
    lines = raw.split(b"\n")
    body = [
        (k, ln) for k, ln in enumerate(lines, start=1) if ln.strip() and not ln.startswith(b"#")
    ]
    if not body:
        raise ValueError(f"{path}: no data lines")
    ncol = len(body[0][1].split(b","))
    if ncol < 8:
        raise ValueError(
            f"{path}:{body[0][0]}: expected at least 8 comma-separated columns "
            f"(timestamp [ns], p xyz, q wxyz), got {ncol}"
        )
    for k, ln in body:  # cheap structural check: same number of commas on every line
        if ln.count(b",") != ncol - 1:
            raise ValueError(f"{path}:{k}: expected {ncol} columns, got {ln.count(b',') + 1}")
    text = b"\n".join(ln for _, ln in body)
    try:
        ns = np.loadtxt(_io.BytesIO(text), delimiter=",", usecols=0, dtype=np.int64, ndmin=1)
        data = np.loadtxt(_io.BytesIO(text), delimiter=",", ndmin=2, dtype=np.float64)
    except ValueError as exc:
        _name_bad_stamp(path, body)
        raise ValueError(f"{path}: {exc} (rows count data lines, from 1)") from None
    if not np.isfinite(data).all():
        r = int(np.argwhere(~np.isfinite(data))[0, 0])
        raise ValueError(f"{path}:{body[r][0]}: NaN or Inf")
    line_numbers = np.array([k for k, _ in body], dtype=np.intp)

    def explained(r: int) -> float:
        fields = [f.decode().strip() for f in body[r][1].split(b",")[4:8]]
        return _layouts.text_quaternion_tol(fields)

    q = unit_quaternions(
        data[:, 4:8], quat_tolerance, source=str(path), lines=line_numbers, explained=explained
    )
    keep = repeated_stamps(ns, duplicates, source=str(path), lines=line_numbers)
    if keep.size != data.shape[0]:
        ns, data, q = ns[keep], data[keep], q[keep]
    t = _seconds(ns)
    if check:
        check_quaternions(q, "wxyz", t, source=str(path), positions=data[:, 1:4])
    x = np.concatenate([data[:, 1:4], q], axis=-1)
    T = _layouts.to_matrix(x, layout="xyz_qwxyz")
    return Trajectory(t, T, source=str(path), extra=np.ascontiguousarray(data[:, 8:]))


def _name_bad_stamp(path: PathLike | int, body: list[tuple[int, bytes]]) -> None:
    """Raise naming the first stamp that is not an integer within int64 nanoseconds, if any."""
    for k, ln in body:
        stamp = ln.split(b",", 1)[0].strip()
        try:
            ns_k = int(stamp)
        except ValueError:
            raise ValueError(
                f"{path}:{k}: timestamp {stamp.decode(errors='replace')!r} is not an integer "
                "number of nanoseconds"
            ) from None
        if abs(ns_k) > _INT64_MAX:
            raise ValueError(
                f"{path}:{k}: timestamp {ns_k} ns is beyond int64 nanoseconds (|t| ≥ 2^63 ns, "
                f"{ns_k / 1e9:.4g} s); not representable"
            )


def write_euroc(path: PathLike | int, timestamps: Any, poses: Any = None) -> None:
    """Write a pose-only EuRoC CSV (integer nanoseconds, ``wxyz``, the one sign rule).

    Parameters
    ----------
    path : str, os.PathLike or int
        Written through :func:`liebridge.io.atomic.atomic_write`.
    timestamps : array_like, shape (N,), or Trajectory
        Seconds; rounded to the nearest nanosecond. |t| ≥ 2⁶³ ns (≈ 9.22e9 s) is refused (an
        int64 nanosecond stamp cannot hold it). A Trajectory supplies the poses too.
    poses : array_like, shape (N, 4, 4)
        ``T_world_body``.
    """
    if isinstance(timestamps, Trajectory) and poses is None:
        timestamps, poses = timestamps.stamps, timestamps.T
    t, T = _layouts.stamped_poses(timestamps, poses)
    big = np.flatnonzero(~(np.abs(t) < 9.2e9))
    if big.size:
        i = int(big[0])
        raise ValueError(
            f"timestamps: {big.size} of {t.size} beyond int64 nanoseconds (|t| < 9.2e9 s), "
            f"first at batch index ({i},): {t[i]:.6g} s"
        )
    x = _layouts.from_matrix(T, layout="xyz_qxyzw")
    q = tum_quaternions(x[:, 3:])
    x = np.concatenate([x[:, :3], q[:, [3, 0, 1, 2]]], axis=-1)
    sec = np.floor(t)  # whole seconds apart: t·1e9 in one float would round to 256 ns at 1.4e9 s
    ns = sec.astype(np.int64) * 10**9 + np.round((t - sec) * 1e9).astype(np.int64)
    with atomic_write(path, "w") as fh:
        fh.write(HEADER + "\n")
        fh.writelines(
            f"{n}," + ",".join(repr(a) for a in xi) + "\n"
            for n, xi in zip(ns.tolist(), x.tolist(), strict=True)
        )
