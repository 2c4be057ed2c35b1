"""The one place that knows what liebridge's readers return: a log as stamps, poses, covariances.

Every job of :mod:`liebridge.batch` reads its inputs through :func:`read_log`, which calls the
public readers (:func:`liebridge.io.trajfile.read_trajectory` for TUM, KITTI and EuRoC files,
:func:`liebridge.ros.read_messages` for a bag topic) and hands back one :class:`Log`. When the
readers' return types change, this module is the one to follow them.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass

import numpy as np

from .._validate import FloatArray

__all__ = ["Log", "read_log", "split_topic"]

PathLike = str | os.PathLike[str]


@dataclass(frozen=True)
class Log:
    """One trajectory log as the batch layer uses it.

    Attributes
    ----------
    stamps : ndarray, shape (N,)
        Seconds (KITTI: the frame index).
    T_world_body : ndarray, shape (N, 4, 4)
        Poses, row-major homogeneous matrices.
    cov : ndarray, shape (N, 6, 6) or None
        One covariance per pose in ``convention``'s tangent (a bag's ``pose.covariance``), or
        None when the log holds none.
    convention : str or None
        Preset name of ``cov``'s convention (None without covariances).
    warnings : tuple of str
        The readers' warnings (e.g. a suspicious quaternion order), one line each.
    """

    stamps: FloatArray
    T_world_body: FloatArray
    cov: FloatArray | None
    convention: str | None
    warnings: tuple[str, ...] = ()


def split_topic(spec: PathLike) -> tuple[str, str | None]:
    """Split ``"run.bag:/odom"`` into ``("run.bag", "/odom")``; a plain path gets ``None``.

    A spec that names an existing file or directory is a path, whatever it contains; otherwise
    the text after the last ``":/"`` is a topic when the text before it exists.
    """
    path, topic, _ = _split(os.fspath(spec))
    return path, topic


def _split(text: str) -> tuple[str, str | None, bool]:
    """:func:`split_topic` and whether the path exists (one ``stat`` for a plain file)."""
    if ":/" not in text:
        return text, None, os.path.exists(text)
    if os.path.exists(text):
        return text, None, True
    path, topic = text.rsplit(":/", 1)
    if path and os.path.exists(path):
        return path, "/" + topic, True
    return text, None, False


def read_log(
    spec: PathLike,
    *,
    format: str = "auto",
    quat_order: str | None = None,
    topic: str | None = None,
    cov: PathLike | None = None,
    convention: str | None = None,
) -> Log:
    """Read one trajectory log: a TUM / KITTI / EuRoC file, or one topic of a ROS bag.

    Parameters
    ----------
    spec : str or os.PathLike
        A trajectory file, or ``"BAG:/topic"`` (see :func:`split_topic`).
    format : {"auto", "tum", "kitti", "euroc"}
        The file's format (files only).
    quat_order : {"xyzw", "wxyz"}, optional
        TUM files only (default: from the header, else ``xyzw``).
    topic : str, optional
        The bag topic, instead of writing it into ``spec``.
    cov : str or os.PathLike, optional
        A ``.npy`` file of ``(N, 6, 6)`` covariances, one per pose in file order, in
        ``convention`` (a bag topic's own covariances are used when this is not given).
    convention : str, optional
        Preset name of ``cov``'s convention (required with ``cov``); for a bag topic, the
        convention the message covariances are returned in (default ``"ros"``: as stored).

    Raises
    ------
    ValueError
        Naming the file (and topic): no such file, unreadable contents, covariances of the
        wrong shape or count.
    """
    path, spec_topic, exists = _split(os.fspath(spec))
    topic = topic or spec_topic
    if not exists:
        raise ValueError(f"{path}: no such file")
    notes: list[str] = []
    C: FloatArray | None = None
    conv = convention
    if topic is not None:
        from ..ros import read_messages

        msgs = read_messages(path, topic, convention=convention or "ros")
        t = np.asarray(msgs.stamps, dtype=np.float64)
        T = np.asarray(msgs.T, dtype=np.float64)
        if msgs.cov is not None and cov is None:
            C = np.asarray(msgs.cov, dtype=np.float64)
            conv = msgs.convention.name
    else:
        from ..io import trajfile
        from ..io.sanity import QuaternionOrderWarning

        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", QuaternionOrderWarning)
            t, T = trajfile.read_trajectory(path, format, quat_order=quat_order)
        notes = [" ".join(str(w.message).split()) for w in caught]
    if cov is not None:
        if convention is None:
            raise ValueError(f"convention: required with cov ({os.fspath(cov)})")
        try:
            C = np.load(cov, allow_pickle=False)
        except (OSError, ValueError, EOFError) as exc:
            raise ValueError(f"{os.fspath(cov)}: cannot read as .npy: {exc}") from None
        if not isinstance(C, np.ndarray) or C.ndim != 3 or C.shape[1:] != (6, 6):
            shape = getattr(C, "shape", None)
            raise ValueError(f"{os.fspath(cov)}: expected an array of shape (N, 6, 6), got {shape}")
        C = np.asarray(C, dtype=np.float64)
        if C.shape[0] != t.shape[0]:
            raise ValueError(
                f"{os.fspath(cov)}: {C.shape[0]} covariances for {t.shape[0]} poses of {path} "
                f"(one per pose, in file order)"
            )
    return Log(t, T, C, conv if C is not None else None, tuple(notes))
