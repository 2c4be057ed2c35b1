"""Other libraries' pose and rotation objects, in and out.

In: every liebridge function that takes a pose or a rotation (and every other array argument)
also takes the objects below, or a list or tuple of them, read as their homogeneous matrices
(``(4, 4)`` SE(3), ``(3, 3)`` SO(3)) by the same validation as an array
(:data:`liebridge._validate.LIBRARY_OBJECTS`). The object is recognised by the module of its class
(``type(obj).__module__``), so none of these libraries is imported by liebridge unless the object
is already one of theirs:

========================================= ======================== ==============================
library (import)                          classes                  read as
========================================= ======================== ==============================
GTSAM (``gtsam``)                         ``Pose3``, ``Rot3``      ``.matrix()``
GTSAM (``gtsam``), planar                 ``Pose2``, ``Rot2``      ``.matrix()`` (3×3, 2×2)
Sophus (``sophuspy``)                     ``SE3``, ``SO3``         ``.matrix()``
Sophus (``projectaria_tools.core.sophus``) ``SE3``, ``SO3``        ``.to_matrix()`` (vectorized)
Pinocchio (``pinocchio``)                 ``SE3``                  ``.homogeneous``
spatialmath (``spatialmath``)             ``SE3``, ``SO3``, …      ``.A`` (every value)
scipy (``scipy.spatial.transform``)       ``Rotation``,            ``.as_matrix()`` (vectorized)
                                          ``RigidTransform``
========================================= ======================== ==============================

Anything else raises one ``TypeError`` naming the argument and listing what is accepted. The
matrices carry no convention: a library's *tangent* order and perturbation side are the
conventions' business (``liebridge.conventions.get("sophus")``, ...), the matrix of a pose is the
same ``T_world_body`` in all of them.

Out: :func:`to_library` builds the caller's type from liebridge's matrices (a Python list of
objects for a batch of a non-vectorized class), ``to_library(T, like=obj)``.

Sequences: GTSAM, sophuspy and Pinocchio objects hold one pose each (a list of them is a batch);
scipy, spatialmath and projectaria objects may hold several (read as a ``(N, 4, 4)`` batch).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import _validate as validate
from ._validate import library_key

__all__ = ["SUPPORTED", "from_library", "library_key", "to_library"]

#: How :func:`to_library` builds each class from validated matrices:
#: ``(module root, class) → (group, constructor, vectorized)``. ``group`` is ``"SE3"``, ``"SO3"``,
#: ``"SE2"`` or ``"SO2"``; ``constructor`` is ``"call"`` (``cls(M)``), ``"from_matrix"``
#: (``cls.from_matrix(M)``), ``"list"`` (``cls([M, ...])``, spatialmath), ``"pose2"``
#: (``cls(x, y, θ)``) or ``"rot2"`` (``cls(θ)``); ``vectorized``: one object holds a batch.
_BUILD: dict[tuple[str, str], tuple[str, str, bool]] = {
    ("gtsam", "Pose3"): ("SE3", "call", False),
    ("gtsam", "Rot3"): ("SO3", "call", False),
    ("gtsam", "Pose2"): ("SE2", "pose2", False),
    ("gtsam", "Rot2"): ("SO2", "rot2", False),
    ("sophuspy", "SE3"): ("SE3", "call", False),
    ("sophuspy", "SO3"): ("SO3", "call", False),
    ("_core_pybinds", "SE3"): ("SE3", "from_matrix", True),
    ("_core_pybinds", "SO3"): ("SO3", "from_matrix", True),
    ("pinocchio", "SE3"): ("SE3", "call", False),
    ("spatialmath", "SE3"): ("SE3", "list", True),
    ("spatialmath", "SO3"): ("SO3", "list", True),
    ("spatialmath", "SE2"): ("SE2", "list", True),
    ("spatialmath", "SO2"): ("SO2", "list", True),
    ("scipy", "Rotation"): ("SO3", "from_matrix", True),
    ("scipy", "RigidTransform"): ("SE3", "from_matrix", True),
}

#: The accepted classes, ``(module root, class name)``: the keys of
#: :data:`liebridge._validate.LIBRARY_OBJECTS` (``_core_pybinds`` is projectaria_tools').
SUPPORTED: tuple[tuple[str, str], ...] = tuple(validate.LIBRARY_OBJECTS)

_E3 = np.array([0.0, 0.0, 1.0])


def from_library(obj: Any, name: str = "obj") -> validate.FloatArray:
    """Return the homogeneous matrix (batch) of a library's pose or rotation object (or list).

    Parameters
    ----------
    obj : object
        One of the classes of the module docstring, a list or tuple of them, or an array (returned
        as float64).
    name : str
        Argument name used in error messages.

    Returns
    -------
    numpy.ndarray
        ``(4, 4)`` for an SE(3) pose, ``(3, 3)`` for a rotation or an SE(2) pose, ``(2, 2)`` for
        an SO(2) rotation; with a leading batch axis for a list or a vectorized object. Not
        validated as a rotation: the functions that take poses validate.

    Examples
    --------
    >>> import gtsam
    >>> from liebridge import interop
    >>> interop.from_library(gtsam.Pose3()).shape
    (4, 4)
    """
    return validate.as_float_array(obj, name)


def _check_planar(M: validate.FloatArray, name: str, group: str) -> validate.FloatArray:
    """Validate SE(2) ``(..., 3, 3)`` or SO(2) ``(..., 2, 2)`` matrices (ground floor has 3D)."""
    n = 3 if group == "SE2" else 2
    arr = validate.square(M, name, n)
    R = arr[..., :2, :2]
    err = np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(2)).max(axis=(-1, -2))
    det = R[..., 0, 0] * R[..., 1, 1] - R[..., 0, 1] * R[..., 1, 0]
    bad = ~(err <= validate.ROTATION_TOL) | (det <= 0)
    if bad.any():
        i = tuple(int(k) for k in np.argwhere(np.asarray(bad))[0]) if bad.ndim else ()
        raise ValueError(
            f"{name}: not a planar rotation at batch index {i}: max|RᵀR − I| = "
            f"{float(np.asarray(err)[i]):.3g}, det = {float(np.asarray(det)[i]):.3g}"
        )
    if group == "SE2" and (arr[..., 2, :] != _E3).any():
        i = tuple(int(k) for k in np.argwhere((arr[..., 2, :] != _E3).any(axis=-1))[0])
        raise ValueError(f"{name}: bottom row is not [0, 0, 1] at batch index {i}")
    return arr


def _build_one(cls: Any, M: validate.FloatArray, how: str) -> Any:
    if how == "call" or how == "list":
        return cls(M)
    if how == "from_matrix":
        return cls.from_matrix(M)
    theta = float(np.arctan2(M[1, 0], M[0, 0]))
    if how == "pose2":
        return cls(float(M[0, 2]), float(M[1, 2]), theta)
    return cls(theta)  # rot2


def _build_nested(cls: Any, M: validate.FloatArray, how: str, core: int) -> Any:
    if M.ndim == core:
        return _build_one(cls, M, how)
    return [_build_nested(cls, m, how, core) for m in M]


def to_library(T: Any, like: Any, name: str = "T") -> Any:
    """Return ``T`` as an object (or list of objects) of the class of ``like``.

    Parameters
    ----------
    T : array_like
        Homogeneous matrices in liebridge's storage: ``(..., 4, 4)`` poses for an SE(3) class,
        ``(..., 3, 3)`` rotations for an SO(3) class (``(..., 3, 3)`` SE(2), ``(..., 2, 2)`` SO(2)
        for the planar classes); validated (rotation within ``ROTATION_TOL``, bottom row exact).
        A library object is accepted too (``to_library(gtsam_pose, like=pin.SE3)``).
    like : object or type
        An object of the wanted class, or the class itself: one of :data:`SUPPORTED`.
    name : str
        Argument name used in error messages.

    Returns
    -------
    object
        For one matrix, one object. For a batch: one object holding the batch for the vectorized
        classes (scipy ``Rotation``/``RigidTransform``, spatialmath, projectaria; batch axes
        flattened), else a (nested)
        Python list of objects with the batch's shape.

    Raises
    ------
    TypeError
        ``like`` is not one of the supported classes.
    ValueError
        ``T`` has the wrong shape for that class or is not a valid pose/rotation.

    Examples
    --------
    >>> import gtsam, liebridge as lb
    >>> from liebridge import interop
    >>> P = gtsam.Pose3(gtsam.Rot3.Rz(0.3), [1.0, 2.0, 3.0])
    >>> T = lb.lie.se3.exp(lb.lie.se3.log(P))         # a gtsam.Pose3 in, a (4, 4) array out
    >>> interop.to_library(T, like=P).equals(P, 1e-12)
    True
    """
    key = library_key(like)
    build = _BUILD.get(key) if key is not None else None
    cls: Any = like if isinstance(like, type) else type(like)
    if key is None or build is None:
        names = ", ".join(f"{root}.{c}" for root, c in _BUILD)
        raise TypeError(
            f"like: expected an object or class among {names}; got {cls.__module__}.{cls.__name__}"
        )
    group, how, vectorized = build
    if group == "SE3":
        M = validate.pose(T, name)
    elif group == "SO3":
        M = validate.rotation(T, name)
    else:
        M = _check_planar(validate.as_float_array(T, name), name, group)
    core = 2
    if vectorized and M.ndim > core:
        flat = M.reshape(-1, *M.shape[-2:])
        if how == "list":
            return cls(list(flat))
        return cls.from_matrix(flat)
    return _build_nested(cls, M, how, core)
