"""Pose layouts: flat vectors ↔ homogeneous ``(..., 4, 4)`` matrices, with the order explicit.

Old path: also reachable as ``lb.poses`` (earlier releases); new code writes ``lb.io.poses``.

Every layout names where the translation and the quaternion sit and the quaternion's storage
order; liebridge never guesses it. All quaternions are Hamilton (see
:mod:`liebridge.lie.quaternion`).

Layouts (element order; who uses it):

* ``"xyz_qxyzw"`` — 7 numbers ``[x, y, z, qx, qy, qz, qw]``: TUM RGB-D trajectory files, ROS
  ``geometry_msgs/Pose`` (position, then orientation x, y, z, w), g2o ``VERTEX_SE3:QUAT`` /
  ``EDGE_SE3:QUAT``, Pinocchio ``XYZQUATToSE3`` / ``SE3ToXYZQUAT`` (and the free-flyer ``q``),
  manif ``SE3`` coeffs, PyPose ``SE3``.
* ``"xyz_qwxyz"`` — 7 numbers ``[x, y, z, qw, qx, qy, qz]``: pytransform3d ``pq``
  (``transform_from_pq`` / ``pq_from_transform``).
* ``"qxyzw_xyz"`` — 7 numbers ``[qx, qy, qz, qw, x, y, z]``: Sophus ``SE3::params()``, symforce
  ``Pose3`` storage.
* ``"qwxyz_xyz"`` — 7 numbers ``[qw, qx, qy, qz, x, y, z]``: jaxlie ``SE3`` (``wxyz_xyz``).
* ``"kitti"`` — 12 numbers, the top 3×4 block ``[R | t]`` row-major: KITTI odometry
  ``poses/*.txt``.
* ``"matrix"`` — ``(4, 4)`` homogeneous ``[[R, t], [0, 1]]``: liebridge's canonical form, GTSAM
  ``Pose3.matrix()``.

Evidence for the library rows: ``docs/library-facts.md`` (quaternion storage column)
and, for pytransform3d and Pinocchio, the tests in ``tests/test_poses.py`` which run them.

Reading (:func:`to_matrix`) never repairs input silently: a quaternion whose norm is off by more
than :data:`QUATERNION_TOL` raises (naming the batch index and by how much); within it, the
quaternion is normalised. A rotation block (``"kitti"``, ``"matrix"``) must be orthonormal within
:data:`ROTATION_TOL`; it is returned as given, not projected. Writing (:func:`from_matrix`) returns
quaternions with ``w ≥ 0``.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from .. import _validate as validate
from .._validate import QUATERNION_TOL, ROTATION_TOL, FloatArray
from ..lie import quaternion as quat

__all__ = [
    "QUATERNION_TOL",
    "ROTATION_TOL",
    "TEXT_TOL_MAX",
    "Layout",
    "describe",
    "from_matrix",
    "layouts",
    "text_quaternion_tol",
    "text_rotation_tol",
    "to_matrix",
]

Layout = Literal["xyz_qxyzw", "xyz_qwxyz", "qxyzw_xyz", "qwxyz_xyz", "kitti", "matrix"]


@dataclass(frozen=True)
class _Spec:
    shape: tuple[int, ...]
    meaning: str
    used_by: tuple[str, ...]
    # quaternion layouts: slice of the translation, slice of the quaternion, its order
    t_slice: slice | None = None
    q_slice: slice | None = None
    q_order: quat.QuatOrder | None = None


_LAYOUTS: dict[str, _Spec] = {
    "xyz_qxyzw": _Spec(
        (7,),
        "[x, y, z, qx, qy, qz, qw]",
        ("TUM", "ROS geometry_msgs/Pose", "g2o", "Pinocchio", "manif", "PyPose"),
        slice(0, 3),
        slice(3, 7),
        "xyzw",
    ),
    "xyz_qwxyz": _Spec(
        (7,),
        "[x, y, z, qw, qx, qy, qz]",
        ("pytransform3d",),
        slice(0, 3),
        slice(3, 7),
        "wxyz",
    ),
    "qxyzw_xyz": _Spec(
        (7,),
        "[qx, qy, qz, qw, x, y, z]",
        ("Sophus", "symforce"),
        slice(4, 7),
        slice(0, 4),
        "xyzw",
    ),
    "qwxyz_xyz": _Spec(
        (7,),
        "[qw, qx, qy, qz, x, y, z]",
        ("jaxlie",),
        slice(4, 7),
        slice(0, 4),
        "wxyz",
    ),
    "kitti": _Spec((12,), "top 3x4 block [R | t], row-major (12 numbers)", ("KITTI",)),
    "matrix": _Spec((4, 4), "homogeneous 4x4 [[R, t], [0, 1]]", ("liebridge", "GTSAM")),
}


def layouts() -> tuple[str, ...]:
    """Names of the supported pose layouts, in documentation order."""
    return tuple(_LAYOUTS)


def describe(layout: str) -> str:
    """One line: the layout's element order and the libraries that use it."""
    spec = _spec(layout)
    return f"{layout}: {spec.meaning}; used by {', '.join(spec.used_by)}"


def _name(layout: str) -> str:
    """Return the layout name read like every string option: stripped, lower case."""
    return layout.strip().lower()


def _spec(layout: Any) -> _Spec:
    if not isinstance(layout, str):
        raise TypeError(f"layout: expected a layout name (str), got {type(layout).__name__}")
    try:
        return _LAYOUTS[_name(layout)]
    except KeyError:
        pass
    hints = difflib.get_close_matches(layout, list(_LAYOUTS), n=3, cutoff=0.5)
    low = layout.lower()
    if len(low) >= 3:  # a library name ("tum", "sophus") points to the layout it uses
        for name, spec in _LAYOUTS.items():
            if any(low in lib.lower() for lib in spec.used_by) and name not in hints:
                hints.append(name)
    msg = f"layout: unknown layout {layout!r}"
    if hints:
        msg += "; did you mean " + " or ".join(repr(h) for h in hints) + "?"
    raise ValueError(msg + f" (known: {', '.join(_LAYOUTS)})")


def _normalised_quaternion(q: FloatArray, name: str, tol: float) -> FloatArray:
    """Normalise ``q`` (..., 4) if ``| ‖q‖ − 1 | ≤ tol`` everywhere, else raise naming the index."""
    norm = np.linalg.norm(q, axis=-1)
    err = np.abs(norm - 1.0)
    if (err > tol).any():
        bad = np.argwhere(err > tol)[0]
        i = tuple(int(k) for k in bad)
        raise ValueError(
            f"{name}: quaternion norm off by {float(err[i]):.3g} at batch index {i} "
            f"(tolerance {tol:g}); normalise it explicitly if that is intended"
        )
    return np.asarray(q / norm[..., None], dtype=np.float64)


def to_matrix(x: Any, *, layout: Layout | str, tol: float | None = None) -> FloatArray:
    """Convert poses stored in ``layout`` to homogeneous matrices ``(..., 4, 4)``.

    Parameters
    ----------
    x : array_like, shape (..., 7), (..., 12) or (..., 4, 4)
        Poses in ``layout`` (see the module table); any leading batch shape.
    layout : str
        One of :func:`layouts`. Required: the quaternion order is never guessed.
    tol : float, optional
        Quaternion layouts: accepted ``| ‖q‖ − 1 |`` (default :data:`QUATERNION_TOL`); within it
        the quaternion is normalised, beyond it a ``ValueError`` names the batch index and the
        size of the error. ``"kitti"`` / ``"matrix"``: accepted ``max|RᵀR − I|`` (default
        :data:`ROTATION_TOL`); the rotation is returned unchanged, never projected.

    Returns
    -------
    ndarray, shape (..., 4, 4)
        ``T = [[R, t], [0, 1]]`` (a new array; ``x`` is not modified).
    """
    spec = _spec(layout)
    layout = _name(layout)
    if layout == "matrix":
        return np.array(
            validate.pose(x, "x", ROTATION_TOL if tol is None else tol), dtype=np.float64
        )
    arr = validate.as_float_array(x, "x")
    if arr.ndim < 1 or arr.shape[-1:] != spec.shape:
        raise ValueError(
            f"x: layout {layout!r} expects shape (..., {spec.shape[0]}), got {arr.shape}"
        )
    validate.check_finite(arr, "x")
    T = np.zeros((*arr.shape[:-1], 4, 4))
    T[..., 3, 3] = 1.0
    if layout == "kitti":
        T[..., :3, :] = arr.reshape((*arr.shape[:-1], 3, 4))
        validate.check_rotation(T[..., :3, :3], "x", ROTATION_TOL if tol is None else tol)
        return T
    assert spec.q_slice is not None and spec.t_slice is not None and spec.q_order is not None
    q = _normalised_quaternion(
        arr[..., spec.q_slice],
        f"x (layout {layout!r})",
        QUATERNION_TOL if tol is None else tol,
    )
    T[..., :3, :3] = quat.to_matrix(q, order=spec.q_order)
    T[..., :3, 3] = arr[..., spec.t_slice]
    return T


def from_matrix(T: Any, *, layout: Layout | str) -> FloatArray:
    """Convert homogeneous matrices ``(..., 4, 4)`` to ``layout``.

    Parameters
    ----------
    T : array_like, shape (..., 4, 4)
        Poses; the rotation block must be orthonormal within :data:`ROTATION_TOL` (project
        explicitly with :func:`liebridge.lie.so3.project` otherwise) and the bottom row
        ``[0, 0, 0, 1]``.
    layout : str
        One of :func:`layouts`.

    Returns
    -------
    ndarray, shape (..., 7), (..., 12) or (..., 4, 4)
        Quaternion layouts hold the quaternion with ``w ≥ 0`` (``q`` and ``−q`` are the same
        rotation; the sign is chosen, never left to chance).
    """
    spec = _spec(layout)
    layout = _name(layout)
    T = validate.pose(T, "T")
    if layout == "matrix":
        return np.array(T, dtype=np.float64)
    if layout == "kitti":
        return np.ascontiguousarray(T[..., :3, :]).reshape((*T.shape[:-2], 12))
    assert spec.q_slice is not None and spec.t_slice is not None and spec.q_order is not None
    out = np.empty((*T.shape[:-2], 7))
    out[..., spec.q_slice] = quat.from_matrix(T[..., :3, :3], order=spec.q_order)
    out[..., spec.t_slice] = T[..., :3, 3]
    return out


#: Largest tolerance :func:`text_quaternion_tol` / :func:`text_rotation_tol` grant: numbers
#: printed with fewer than three decimals are not trusted to describe a rotation.
TEXT_TOL_MAX = 1e-3


def _text_place(fields: list[str] | tuple[str, ...]) -> float:
    """Place of the last printed digit, read from the field(s) with the most significant digits.

    ``%g`` strips trailing zeros (``0.5`` says nothing about the writer's precision) and ``repr``
    prints ``0.1`` for 0.1, so the precision is taken from the most detailed fields: the coarsest
    last-digit place among the fields with the most significant digits.
    """
    best_sig, place = -1, 0.0
    for f in fields:
        mant, _, exp = f.lower().partition("e")
        whole, _, frac = mant.lstrip("+-").partition(".")
        sig = len((whole + frac).lstrip("0"))
        try:
            e = (int(exp) if exp else 0) - len(frac)
        except ValueError:
            e = 0
        # a finite number may carry any exponent (``0e400`` is 0.0): clip to float64's range
        p = 10.0 ** min(max(e, -320), 300)
        if sig > best_sig:
            best_sig, place = sig, p
        elif sig == best_sig:
            place = max(place, p)
    return place


def text_quaternion_tol(fields: list[str] | tuple[str, ...]) -> float:
    """Norm tolerance for a quaternion parsed from text, from the precision it was printed with.

    Text cannot hold a unit quaternion exactly: a component whose last printed digit sits at
    place ``p`` (``0.6574`` → ``1e-4``; ``1.5e-07`` → ``1e-8``) is off by up to ``p/2``, so the norm
    of four such components is off by up to ``√4 · p/2 = p``. The tolerance is ``2·p`` (``p`` from
    the most detailed fields, see ``_text_place``) clipped to
    ``[QUATERNION_TOL, TEXT_TOL_MAX]``: full-precision text gets :data:`QUATERNION_TOL`, TUM
    RGB-D ground truth (4 decimals) ``2e-4``, GTSAM's ``writeG2o`` output (6 significant digits)
    ``2e-6``, and ``"1 1 0 0"`` still fails. Used by :mod:`liebridge.io.trajectory` and
    :mod:`liebridge.io.g2o`.
    """
    return float(min(max(QUATERNION_TOL, 2.0 * _text_place(fields)), TEXT_TOL_MAX))


def text_rotation_tol(fields: list[str] | tuple[str, ...]) -> float:
    """Tolerance on ``max|RᵀR − I|`` for a rotation matrix parsed from text (nine fields).

    Entries off by up to ``p/2`` change ``(RᵀR)_ij = Σ_k r_ki r_kj`` by up to
    ``Σ_k (|r_ki| + |r_kj|)·p/2 ≤ √3·p`` (columns of unit norm), so the tolerance is ``2·p``
    clipped to ``[ROTATION_TOL, TEXT_TOL_MAX]``. KITTI ground truth (``%e`` with 6 decimals)
    gets ``2e-6``.
    """
    return float(min(max(ROTATION_TOL, 2.0 * _text_place(fields)), TEXT_TOL_MAX))


def stamped_poses(timestamps: Any, poses: Any) -> tuple[FloatArray, FloatArray]:
    """Validate a trajectory to write: finite ``timestamps (N,)`` and poses ``(N, 4, 4)``."""
    t = validate.as_float_array(timestamps, "timestamps")
    validate.check_finite(t, "timestamps")
    T = validate.pose(poses, "poses")
    if t.ndim != 1 or T.ndim != 3 or T.shape[0] != t.shape[0]:
        raise ValueError(
            f"timestamps, poses: expected (N,) and (N, 4, 4), got {t.shape}, {T.shape}"
        )
    return t, T
