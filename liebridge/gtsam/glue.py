"""GTSAM glue: ``gtsam.Pose3`` and ``gtsam.Values`` ↔ batched ``(..., 4, 4)`` arrays.

Old path: also reachable as ``lb.gtsam_glue`` (earlier releases); new code writes ``lb.gtsam``.

The array side is liebridge's canonical form: ``T = [[R, t], [0, 1]]``, float64, the same matrix
``gtsam.Pose3.matrix()`` returns (GTSAM's ``Pose3`` *is* the canonical convention: right
perturbation, tangent ``(ω, v)``). Nothing here changes a convention; it moves data.

What GTSAM does not check, this module does: ``gtsam.Rot3`` and ``gtsam.Pose3`` accept a
non-orthonormal matrix silently (``Rot3.IsValid`` is then False, and every later result is
wrong), and ``Values.insert(key, ndarray)`` stores a 4×4 array as a generic *matrix* value, not a
pose. :func:`to_pose3` and :func:`to_values` validate every rotation
(:data:`liebridge._validate.ROTATION_TOL`, naming the batch index) and always build ``Pose3``.

Batch path. ``gtsam.utilities.extractPose3(values)`` returns every ``Pose3`` of a ``Values`` as
an ``N×12`` matrix (rows in increasing key order: ``R`` row-major, then ``t``) in one C++ call;
:func:`from_values` uses it on ``values.extract(keys)`` and reorders the rows, instead of calling
``atPose3(key).matrix()`` per key. There is no batch *insert* in the wheel, so :func:`to_values`
loops over ``Pose3(R, t)`` constructions. ``benchmarks/bench_values.py`` measures both against
the per-key loop.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import gtsam
import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..lie import se3, so3
from ..uncertain import UncertainPose
from .groups import GTSAM_GROUPS, gtsam_group

__all__ = [
    "GROUPS",
    "from_gtsam",
    "from_pose3",
    "from_values",
    "to_gtsam",
    "to_pose3",
    "to_values",
]


def _poses_2d_or_3d(T: Any, name: str) -> FloatArray:
    arr = validate.pose(T, name)
    if arr.ndim not in (2, 3):
        raise ValueError(
            f"{name}: expected shape (4, 4) or (N, 4, 4), got {arr.shape}; "
            "reshape to (N, 4, 4) first"
        )
    return arr


def _pose3(T: FloatArray) -> Any:
    return gtsam.Pose3(gtsam.Rot3(T[:3, :3]), T[:3, 3])


def to_pose3(T: Any) -> Any:
    """Build ``gtsam.Pose3`` from one pose ``(4, 4)`` or a list of them from ``(N, 4, 4)``.

    Parameters
    ----------
    T : array_like, shape (4, 4) or (N, 4, 4)
        Homogeneous poses; rotations must be orthonormal with det +1 within
        :data:`liebridge._validate.ROTATION_TOL` (GTSAM itself would accept anything).

    Returns
    -------
    gtsam.Pose3 or list of gtsam.Pose3
    """
    arr = _poses_2d_or_3d(T, "T")
    if arr.ndim == 2:
        return _pose3(arr)
    return [_pose3(Ti) for Ti in arr]


def _check_pose3(p: Any, where: str) -> None:
    if not isinstance(p, gtsam.Pose3):
        raise TypeError(f"{where}: expected gtsam.Pose3, got {type(p).__name__}")


def from_pose3(p: Any) -> FloatArray:
    """``gtsam.Pose3`` → ``(4, 4)``; a sequence of them → ``(N, 4, 4)``.

    Parameters
    ----------
    p : gtsam.Pose3 or sequence of gtsam.Pose3

    Returns
    -------
    ndarray, shape (4, 4) or (N, 4, 4)
        ``Pose3.matrix()``, exactly (no validation: what GTSAM holds is returned as is).
    """
    if isinstance(p, gtsam.Pose3):
        return np.array(p.matrix(), dtype=np.float64)
    if not isinstance(p, Iterable):
        raise TypeError(f"p: expected gtsam.Pose3 or a sequence of them, got {type(p).__name__}")
    items = list(p)
    out = np.empty((len(items), 4, 4))
    for i, pi in enumerate(items):
        _check_pose3(pi, f"p[{i}]")
        out[i] = pi.matrix()
    return out


def _keys(keys: Any, n: int | None, name: str = "keys") -> list[int]:
    if isinstance(keys, (str, bytes)) or not isinstance(keys, Iterable):
        raise TypeError(f"{name}: expected a sequence of integer keys, got {type(keys).__name__}")
    items = keys.tolist() if isinstance(keys, np.ndarray) else list(keys)
    types = set(map(type, items))
    if not all(t is int or issubclass(t, np.integer) for t in types):  # rejects bool, float
        i = next(
            i for i, k in enumerate(items) if not (type(k) is int or isinstance(k, np.integer))
        )
        raise TypeError(f"{name}[{i}]: expected an integer key, got {type(items[i]).__name__}")
    out = list(map(int, items))
    if out and (min(out) < 0 or max(out) >= 2**64):
        i = next(i for i, k in enumerate(out) if k < 0 or k >= 2**64)
        raise ValueError(f"{name}[{i}]: key {out[i]} is not a uint64 GTSAM key")
    if n is not None and len(out) != n:
        raise ValueError(f"{name}: expected {n} keys (one per pose), got {len(out)}")
    return out


def _first_duplicate(keys: Sequence[int]) -> int | None:
    seen: set[int] = set()
    for i, k in enumerate(keys):
        if k in seen:
            return i
        seen.add(k)
    return None


def from_values_pose3(values: Any, keys: Any) -> FloatArray:
    """Read the ``Pose3`` stored under ``keys`` into an ``(N, 4, 4)`` array, in ``keys`` order.

    Parameters
    ----------
    values : gtsam.Values
    keys : sequence of int
        Keys to read (repeats allowed). Each must exist and hold a ``Pose3``.

    Returns
    -------
    ndarray, shape (N, 4, 4)

    Notes
    -----
    One ``gtsam.utilities.extractPose3`` call (rows in increasing key order) replaces N
    ``atPose3(k).matrix()`` calls: on the whole ``values`` when it holds only ``Pose3`` and at
    least a quarter of it is wanted, else on ``values.extract(unique keys)``. About 2× faster
    than the per-key loop at 1,000–10,000 poses; see ``benchmarks/bench_values.py``.
    """
    if not isinstance(values, gtsam.Values):
        raise TypeError(f"values: expected gtsam.Values, got {type(values).__name__}")
    ks = _keys(keys, None)
    if not ks:
        return np.empty((0, 4, 4))
    want = np.array(ks, dtype=np.uint64)
    uniq = np.unique(want)  # sorted, as extractPose3 returns rows
    rows = None
    if 4 * uniq.shape[0] >= values.size():
        # most of the values are wanted: convert them all, no copy of the Values
        all_keys = np.asarray(values.keys(), dtype=np.uint64)  # a std::map: sorted
        rows_all = np.asarray(gtsam.utilities.extractPose3(values))
        if rows_all.shape[0] == all_keys.shape[0]:  # every value is a Pose3
            pos = np.searchsorted(all_keys, uniq)
            pos = np.minimum(pos, all_keys.shape[0] - 1)
            if np.array_equal(all_keys[pos], uniq):
                rows = rows_all[pos]
    if rows is None:
        try:
            sub = values.extract([int(k) for k in uniq])
        except RuntimeError:
            for i, k in enumerate(ks):  # name the first missing key
                if not values.exists(k):
                    raise ValueError(f"keys[{i}]: key {k} is not in values") from None
            raise
        rows = np.asarray(gtsam.utilities.extractPose3(sub))
        if rows.shape[0] != uniq.shape[0]:
            for i, k in enumerate(ks):  # name the first key that does not hold a Pose3
                try:
                    values.atPose3(k)
                except RuntimeError:
                    raise TypeError(f"keys[{i}]: the value under key {k} is not a Pose3") from None
    idx = np.searchsorted(uniq, want)
    rows = rows[idx]
    out = np.zeros((len(ks), 4, 4))
    out[:, :3, :3] = rows[:, :9].reshape(-1, 3, 3)
    out[:, :3, 3] = rows[:, 9:12]
    out[:, 3, 3] = 1.0
    return out


# --------------------------------------------------------------------------- every group
#: GTSAM's record of each group (class, matrix ↔ object; see :mod:`liebridge.gtsam.groups`).
GROUPS = GTSAM_GROUPS


def to_gtsam(X: Any, group: str | None = None) -> Any:
    """Build the GTSAM object of ``group`` from one matrix, or a list from a batch ``(N, n, n)``.

    The one ``to_gtsam`` of liebridge (``liebridge.gtsam.uncertain.to_gtsam`` is this function;
    ``G2OGraph.to_gtsam`` is a method building a whole graph).

    Parameters
    ----------
    X : array_like, shape (n, n) or (N, n, n), or UncertainPose
        Elements as liebridge's matrices (see :data:`GROUPS`), validated (a rotation block must be
        orthonormal, a scale positive, the constant rows exact). An
        :class:`~liebridge.uncertain.UncertainPose` gives ``(object, covariance)``: the
        ``gtsam.Pose3`` or ``gtsam.Rot3`` (a list for a batch) and its covariance in GTSAM's
        tangent ``(ω, v)`` — what ``gtsam.noiseModel.Gaussian.Covariance`` takes for a
        ``PriorFactorPose3`` on that pose.
    group : {"se3", "so3", "se2", "so2", "sim3", "se23"}
        Required for arrays; for an UncertainPose it is implied (``"so3"`` or ``"se3"``).
    """
    if isinstance(X, UncertainPose):
        implied = (so3.GROUP if X.is_rotation else se3.GROUP).name
        if group is not None and group != implied:
            raise ValueError(f"group: {group!r} given for an UncertainPose of {implied!r}")
        return to_gtsam(X.T, implied), np.array(X.gtsam_cov())
    if group is None:
        raise TypeError(f"group: required for an array X (one of {tuple(GROUPS)})")
    rec = gtsam_group(group)
    n, make = rec.group.matrix, rec.to_object
    arr = rec.group.element(X, "X")
    if arr.ndim == 2:
        return make(arr)
    if arr.ndim != 3:
        raise ValueError(f"X: expected shape ({n}, {n}) or (N, {n}, {n}), got {arr.shape}")
    return [make(a) for a in arr]


def from_gtsam(obj: Any, group: str) -> FloatArray:
    """Return the matrix of one GTSAM object of ``group`` (``Pose2``, ``NavState``, ...)."""
    rec = gtsam_group(group)
    if type(obj).__name__ != rec.cls:
        raise TypeError(
            f"obj: expected gtsam.{rec.cls} for group {group!r}, got {type(obj).__name__}"
        )
    return np.asarray(rec.from_object(obj), dtype=np.float64)


def to_values(T: Any, keys: Any, values: Any = None, *, group: str = "se3") -> Any:
    """Insert a batch of elements into a ``gtsam.Values`` as the GTSAM class of ``group``.

    Parameters
    ----------
    T : array_like, shape (N, n, n)
        Elements as liebridge's matrices of ``group`` (see :data:`GROUPS`).
    keys : sequence of int, length N
        GTSAM keys; must be unique.
    values : gtsam.Values, optional
        Existing values to extend (not modified: a copy is returned). Keys must not collide.
    group : {"se3", "so3", "se2", "so2", "sim3", "se23"}
        ``"se3"`` (default) stores ``Pose3``, ``"se2"`` ``Pose2``, ``"sim3"`` ``Similarity3``,
        ``"se23"`` ``NavState``, and so on.

    Returns
    -------
    gtsam.Values
    """
    rec = gtsam_group(group)
    n, make = rec.group.matrix, rec.to_object
    arr = rec.group.element(T, "T")
    if arr.ndim != 3:
        raise ValueError(f"T: expected shape (N, {n}, {n}), got {arr.shape}")
    ks = _keys(keys, arr.shape[0])
    dup = _first_duplicate(ks)
    if dup is not None:
        raise ValueError(f"keys: key {ks[dup]} appears twice (second time at index {dup})")
    if values is None:
        out = gtsam.Values()
    elif isinstance(values, gtsam.Values):
        out = gtsam.Values(values)
        for i, k in enumerate(ks):
            if out.exists(k):
                raise ValueError(f"keys[{i}]: key {k} already exists in values")
    else:
        raise TypeError(f"values: expected gtsam.Values or None, got {type(values).__name__}")
    for k, Xi in zip(ks, arr, strict=True):
        out.insert(k, make(Xi))
    return out


def from_values(values: Any, keys: Any, *, group: str = "se3") -> FloatArray:
    """Read the elements of ``group`` stored under ``keys`` into an ``(N, n, n)`` array.

    ``group="se3"`` (default) reads ``Pose3`` in one batched call (its record's ``read_values``);
    the other groups read ``values.atPose2(k)``, ``atSimilarity3``, ``atNavState``... per key.
    A missing key or a value of another type is a ``ValueError``/``TypeError`` naming it.
    """
    rec = gtsam_group(group)
    if rec.read_values is not None:
        return rec.read_values(values, keys)
    n, cls, read = rec.group.matrix, rec.cls, rec.from_object
    if not isinstance(values, gtsam.Values):
        raise TypeError(f"values: expected gtsam.Values, got {type(values).__name__}")
    ks = _keys(keys, None)
    at = getattr(values, f"at{cls}")
    out = np.empty((len(ks), n, n))
    for i, k in enumerate(ks):
        if not values.exists(k):
            raise ValueError(f"keys[{i}]: key {k} is not in values")
        try:
            out[i] = read(at(k))
        except RuntimeError:
            raise TypeError(f"keys[{i}]: the value under key {k} is not a {cls}") from None
    return out
