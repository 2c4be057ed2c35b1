"""EuRoC MAV ground truth (``state_groundtruth_estimate0/data.csv``), read and written.

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
``ns // 10⁹ + (ns mod 10⁹)·1e-9``. Velocities and biases are returned as they are.
"""

from __future__ import annotations

import io as _io
import os
from typing import Any

import numpy as np

from .._validate import FloatArray
from . import poses as _layouts
from .sanity import check_quaternions, hemisphere_continuous

__all__ = ["HEADER", "read_euroc", "write_euroc"]

PathLike = str | os.PathLike[str]

#: The header line of a pose-only file written by :func:`write_euroc`.
HEADER = (
    "#timestamp [ns],p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],q_RS_w [],q_RS_x [],q_RS_y [],q_RS_z []"
)


def _seconds(ns: np.ndarray[Any, np.dtype[np.int64]]) -> FloatArray:
    return np.asarray((ns // 10**9).astype(np.float64) + (ns % 10**9) * 1e-9, dtype=np.float64)


def read_euroc(path: PathLike, *, check: bool = True) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Read a EuRoC ground-truth CSV.

    Returns
    -------
    timestamps : ndarray, shape (N,)
        Seconds.
    poses : ndarray, shape (N, 4, 4)
        ``T_world_body`` (quaternion normalised).
    extra : ndarray, shape (N, K)
        The columns after the quaternion (velocity, gyro and accelerometer biases: K = 9),
        K = 0 for a pose-only file.

    Raises
    ------
    ValueError
        Fewer than 8 columns, a field that is not a number, a quaternion norm off by more than
        ``1e-3``, naming the file and line.
    """
    with open(path, "rb") as fh:
        raw = fh.read().replace(b"\r", b"")
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
        raise ValueError(f"{path}: {exc} (rows count data lines, from 1)") from None
    if not np.isfinite(data).all():
        r = int(np.argwhere(~np.isfinite(data))[0, 0])
        raise ValueError(f"{path}:{body[r][0]}: NaN or Inf")
    q = data[:, 4:8]
    err = np.abs(np.linalg.norm(q, axis=-1) - 1.0)
    if (err > 1e-3).any():
        r = int(np.argmax(err > 1e-3))
        raise ValueError(f"{path}:{body[r][0]}: quaternion norm off by {err[r]:.3g}")
    t = _seconds(ns)
    if check:
        check_quaternions(q, "wxyz", t, source=str(path))
    x = np.concatenate([data[:, 1:4], q / np.linalg.norm(q, axis=-1, keepdims=True)], axis=-1)
    return t, _layouts.to_matrix(x, layout="xyz_qwxyz"), np.ascontiguousarray(data[:, 8:])


def write_euroc(path: PathLike, timestamps: Any, poses: Any) -> None:
    """Write a pose-only EuRoC CSV (integer nanoseconds, ``wxyz``, hemisphere-continuous).

    Parameters
    ----------
    timestamps : array_like, shape (N,)
        Seconds; rounded to the nearest nanosecond.
    poses : array_like, shape (N, 4, 4)
        ``T_world_body``.
    """
    t, T = _layouts.stamped_poses(timestamps, poses)
    x = _layouts.from_matrix(T, layout="xyz_qwxyz")
    x[:, 3:] = hemisphere_continuous(x[:, 3:])
    sec = np.floor(t)  # whole seconds apart: t·1e9 in one float would round to 256 ns at 1.4e9 s
    ns = sec.astype(np.int64) * 10**9 + np.round((t - sec) * 1e9).astype(np.int64)
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(HEADER + "\n")
        fh.writelines(
            f"{n}," + ",".join(repr(float(a)) for a in xi) + "\n"
            for n, xi in zip(ns, x, strict=True)
        )
