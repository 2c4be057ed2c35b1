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

**Learned-SLAM tensor libraries** (:func:`as_pose_matrix` reads them, :func:`to_library` builds
them; recognised by ``type(obj).__module__`` too, never imported eagerly). Their matrices stay in
the library's array type — a torch tensor (device, dtype and autograd graph kept) or a JAX array:

========================================= ===================== ================================
library (import)                          classes               stored as
========================================= ===================== ================================
PyPose (``pypose``)                       ``LieTensor`` SE3/SO3 ``[tx, ty, tz, qx, qy, qz, qw]``
                                          (``ltype``)           / ``[qx, qy, qz, qw]``
lietorch (``lietorch``)                   ``SE3``, ``SO3``      ``.data`` as PyPose
Theseus (``theseus``)                     ``SE3``, ``SO3``      ``.tensor`` ``(B, 3, 4)`` /
                                                                ``(B, 3, 3)`` (always a batch)
kornia (``kornia.geometry.liegroup``)     ``Se3``, ``So3``      ``.r.q.data`` ``[w, x, y, z]``,
                                                                ``.t``
jaxlie (``jaxlie``)                       ``SE3``, ``SO3``      ``wxyz_xyz`` / ``wxyz``
========================================= ===================== ================================

DPVO and DROID-SLAM keep ``T_cam_world`` in lietorch: the matrix read from such an object is
``T_cam_world``; invert it for ``T_world_cam`` (the ``dpvo`` preset's element).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import _validate as validate
from . import arrays
from ._validate import library_key

__all__ = [
    "SUPPORTED",
    "TENSOR_LIBRARIES",
    "as_pose_matrix",
    "from_library",
    "library_key",
    "tensor_library_key",
    "to_library",
]

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


# ----------------------------------------------------------------------------- tensor libraries
#: Pose classes of the learned-SLAM tensor libraries, ``(module root, class) → group`` (``"SE3"``,
#: ``"SO3"``; a PyPose ``LieTensor``'s group is its ``ltype``).
_TENSOR_CLASSES: dict[tuple[str, str], str] = {
    ("pypose", "LieTensor"): "ltype",
    ("lietorch", "SE3"): "SE3",
    ("lietorch", "SO3"): "SO3",
    ("theseus", "SE3"): "SE3",
    ("theseus", "SO3"): "SO3",
    ("kornia", "Se3"): "SE3",
    ("kornia", "So3"): "SO3",
    ("jaxlie", "SE3"): "SE3",
    ("jaxlie", "SO3"): "SO3",
}

#: The names :func:`to_library` takes for ``like`` (the library's import name), each with its
#: SE(3) and SO(3) class: ``name → (module, SE(3) class, SO(3) class)``.
TENSOR_LIBRARIES: dict[str, tuple[str, str, str]] = {
    "pypose": ("pypose", "LieTensor", "LieTensor"),
    "lietorch": ("lietorch", "SE3", "SO3"),
    "theseus": ("theseus", "SE3", "SO3"),
    "kornia": ("kornia.geometry.liegroup", "Se3", "So3"),
    "jaxlie": ("jaxlie", "SE3", "SO3"),
}
#: The other libraries' names for ``like``: ``name → (module, SE(3) class, SO(3) class)``.
_CLASSIC_LIBRARIES: dict[str, tuple[str, str, str]] = {
    "gtsam": ("gtsam", "Pose3", "Rot3"),
    "sophuspy": ("sophuspy", "SE3", "SO3"),
    "pinocchio": ("pinocchio", "SE3", ""),
    "scipy": ("scipy.spatial.transform", "RigidTransform", "Rotation"),
    "spatialmath": ("spatialmath", "SE3", "SO3"),
}


def tensor_library_key(obj: Any) -> tuple[str, str] | None:
    """Return ``(module root, class name)`` of a tensor library's pose object or class, else None.

    Only ``__module__`` strings are read: nothing is imported. The keys are PyPose's
    ``LieTensor``, lietorch's, Theseus's and jaxlie's ``SE3``/``SO3`` and kornia's ``Se3``/``So3``.
    """
    cls = obj if isinstance(obj, type) else type(obj)
    key = (str(getattr(cls, "__module__", "")).partition(".")[0], cls.__name__)
    return key if key in _TENSOR_CLASSES else None


def _pypose_group(obj: Any, name: str) -> str:
    ltype = type(getattr(obj, "ltype", None)).__name__  # SE3Type, SO3Type, se3Type, ...
    group = ltype.removesuffix("Type")
    if group not in ("SE3", "SO3"):
        # PyPose names its tangent (Lie algebra) types in lower case: se3Type, so3Type, sim3Type
        hint = " (a tangent: call .Exp() for the element)" if group.islower() else ""
        raise TypeError(
            f"{name}: a pypose LieTensor of type {group or ltype!r}{hint} is not an SE(3) pose or "
            "an SO(3) rotation"
        )
    return group


def _plain_tensor(x: Any) -> Any:
    """Return a torch tensor subclass (PyPose's LieTensor) as a plain ``torch.Tensor``."""
    import torch  # the object is a torch library's: torch is imported already

    return x.as_subclass(torch.Tensor) if isinstance(x, torch.Tensor) else x


def _tensor_matrix(obj: Any, key: tuple[str, str], name: str) -> Any:
    """Return a tensor library object's homogeneous matrix, in that library's array type."""
    root = key[0]
    if root == "pypose":
        group = _pypose_group(obj, name)
        M = _plain_tensor(obj.matrix())
        return M[..., :3, :3] if group == "SO3" else M
    if root == "lietorch":  # .matrix() acts on the homogeneous identity: 4×4 for SO3 too
        M = obj.matrix()
        return M[..., :3, :3] if key[1] == "SO3" else M
    if root == "theseus":
        return obj.to_matrix()
    if root == "kornia":
        return obj.matrix()
    return obj.as_matrix()  # jaxlie


def as_pose_matrix(obj: Any, name: str = "obj") -> Any:
    """Return the homogeneous matrix of a library's pose or rotation object; anything else as is.

    Parameters
    ----------
    obj : object
        A pose or rotation of a tensor library (PyPose ``LieTensor`` of type SE3/SO3, lietorch
        ``SE3``/``SO3``, Theseus ``SE3``/``SO3``, kornia ``Se3``/``So3``, jaxlie ``SE3``/``SO3``),
        of a library of :data:`SUPPORTED` (GTSAM, Sophus, Pinocchio, spatialmath, scipy), or a
        list or tuple of the latter. Anything else (an array, a tensor, a number, a list of
        numbers) is returned unchanged for the caller's own validation.
    name : str
        Argument name used in error messages.

    Returns
    -------
    array
        ``(..., 4, 4)`` for a pose, ``(..., 3, 3)`` for a rotation, in liebridge's storage
        (``[R t; 0 1]``, ``T_world_body`` as the object holds it). The tensor libraries' matrices
        stay in their array type (a ``torch.Tensor`` on the object's device with its dtype and
        autograd graph; a JAX array for jaxlie); the others are float64 numpy arrays
        (:func:`from_library`). Theseus objects always carry a batch axis ``(B, 4, 4)``.

    Raises
    ------
    TypeError
        For an object of a known library that is not a pose or rotation (a PyPose ``se3``
        tangent, a ``gtsam.Point3``), naming ``name``.

    Notes
    -----
    Recognised by ``type(obj).__module__``: no library is imported unless ``obj`` is already one
    of its objects. The matrix carries no convention; a stored world→camera pose (DPVO,
    DROID-SLAM) reads as ``T_cam_world``.
    """
    key = tensor_library_key(obj)
    if key is not None and not isinstance(obj, type):
        return _tensor_matrix(obj, key, name)
    if library_key(obj) is not None or (
        type(obj) in (list, tuple) and obj and library_key(obj[0]) is not None
    ):
        return from_library(obj, name)
    return obj


def _to_numpy(T: Any) -> Any:
    """Return a detached float64 numpy copy of ``T`` (for validation only)."""
    if hasattr(T, "detach"):
        T = T.detach().cpu().numpy()
    return np.asarray(T, dtype=np.float64)


def _check_tensor_input(T: Any, group: str, name: str) -> None:
    arr = _to_numpy(T)
    if group == "SE3":
        validate.pose(arr, name)
    else:
        validate.rotation(arr, name)


def _torch_input(T: Any) -> Any:
    import torch

    return T if isinstance(T, torch.Tensor) else torch.as_tensor(_to_numpy(T))


def _build_tensor(T: Any, key: tuple[str, str], group: str, name: str) -> Any:
    """Build a tensor library's object from liebridge matrices (validated here)."""
    import importlib

    _check_tensor_input(T, group, name)
    root = key[0]
    if root == "jaxlie":
        import jax.numpy as jnp

        jaxlie = importlib.import_module("jaxlie")
        cls = jaxlie.SE3 if group == "SE3" else jaxlie.SO3
        return cls.from_matrix(jnp.asarray(T if not hasattr(T, "detach") else _to_numpy(T)))
    Tt = _torch_input(T)
    if root == "pypose":
        pp = importlib.import_module("pypose")
        return pp.mat2SE3(Tt, check=False) if group == "SE3" else pp.mat2SO3(Tt, check=False)
    if root == "theseus":
        th = importlib.import_module("theseus")
        if group == "SE3":
            return th.SE3(tensor=Tt.reshape(-1, 4, 4)[:, :3, :])
        return th.SO3(tensor=Tt.reshape(-1, 3, 3))
    if root == "kornia":
        lg = importlib.import_module("kornia.geometry.liegroup")
        return (lg.Se3 if group == "SE3" else lg.So3).from_matrix(Tt)
    # lietorch: no from-matrix constructor; its storage [t, qx, qy, qz, qw] from liebridge's
    import torch

    from .lie import quaternion

    lt = importlib.import_module("lietorch")
    R = _to_numpy(Tt)[..., :3, :3]
    q = torch.as_tensor(quaternion.from_matrix(R, order="xyzw"), dtype=Tt.dtype, device=Tt.device)
    if group == "SO3":
        return lt.SO3(q)
    return lt.SE3(torch.cat([Tt[..., :3, 3], q], dim=-1))


def _pypose_like_group(like: Any, T: Any) -> str:
    """Return the group a PyPose ``like`` asks for: its ``ltype``, or (a class) ``T``'s shape."""
    if not isinstance(like, type):
        return _pypose_group(like, "like")
    shape = tuple(getattr(T, "shape", np.shape(T)))
    return "SO3" if shape[-2:] == (3, 3) else "SE3"


def _resolve_like(like: Any, T: Any) -> tuple[Any, tuple[str, str] | None]:
    """Return ``like`` as (object or class, tensor key or None); a name picks a class by shape."""
    if not isinstance(like, str):
        return like, tensor_library_key(like)
    key = like.strip().lower().replace("-", "_")
    table = {**TENSOR_LIBRARIES, **_CLASSIC_LIBRARIES}
    if key in ("torchlie", "theseus_ai"):
        key = "theseus"
    if key not in table:
        raise ValueError(
            f"like: unknown library {like!r}; expected one of {', '.join(table)} (or an object "
            "or class of the library)"
        )
    module, se3_cls, so3_cls = table[key]
    shape = tuple(getattr(T, "shape", np.shape(T)))
    cls_name = so3_cls if shape[-2:] == (3, 3) else se3_cls
    if not cls_name:
        raise ValueError(f"like: {like!r} has no rotation class; pass (..., 4, 4) poses")
    import importlib

    try:
        mod = importlib.import_module(module)
    except ImportError as exc:
        raise ImportError(f"like: {like!r} is not installed ({exc})") from None
    cls = getattr(mod, cls_name)  # PyPose: LieTensor for both, the shape picks the group
    return cls, tensor_library_key(cls)


def to_library(T: Any, like: Any, name: str = "T") -> Any:
    """Return ``T`` as an object (or list of objects) of the class of ``like``.

    Parameters
    ----------
    T : array_like
        Homogeneous matrices in liebridge's storage: ``(..., 4, 4)`` poses for an SE(3) class,
        ``(..., 3, 3)`` rotations for an SO(3) class (``(..., 3, 3)`` SE(2), ``(..., 2, 2)`` SO(2)
        for the planar classes); validated (rotation within ``ROTATION_TOL``, bottom row exact).
        A library object is accepted too (``to_library(gtsam_pose, like=pin.SE3)``).
    like : object, type or str
        An object of the wanted class, or the class itself: one of :data:`SUPPORTED` or of the
        tensor libraries (module docstring); or a library's name (``"pypose"``, ``"lietorch"``,
        ``"theseus"``, ``"kornia"``, ``"jaxlie"``, ``"gtsam"``, ``"sophuspy"``, ``"pinocchio"``,
        ``"scipy"``, ``"spatialmath"``): its SE(3) class for ``(..., 4, 4)``, its SO(3) class for
        ``(..., 3, 3)``.
    name : str
        Argument name used in error messages.

    Returns
    -------
    object
        For one matrix, one object. For a batch: one object holding the batch for the vectorized
        classes (scipy ``Rotation``/``RigidTransform``, spatialmath, projectaria; batch axes
        flattened; the tensor libraries, batch axes kept — Theseus's flattened to ``(B, …)``),
        else a (nested) Python list of objects with the batch's shape. A tensor library's object
        is built from a torch ``T`` as it is (device, dtype, autograd graph kept; lietorch's
        quaternion is computed without a graph), from anything else in float64.

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
    like, tkey = _resolve_like(like, T)
    if tkey is not None:
        group = _pypose_like_group(like, T) if tkey[0] == "pypose" else _TENSOR_CLASSES[tkey]
        return _build_tensor(T, tkey, group, name)
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


def _read_object(obj: Any, name: str) -> Any:
    key = tensor_library_key(obj)
    return obj if key is None or isinstance(obj, type) else _tensor_matrix(obj, key, name)


for _root in {module.partition(".")[0] for module, _, _ in TENSOR_LIBRARIES.values()}:
    # every function that takes a pose reads these objects (liebridge.arrays.unwrap)
    arrays.OBJECT_READERS[_root] = _read_object
