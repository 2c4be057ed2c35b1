"""Input validation shared by every public function.

Every check raises ``ValueError`` (or ``TypeError`` for a non-numeric input) naming the argument,
the first offending batch index and the size of the violation. Nothing is mutated: arrays are
converted with :func:`numpy.asarray` and copied only when a dtype change forces it.

Tolerances (module constants, each check takes its own ``tol`` too):

* rotation: ``max|RᵀR − I| ≤`` :data:`ROTATION_TOL` and ``det R > 0`` (project explicitly with
  :func:`liebridge.lie.so3.project` otherwise; nothing projects silently);
* pose: its rotation block as above, its bottom row exactly ``[0, 0, 0, 1]``;
* unit quaternion: ``| ‖q‖ − 1 | ≤`` :data:`QUATERNION_TOL`;
* tangent: the norm of its rotation part at most :data:`MAX_ANGLE` (1e12 rad);
* covariance / information: relative asymmetry ``max|A − Aᵀ| / max|A| ≤`` :data:`COVARIANCE_TOL`
  and smallest eigenvalue ``≥ −COVARIANCE_TOL · max|A|`` (positive semi-definite up to rounding);
* a factor's covariance (:func:`positive_definite`): as above, and ``λ_min > SINGULAR_RTOL · dim ·
  λ_max`` and ``λ_min ≥ SINGULAR_ATOL`` (1e-200) — a singular one is a hard constraint, which a
  Gaussian noise model cannot hold;
* a GTSAM key (:func:`key`): an integer in ``[0, MAX_KEY]`` (uint64; ``2**64 − 1`` is reserved).

Speed: the checks run first as a cheap *certificate* that can only accept valid input (one pose or
rotation: float arithmetic on its entries; a covariance: exact symmetry and a Cholesky
factorisation); when it does not accept, the exact check decides and, if it fails, explains. So a
single pose costs about a microsecond to validate, a batch a few vectorized passes, and the error
messages and tolerances are those of the exact check.

Other libraries' objects: wherever an array is read, a pose or rotation object of GTSAM, Sophus
(``sophuspy``, ``projectaria_tools.core.sophus``), Pinocchio, spatialmath or scipy (a list or tuple
of them too) is read as its homogeneous matrix (:data:`LIBRARY_OBJECTS`), recognised by the module
of its class, so none of these libraries is imported unless the object is already one of theirs.
``liebridge.interop.to_library`` converts results back.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from . import arrays

FloatArray = npt.NDArray[np.float64]

#: Tolerance on ``‖RᵀR − I‖_max`` accepted for a rotation matrix.
ROTATION_TOL = 1e-6
#: Tolerance on ``| ‖q‖ − 1 |`` accepted for a unit quaternion.
QUATERNION_TOL = 1e-6
#: Relative tolerance on the asymmetry and the negative eigenvalues of a covariance.
COVARIANCE_TOL = 1e-9
#: A covariance with ``λ_min ≤ SINGULAR_RTOL · dim · λ_max`` is singular for a factor's noise model.
SINGULAR_RTOL = float(np.finfo(np.float64).eps)
#: A factor's covariance needs ``λ_min ≥ SINGULAR_ATOL`` too (absolute): below it the information
#: ``Σ⁻¹`` (≥ 1e200) leaves no room for a squared residual in float64, and a subnormal ``λ_min``
#: (a covariance of 1e-310) passes every relative test while GTSAM inverts it to Inf.
SINGULAR_ATOL = 1e-200
#: GTSAM keys are unsigned 64-bit integers; this is the largest one liebridge accepts (the
#: largest, ``2**64 − 1``, is reserved by :mod:`liebridge.gtsam.custom`).
MAX_KEY = 2**64 - 2
#: Largest norm of the rotation part of a tangent (rotation vector, increment), in radians.
MAX_ANGLE = 1e12
_MAX_COMPONENT = MAX_ANGLE / math.sqrt(3.0)  # every component below it: the norm is too

_F64 = np.dtype(np.float64)
#: dtype kinds that are not numbers (bytes, str, void, datetime, timedelta).
_NON_NUMERIC = frozenset("SUVMm")
_E4 = np.array([0.0, 0.0, 0.0, 1.0])


def batch_index(mask: npt.NDArray[np.bool_]) -> tuple[int, ...]:
    """Return the first batch index where ``mask`` is true (``()`` for an unbatched input)."""
    idx = np.argwhere(mask)
    return tuple(int(i) for i in idx[0]) if idx.size else ()


# ----------------------------------------------------------------------------- library objects
#: Pose and rotation classes of other libraries that every array argument accepts, as
#: ``(top-level module of the class, class name) → (accessor, "matrix" | "method" | "attribute")``.
#: The accessor returns the homogeneous matrix (``(4, 4)`` SE(3), ``(3, 3)`` SO(3) or SE(2),
#: ``(2, 2)`` SO(2)), or a batch of them for the vectorized classes (scipy, spatialmath,
#: projectaria). Sources: GTSAM 4.3 ``Pose3.matrix()``/``Rot3.matrix()``; sophuspy 1.2
#: ``SE3.matrix()``; projectaria_tools 2.x ``SE3.to_matrix()``; Pinocchio 4 ``SE3.homogeneous``;
#: spatialmath-python 1.1 ``SE3.A`` (a list for several values); scipy ≥ 1.16
#: ``Rotation.as_matrix()``, ``RigidTransform.as_matrix()``.
LIBRARY_OBJECTS: dict[tuple[str, str], tuple[str, str]] = {
    ("gtsam", "Pose3"): ("matrix", "method"),
    ("gtsam", "Rot3"): ("matrix", "method"),
    ("gtsam", "Pose2"): ("matrix", "method"),
    ("gtsam", "Rot2"): ("matrix", "method"),
    ("sophuspy", "SE3"): ("matrix", "method"),
    ("sophuspy", "SO3"): ("matrix", "method"),
    # projectaria_tools.core.sophus: its classes live in the compiled module _core_pybinds.sophus
    ("_core_pybinds", "SE3"): ("to_matrix", "method"),
    ("_core_pybinds", "SO3"): ("to_matrix", "method"),
    ("pinocchio", "SE3"): ("homogeneous", "attribute"),
    ("spatialmath", "SE3"): ("A", "attribute"),
    ("spatialmath", "SO3"): ("A", "attribute"),
    ("spatialmath", "SE2"): ("A", "attribute"),
    ("spatialmath", "SO2"): ("A", "attribute"),
    ("scipy", "Rotation"): ("as_matrix", "method"),
    ("scipy", "RigidTransform"): ("as_matrix", "method"),
}
_LIBRARY_ROOTS = frozenset(root for root, _ in LIBRARY_OBJECTS)
_ACCEPTED = (
    "a numeric array, or a pose/rotation of GTSAM (Pose3, Rot3, Pose2, Rot2), Sophus "
    "(sophuspy, projectaria_tools: SE3, SO3), Pinocchio (SE3), spatialmath (SE3, SO3, SE2, SO2) "
    "or scipy (Rotation, RigidTransform)"
)


def library_key(obj: Any) -> tuple[str, str] | None:
    """Return ``(module root, class name)`` of a known library's object or class, else ``None``.

    Only ``__module__`` strings are read: nothing is imported. For an object, any class of a known
    library's module counts (so that an unsupported class of GTSAM, say, gets an error naming it);
    for a class, only the supported ones (:data:`LIBRARY_OBJECTS`). ``None`` for anything else
    (numbers, lists, arrays, objects of other libraries). :func:`liebridge.interop.library_key`
    is this function.
    """
    if isinstance(obj, type):
        key = (obj.__module__.partition(".")[0], obj.__name__)
        return key if key in LIBRARY_OBJECTS else None
    cls = type(obj)
    root = cls.__module__.partition(".")[0]
    return (root, cls.__name__) if root in _LIBRARY_ROOTS else None


def _library_matrix(x: Any, key: tuple[str, str], name: str) -> Any:
    """Return the homogeneous matrix (or batch) of a known library's pose or rotation object."""
    how = LIBRARY_OBJECTS.get(key)
    if how is None:
        raise TypeError(
            f"{name}: {key[0]}.{key[1]} is not a pose or rotation liebridge reads; expected "
            f"{_ACCEPTED}"
        )
    attr, kind = how
    value = getattr(x, attr)
    return value() if kind == "method" else value


def _object_key(x: Any) -> tuple[str, str] | None:
    """:func:`library_key` of an object (a class is not a pose: None)."""
    return None if isinstance(x, type) else library_key(x)


def _library_array(x: Any, name: str) -> Any:
    """``x`` as an array if it is (a list/tuple of) known library objects, else ``x`` itself."""
    key = _object_key(x)
    if key is not None:
        return _library_matrix(x, key, name)
    if type(x) in (list, tuple) and x:
        key = _object_key(x[0])
        if key is not None:
            mats = []
            for k, item in enumerate(x):
                if _object_key(item) != key:
                    raise TypeError(
                        f"{name}: item {k} is a {type(item).__name__}, item 0 a "
                        f"{key[0]}.{key[1]}: a sequence of poses holds one type"
                    )
                mats.append(_library_matrix(item, key, f"{name}[{k}]"))
            return np.stack(mats)
    return x


def as_float_array(x: Any, name: str) -> FloatArray:
    """Convert ``x`` to a float64 array without mutating it, rejecting non-numeric input.

    A float64 ndarray is returned as it is (no copy). Complex input is a ``TypeError`` too:
    numpy's cast would silently drop the imaginary part; so are strings, bytes and datetimes.
    A pose or rotation object of a known library (:data:`LIBRARY_OBJECTS`), or a list of them,
    becomes its homogeneous matrix (a batch for a list or a vectorized object).
    """
    x = arrays.unwrap(x, name)
    if arrays.is_foreign(x):
        return _foreign_to_numpy(x, name)
    if type(x) is np.ndarray and x.dtype is _F64:
        return x
    if x is None:  # numpy would make it NaN
        raise TypeError(f"{name}: expected a numeric array, got None")
    x = _library_array(x, name)
    try:
        arr = np.asarray(x)
    except (TypeError, ValueError) as exc:
        raise TypeError(
            f"{name}: expected a numeric array, got {type(x).__name__} ({exc})"
        ) from None
    kind = arr.dtype.kind
    if kind == "c":
        raise TypeError(f"{name}: expected a real numeric array, got complex values")
    if kind in _NON_NUMERIC:
        raise TypeError(f"{name}: expected a numeric array, got dtype {arr.dtype}")
    if kind == "O" and arr.ndim == 0:  # one object numpy cannot read: say what would be read
        cls = type(x)
        raise TypeError(f"{name}: expected {_ACCEPTED}; got {cls.__module__}.{cls.__qualname__}")
    try:
        return np.asarray(arr, dtype=np.float64)
    except OverflowError as exc:
        raise ValueError(f"{name}: a value does not fit in float64 ({exc})") from None
    except (TypeError, ValueError) as exc:
        raise TypeError(
            f"{name}: expected a numeric array, got {type(x).__name__} ({exc})"
        ) from None


def option(value: Any, name: str, choices: tuple[str, ...]) -> str:
    """Return the string option ``value`` stripped and in lower case if it is one of ``choices``.

    Every string option of liebridge (``method=``, ``information=``, ``order=``, ``layout=``,
    preset names) is read this way: ``"GTSAM"``, ``" gtsam "`` and ``"gtsam"`` are the same value.
    """
    if isinstance(value, str):
        key = value.strip().lower()
        if key in choices:
            return key
    allowed = " or ".join(repr(c) for c in choices)
    if len(choices) > 2:
        allowed = "one of " + ", ".join(repr(c) for c in choices)
    raise ValueError(f"{name}: expected {allowed}, got {value!r}")


def check_finite(arr: FloatArray, name: str, core_ndim: int | None = None) -> None:
    """Raise if ``arr`` holds NaN or Inf, naming the first offending index.

    With ``core_ndim`` (the number of trailing non-batch axes: 1 for vectors, 2 for matrices) the
    message splits the index into the batch index and the entry inside the element.
    """
    if arrays.is_foreign(arr):
        return _foreign_check_finite(arr, name, core_ndim)
    if not np.isfinite(arr).all():
        idx = batch_index(~np.isfinite(arr))
        if core_ndim is None:
            raise ValueError(f"{name}: contains NaN or Inf at index {idx}")
        split = len(idx) - core_ndim
        raise ValueError(
            f"{name}: contains NaN or Inf at batch index {idx[:split]}, entry {idx[split:]}"
        )


def vector(x: Any, name: str, dim: int) -> FloatArray:
    """Validate a batch of ``dim``-vectors, shape ``(..., dim)``."""
    if arrays.is_foreign(x):
        return _foreign_vector(x, name, dim)
    arr = as_float_array(x, name)
    if arr.ndim < 1 or arr.shape[-1] != dim:
        raise ValueError(f"{name}: expected shape (..., {dim}), got {arr.shape}")
    check_finite(arr, name, core_ndim=1)
    return arr


def tangent(x: Any, name: str, dim: int, rot: slice = slice(0, 3)) -> FloatArray:
    """Validate a batch of tangents ``(..., dim)`` whose entries ``rot`` are rotation coordinates.

    On top of :func:`vector`: the rotation part's norm must not exceed :data:`MAX_ANGLE` (beyond,
    float64 cannot place the angle — its spacing there is 1e-4 rad — and the series and closed
    forms of the kernel would overflow).
    """
    if arrays.is_foreign(x):
        return _foreign_tangent(x, name, dim, rot)
    arr = vector(x, name, dim)
    r = arr if dim == 3 else arr[..., rot]
    if not (np.abs(r) <= _MAX_COMPONENT).all():
        m = np.maximum(np.abs(r).max(axis=-1), 1e-300)
        norm = m * np.sqrt(np.einsum("...i,...i->...", r / m[..., None], r / m[..., None]))
        bad = ~(norm <= MAX_ANGLE)
        if bad.any():
            i = batch_index(np.asarray(bad))
            raise ValueError(
                f"{name}: rotation part of norm {float(norm[i]):.3g} at batch index {i} exceeds "
                f"{MAX_ANGLE:g} rad (float64 cannot represent such an angle to 1e-4 rad)"
            )
    return arr


def _check_square_shape(arr: FloatArray, name: str, dim: int) -> None:
    if arr.ndim < 2 or arr.shape[-2:] != (dim, dim):
        raise ValueError(f"{name}: expected shape (..., {dim}, {dim}), got {arr.shape}")


def square(x: Any, name: str, dim: int) -> FloatArray:
    """Validate a batch of ``dim × dim`` matrices, shape ``(..., dim, dim)``."""
    if arrays.is_foreign(x):
        return _foreign_square(x, name, dim)
    arr = as_float_array(x, name)
    _check_square_shape(arr, name, dim)
    check_finite(arr, name, core_ndim=2)
    return arr


def batch_shape(*named: tuple[str, tuple[int, ...]]) -> tuple[int, ...]:
    """Broadcast the batch shapes of several arguments; raise naming them if they do not."""
    first = named[0][1]
    if all(shape == first for _, shape in named):
        return first
    try:
        return tuple(np.broadcast_shapes(*(shape for _, shape in named)))
    except ValueError:
        desc = ", ".join(f"{name} {shape}" for name, shape in named)
        raise ValueError(f"batch shapes do not broadcast: {desc}") from None


def finite_output(out: FloatArray, name: str) -> FloatArray:
    """Return ``out`` if it is finite; raise rather than return Inf/NaN from finite input.

    Finite input can still overflow float64 inside a computation (a rotation vector of norm
    1e200, translations near 1e308); the result is then reported, with its first batch index,
    instead of being returned. A small result is summed in Python floats (a non-finite sum means
    a non-finite entry or a sum beyond float64; numpy's sum would warn about the latter).
    """
    if arrays.is_foreign(out):
        return _foreign_finite_output(out, name)
    if out.size <= 64 and math.isfinite(sum(out.ravel().tolist())):
        return out
    if np.isfinite(out).all():
        return out
    idx = batch_index(~np.isfinite(out))
    raise ValueError(
        f"{name}: the result overflows float64 (entry {idx} is not finite): the input magnitudes "
        "are too large for this computation"
    )


# ----------------------------------------------------------------------------- rotations, poses
def _rotation_certified(
    r00: float,
    r01: float,
    r02: float,
    r10: float,
    r11: float,
    r12: float,
    r20: float,
    r21: float,
    r22: float,
    tol: float,
) -> bool:
    """Sufficient test that one rotation is valid: ``‖RᵀR − I‖_F ≤ tol`` and ``det R > 0``.

    The Frobenius norm bounds the maximum entry, so this never accepts what
    :func:`check_rotation` rejects; NaN and Inf make the sum non-finite and fail the comparison.
    """
    e0 = r00 * r00 + r10 * r10 + r20 * r20 - 1.0
    e1 = r01 * r01 + r11 * r11 + r21 * r21 - 1.0
    e2 = r02 * r02 + r12 * r12 + r22 * r22 - 1.0
    e3 = r00 * r01 + r10 * r11 + r20 * r21
    e4 = r00 * r02 + r10 * r12 + r20 * r22
    e5 = r01 * r02 + r11 * r12 + r21 * r22
    if not e0 * e0 + e1 * e1 + e2 * e2 + 2.0 * (e3 * e3 + e4 * e4 + e5 * e5) <= tol * tol:
        return False
    det = (
        r00 * (r11 * r22 - r12 * r21)
        - r01 * (r10 * r22 - r12 * r20)
        + r02 * (r10 * r21 - r11 * r20)
    )
    return det > 0.0


def _rotation_list_certified(a: list[float], tol: float) -> bool:
    """:func:`_rotation_certified` of one rotation given as its 9 entries, row-major."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = a
    return _rotation_certified(r00, r01, r02, r10, r11, r12, r20, r21, r22, tol)


def _rotation_residuals(R: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``max|RᵀR − I|`` and ``det R`` of every ``R[...]``, on the nine entries as batch vectors.

    One transposing copy puts each entry in a contiguous vector (numpy is slow on length-3 rows),
    then the six distinct entries of ``RᵀR − I`` and the triple product ``r0 · (r1 × r2)``.
    """
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = np.ascontiguousarray(
        np.moveaxis(R, (-2, -1), (0, 1))
    ).reshape(9, -1)
    err = np.abs(r00 * r00 + r10 * r10 + r20 * r20 - 1.0)
    for e in (
        r01 * r01 + r11 * r11 + r21 * r21 - 1.0,
        r02 * r02 + r12 * r12 + r22 * r22 - 1.0,
        r00 * r01 + r10 * r11 + r20 * r21,
        r00 * r02 + r10 * r12 + r20 * r22,
        r01 * r02 + r11 * r12 + r21 * r22,
    ):
        np.maximum(err, np.abs(e), out=err)  # NaN propagates
    det = (
        r00 * (r11 * r22 - r12 * r21)
        - r01 * (r10 * r22 - r12 * r20)
        + r02 * (r10 * r21 - r11 * r20)
    )
    return err.reshape(R.shape[:-2]), det.reshape(R.shape[:-2])


def check_rotation(R: FloatArray, name: str, tol: float = ROTATION_TOL) -> None:
    """Raise unless every ``R[...]`` is orthonormal within ``tol`` and has ``det R > 0``.

    ``R`` is a float64 array of shape ``(..., 3, 3)``.
    """
    if R.size == 9 and _rotation_list_certified(R.ravel().tolist(), tol):
        return
    err, det = _rotation_residuals(R)
    _raise_unless_rotations(err, det, tol, name, None)


def checked_rotation(arr: FloatArray, name: str, tol: float = ROTATION_TOL) -> FloatArray:
    """Validate a float64 array as rotations ``(..., 3, 3)``; return it (see :func:`rotation`)."""
    if arrays.is_foreign(arr):
        return _foreign_rotation(arr, name, tol)
    if (
        arr.size == 9
        and arr.shape[-2:] == (3, 3)
        and _rotation_list_certified(arr.ravel().tolist(), tol)
    ):
        return arr
    _check_square_shape(arr, name, 3)
    check_finite(arr, name, core_ndim=2)
    check_rotation(arr, name, tol)
    return arr


def rotation(x: Any, name: str, tol: float = ROTATION_TOL) -> FloatArray:
    """Validate a batch of rotation matrices, shape ``(..., 3, 3)``."""
    x = arrays.unwrap(x, name)
    if arrays.is_foreign(x):
        return _foreign_rotation(x, name, tol)
    return checked_rotation(as_float_array(x, name), name, tol)


def _pose_certified(a: list[float], tol: float) -> bool:
    """Sufficient test that one pose (16 entries, row-major) is valid; see _rotation_certified."""
    r00, r01, r02, t0, r10, r11, r12, t1, r20, r21, r22, t2, b0, b1, b2, b3 = a
    if b0 != 0.0 or b1 != 0.0 or b2 != 0.0 or b3 != 1.0 or not math.isfinite(t0 + t1 + t2):
        return False
    return _rotation_certified(r00, r01, r02, r10, r11, r12, r20, r21, r22, tol)


def checked_pose(arr: FloatArray, name: str, tol: float = ROTATION_TOL) -> FloatArray:
    """Validate a float64 array as poses ``(..., 4, 4)`` and return it (see :func:`pose`)."""
    if arrays.is_foreign(arr):
        return _foreign_pose(arr, name, tol)
    if arr.size == 16 and arr.shape[-2:] == (4, 4) and _pose_certified(arr.ravel().tolist(), tol):
        return arr
    _check_square_shape(arr, name, 4)
    check_finite(arr, name, core_ndim=2)
    check_rotation(arr[..., :3, :3], name, tol)
    bottom = arr[..., 3, :] != _E4
    if bottom.any():
        i = batch_index(np.asarray(bottom.any(axis=-1)))
        row = np.asarray(arr[..., 3, :][i]).tolist()
        raise ValueError(f"{name}: bottom row is {row}, not [0, 0, 0, 1], at batch index {i}")
    return arr


def pose(x: Any, name: str, tol: float = ROTATION_TOL) -> FloatArray:
    """Validate a batch of homogeneous SE(3) matrices, shape ``(..., 4, 4)``."""
    x = arrays.unwrap(x, name)
    if arrays.is_foreign(x):
        return _foreign_pose(x, name, tol)
    return checked_pose(as_float_array(x, name), name, tol)


def quaternion(x: Any, name: str, tol: float = QUATERNION_TOL) -> FloatArray:
    """Validate a batch of unit quaternions, shape ``(..., 4)`` (the order is the caller's)."""
    if arrays.is_foreign(x):
        return _foreign_quaternion(x, name, tol)
    arr = vector(x, name, 4)
    err = np.abs(np.linalg.norm(arr, axis=-1) - 1.0)
    if (err > tol).any():
        i = batch_index(np.asarray(err > tol))
        raise ValueError(
            f"{name}: quaternion norm off by {float(err[i]):.3g} at batch index {i} "
            f"(tolerance {tol:g}); normalise it explicitly if that is intended"
        )
    return arr


# ----------------------------------------------------------------------------- covariances
_dpotrf: Any = None  # scipy's LAPACK Cholesky, imported at first use (scipy.linalg takes 0.4 s)


def _psd_certified(arr: FloatArray) -> bool:
    """Sufficient test: exactly symmetric, finite and positive definite (Cholesky succeeds).

    NaN and Inf either fail the symmetry test (NaN ≠ NaN), break the factorisation or reach the
    factor's diagonal, which must be finite. Positive semi-definite but singular input fails the
    test and goes to the exact (eigenvalue) check.
    """
    if arr.ndim == 2:  # one matrix: LAPACK directly (numpy's wrapper costs more than the work)
        # bitwise symmetry first (cheap); ±0 or NaN payload differences fall through to ==
        if arr.tobytes() != arr.T.tobytes() and not (arr == arr.T).all():
            return False
        global _dpotrf
        if _dpotrf is None:
            from scipy.linalg.lapack import dpotrf as _dpotrf
        c, info = _dpotrf(arr, 1, 0)  # lower, no clean-up (positional: cheaper to parse)
        return bool(info == 0 and math.isfinite(sum(c.diagonal().tolist())))
    if not (arr == arr.swapaxes(-1, -2)).all():
        return False
    try:
        L = np.linalg.cholesky(arr)
    except np.linalg.LinAlgError:
        return False
    return bool(np.isfinite(np.diagonal(L, axis1=-2, axis2=-1)).all())


def covariance(x: Any, name: str, dim: int, tol: float = COVARIANCE_TOL) -> FloatArray:
    """Validate a batch of symmetric positive semi-definite matrices, shape ``(..., dim, dim)``."""
    if arrays.is_foreign(x):
        return _foreign_covariance(x, name, dim, tol)
    arr = as_float_array(x, name)
    _check_square_shape(arr, name, dim)
    if arr.size and _psd_certified(arr):
        return arr
    check_finite(arr, name, core_ndim=2)
    scale = np.maximum(np.abs(arr).max(axis=(-1, -2)), 1e-300)
    half, half_t = 0.5 * arr, 0.5 * np.swapaxes(arr, -1, -2)  # halves first: no overflow
    asym = 2.0 * (np.abs(half - half_t).max(axis=(-1, -2)) / scale)
    if (asym > tol).any():
        i = batch_index(np.asarray(asym > tol))
        raise ValueError(
            f"{name}: not symmetric at batch index {i}: relative asymmetry {float(asym[i]):.3g}"
        )
    lam = np.linalg.eigvalsh(half + half_t)[..., 0]
    if (lam < -tol * scale).any():
        i = batch_index(np.asarray(lam < -tol * scale))
        raise ValueError(
            f"{name}: not positive semi-definite at batch index {i}: "
            f"smallest eigenvalue {float(lam[i]):.3g}"
        )
    return arr


# ----------------------------------------------------------------------------- other groups
def _orthonormal_residuals(A: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``max|AᵀA − I|`` and ``det A`` of every ``A[...]`` (any small size, e.g. 2×2)."""
    n = A.shape[-1]
    with np.errstate(over="ignore", invalid="ignore"):  # huge entries: a large residual, reported
        err = np.abs(np.einsum("...ki,...kj->...ij", A, A) - np.eye(n)).max(axis=(-1, -2))
        det = np.linalg.det(A)
    return err, det


def _check_orthonormal(A: FloatArray, name: str, tol: float, what: str) -> None:
    err, det = _orthonormal_residuals(A)
    _raise_unless_rotations(err, det, tol, name, what)


def _raise_unless_rotations(
    err: FloatArray, det: FloatArray, tol: float, name: str, what: str | None
) -> None:
    """One error for the first element that is not orthonormal, or is a reflection.

    ``what`` names a block of a larger element (``"its rotation block"``); None for a rotation
    matrix itself, whose message also points to ``so3.project``.
    """
    bad = ~(err <= tol)  # NaN counts as bad
    if bad.any():
        i = batch_index(np.asarray(bad))
        if what is None:
            raise ValueError(
                f"{name}: not a rotation at batch index {i}: max|RᵀR − I| = {float(err[i]):.3g} "
                f"> tolerance {tol:g} (use liebridge.lie.so3.project to project explicitly)"
            )
        raise ValueError(
            f"{name}: {what} is not a rotation at batch index {i}: max|RᵀR − I| = "
            f"{float(err[i]):.3g} > tolerance {tol:g}"
        )
    if (det < 0).any():
        i = batch_index(np.asarray(det < 0))
        if what is None:
            raise ValueError(
                f"{name}: det(R) = {float(det[i]):.3g} < 0 at batch index {i} (a reflection)"
            )
        raise ValueError(f"{name}: {what} has det {float(det[i]):.3g} < 0 at batch index {i}")


def _check_bottom(arr: FloatArray, name: str, rows: FloatArray, group: str, hint: str) -> None:
    """Raise unless the last ``len(rows)`` rows of every matrix are exactly ``rows``."""
    k = rows.shape[0]
    bottom = arr[..., -k:, :] != rows
    if bottom.any():
        i = batch_index(np.asarray(bottom.any(axis=(-1, -2))))
        got = np.asarray(arr[..., -k:, :][i]).tolist()
        want = rows.tolist()
        raise ValueError(
            f"{name}: not a valid {group} element at batch index {i}: last row(s) {got}, "
            f"expected exactly {want}{hint}"
        )


def rotation2(x: Any, name: str, tol: float = ROTATION_TOL) -> FloatArray:
    """Validate a batch of 2-D rotation matrices, shape ``(..., 2, 2)``."""
    if arrays.is_foreign(x):
        return _foreign_group(x, name, tol, 2, 2, rotation2)
    arr = square(x, name, 2)
    _check_orthonormal(arr, name, tol, "the 2×2 matrix")
    return arr


_SE2_BOTTOM = np.array([[0.0, 0.0, 1.0]])


def pose2(x: Any, name: str, tol: float = ROTATION_TOL) -> FloatArray:
    """Validate a batch of SE(2) matrices ``[R t; 0 0 1]``, shape ``(..., 3, 3)``.

    An SO(3) rotation (also 3×3) fails on its last row, and the message says so.
    """
    if arrays.is_foreign(x):
        return _foreign_group(x, name, tol, 3, 2, pose2)
    arr = square(x, name, 3)
    _check_bottom(
        arr,
        name,
        _SE2_BOTTOM,
        "SE(2)",
        " (an SE(2) pose is [R t; 0 0 1]; a 3×3 rotation of SO(3) is a different group)",
    )
    _check_orthonormal(arr[..., :2, :2], name, tol, "its rotation block")
    return arr


_SIM3_BOTTOM = np.array([[0.0, 0.0, 0.0, 1.0]])


def similarity(x: Any, name: str, tol: float = ROTATION_TOL) -> FloatArray:
    """Validate a batch of Sim(3) matrices ``[sR t; 0 1]`` (``s > 0``), shape ``(..., 4, 4)``.

    GTSAM's ``Similarity3.matrix()`` ``[R t; 0 1/s]`` is rejected with a hint to divide by
    ``X[3, 3]`` (liebridge's matrix is the normalised one, bottom-right entry 1).
    """
    if arrays.is_foreign(x):
        return _foreign_similarity(x, name, tol)
    arr = square(x, name, 4)
    corner = arr[..., 3, 3]
    gtsam_like = (arr[..., 3, :3] == 0).all(axis=-1) & (corner > 0) & (corner != 1.0)
    hint = ""
    if gtsam_like.any():
        hint = (
            " (this looks like GTSAM's Similarity3.matrix() [R t; 0 1/s]: divide by X[3, 3] to "
            "get [sR t'; 0 1])"
        )
    _check_bottom(arr, name, _SIM3_BOTTOM, "Sim(3)", hint)
    A = arr[..., :3, :3]
    check_finite(arr, name, core_ndim=2)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        # det(sR) = s³ under/overflows for s < 1e-103 or > 1e102: scale by a power of two first
        big = np.max(np.abs(A), axis=(-1, -2))
        m = np.ldexp(1.0, np.frexp(np.where(big > 0, big, 1.0))[1])
        det = np.linalg.det(A / m[..., None, None])
    if (det <= 0).any():
        i = batch_index(np.asarray(det <= 0))
        raise ValueError(
            f"{name}: Sim(3) scale s = cbrt(det(sR)) = {float(m[i] * np.cbrt(det[i])):.3g} ≤ 0 "
            f"at batch index {i} (the scale must be positive)"
        )
    s = m * np.cbrt(det)
    _check_orthonormal(A / s[..., None, None], name, tol, "its linear block divided by its scale")
    return arr


_SE23_BOTTOM = np.array([[0.0, 0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 0.0, 1.0]])


def extended_pose(x: Any, name: str, tol: float = ROTATION_TOL) -> FloatArray:
    """Validate a batch of SE₂(3) matrices ``[R p v; 0 1 0; 0 0 1]``, shape ``(..., 5, 5)``."""
    if arrays.is_foreign(x):
        return _foreign_group(x, name, tol, 5, 3, extended_pose)
    arr = square(x, name, 5)
    _check_bottom(arr, name, _SE23_BOTTOM, "SE₂(3)", " (GTSAM NavState.matrix() layout)")
    check_rotation(arr[..., :3, :3], name, tol)
    return arr


def positive_definite(x: Any, name: str, dim: int, tol: float = COVARIANCE_TOL) -> FloatArray:
    """Validate a batch of covariances that a noise model can invert, shape ``(..., dim, dim)``.

    As :func:`covariance`, and the smallest eigenvalue must exceed
    ``SINGULAR_RTOL · dim · λ_max`` and be at least :data:`SINGULAR_ATOL` (an absolute floor: a
    covariance of 1e-310·I is relatively perfect but its inverse overflows): a zero or singular
    covariance is a hard constraint, which
    needs a constrained noise model, not a Gaussian one (GTSAM's ``Gaussian.Covariance`` would
    give NaN errors or an information matrix with no correct digit).
    """
    arr = covariance(x, name, dim, tol)
    if arr.size == 0:
        return arr
    lam = np.linalg.eigvalsh(0.5 * arr + 0.5 * np.swapaxes(arr, -1, -2))
    lo, hi = lam[..., 0], lam[..., -1]
    bad = ~((lo > SINGULAR_RTOL * dim * hi) & (lo >= SINGULAR_ATOL))
    if bad.any():
        i = batch_index(np.asarray(bad))
        raise ValueError(
            f"{name}: singular covariance at batch index {i}: smallest eigenvalue "
            f"{float(lo[i]):.3g} (largest {float(hi[i]):.3g}; needed above "
            f"{SINGULAR_RTOL * dim:.2g} × largest and at least {SINGULAR_ATOL:g}); a hard "
            "constraint needs gtsam.noiseModel.Constrained, not a covariance"
        )
    return arr


def key(x: Any, name: str) -> int:
    """Validate a GTSAM key: an integer in ``[0, MAX_KEY]`` (keys are unsigned 64-bit)."""
    if isinstance(x, bool) or not isinstance(x, (int, np.integer)):
        raise TypeError(f"{name}: expected an integer key, got {type(x).__name__} ({x!r})")
    k = int(x)
    if not 0 <= k <= MAX_KEY:
        raise ValueError(f"{name}: key {k} is outside [0, 2**64 - 2] (GTSAM keys are uint64)")
    return k


# ----------------------------------------------------------------------------- torch and JAX arrays
# The same contract on the array-generic path (:mod:`liebridge.arrays`): a cheap check runs in the
# array's own namespace and device; only when it fails is a host copy made, and the numpy check
# above words the error (the same message, argument, batch index and size). Under tracing
# (``jax.jit``, ``torch.compile``, ``torch.func``) values are unknown: shapes are checked, values
# are not (docs/tensors.md says so).


def _foreign_float(x: Any, name: str) -> Any:
    """``x`` as a float32/float64 array of its own library (integers and booleans → float64)."""
    xp = arrays.namespace(x)
    dt = x.dtype
    if dt in (xp.float32, xp.float64):
        return x
    if xp.isdtype(dt, "complex floating"):
        raise TypeError(f"{name}: expected a real numeric array, got complex values")
    if xp.isdtype(dt, "real floating"):
        raise TypeError(
            f"{name}: dtype {dt} is not supported (float32 and float64 are): convert it first"
        )
    return xp.astype(x, xp.float64)


def _foreign_to_numpy(x: Any, name: str) -> FloatArray:
    """Copy a torch/JAX array to the host for a numpy-only function, unless a gradient is lost."""
    return as_float_array(arrays.host(x, name), name)


def _tol(arr: Any, tol: float) -> float:
    """``tol``, widened for float32 (64 ulps: a float32 rotation is orthonormal to ~1e-7)."""
    return max(tol, 64.0 * arrays.eps(arr))


def _all_finite(arr: Any) -> bool | None:
    """Certify that every entry is finite: the sum is (NaN and ±Inf propagate into it).

    One reduction instead of an element-wise test and a second reduction; a sum that overflows
    (entries near 1e308) only sends the call to the exact check, which decides.
    """
    xp = arrays.namespace(arr)
    if arr.ndim == 0 or arr.shape[-1] == 0:
        return arrays.all_true(xp.isfinite(arr))
    return arrays.all_true(xp.isfinite(xp.sum(arr)))


def _foreign_check_finite(arr: Any, name: str, core_ndim: int | None) -> None:
    if _all_finite(arr) is False:
        check_finite(arrays.to_numpy(arr), name, core_ndim)


def _foreign_vector(x: Any, name: str, dim: int) -> Any:
    arr = _foreign_float(x, name)
    if arr.ndim < 1 or arr.shape[-1] != dim:
        raise ValueError(f"{name}: expected shape (..., {dim}), got {tuple(arr.shape)}")
    _foreign_check_finite(arr, name, 1)
    return arr


def _foreign_tangent(x: Any, name: str, dim: int, rot: slice) -> Any:
    arr = _foreign_vector(x, name, dim)
    xp = arrays.namespace(arr)
    r = arr if dim == 3 else arr[..., rot]
    if arrays.all_true(xp.abs(r) <= _MAX_COMPONENT) is False:
        tangent(arrays.to_numpy(arr), name, dim, rot)
    return arr


def _foreign_square(x: Any, name: str, dim: int) -> Any:
    arr = _foreign_float(x, name)
    if arr.ndim < 2 or tuple(arr.shape[-2:]) != (dim, dim):
        raise ValueError(f"{name}: expected shape (..., {dim}, {dim}), got {tuple(arr.shape)}")
    _foreign_check_finite(arr, name, 2)
    return arr


def _foreign_finite_output(out: Any, name: str) -> Any:
    if _all_finite(out) is False:
        finite_output(arrays.to_numpy(out), name)
    return out


def _foreign_rotation_ok(R: Any, tol: float) -> bool | None:
    """Certify ``max|RᵀR − I| ≤ tol`` and ``det R > 0`` for every ``R``.

    Batched: one ``RᵀR`` product and the triple product ``(r₀ × r₁)·r₂`` of the columns (no LU),
    a few whole-array operations (an entry-by-entry form costs one operation per entry there).
    """
    xp = arrays.namespace(R)
    err = xp.max(xp.abs(arrays.mT(R) @ R - arrays.eye(3, R)), axis=(-1, -2))
    det = xp.sum(xp.linalg.cross(R[..., :, 0], R[..., :, 1]) * R[..., :, 2], axis=-1)
    return arrays.all_true((err <= tol) & (det > 0.0))


def _foreign_rotation(x: Any, name: str, tol: float) -> Any:
    arr = _foreign_square(x, name, 3)
    tol = _tol(arr, tol)
    if _foreign_rotation_ok(arr, tol) is False:
        check_rotation(arrays.to_numpy(arr).astype(np.float64), name, tol)
    return arr


def _foreign_pose(x: Any, name: str, tol: float) -> Any:
    arr = _foreign_square(x, name, 4)
    xp = arrays.namespace(arr)
    tol = _tol(arr, tol)
    bottom = arrays.all_true(xp.all(arr[..., 3, :] == arrays.like(_E4, arr), axis=-1))
    if _foreign_rotation_ok(arr[..., :3, :3], tol) is False or bottom is False:
        checked_pose(arrays.to_numpy(arr).astype(np.float64), name, tol)
    return arr


def _foreign_covariance(x: Any, name: str, dim: int, tol: float) -> Any:
    arr = _foreign_float(x, name)
    if arr.ndim < 2 or tuple(arr.shape[-2:]) != (dim, dim):
        raise ValueError(f"{name}: expected shape (..., {dim}, {dim}), got {tuple(arr.shape)}")
    xp = arrays.namespace(arr)
    tol = max(tol, 16.0 * arrays.eps(arr))
    scale = xp.max(xp.abs(arr), axis=(-1, -2))
    asym = xp.max(xp.abs(arr - arrays.mT(arr)), axis=(-1, -2))
    ok = arrays.all_true(xp.isfinite(scale) & (asym <= tol * scale))
    if ok is not False:
        lam = xp.linalg.eigvalsh(0.5 * (arr + arrays.mT(arr)))[..., 0]
        ok = arrays.all_true(lam >= -tol * scale)
    if ok is False:
        covariance(arrays.to_numpy(arr).astype(np.float64), name, dim, tol)
    return arr


def _foreign_group(x: Any, name: str, tol: float, m: int, k: int, exact: Any) -> Any:
    """Validate matrix group elements ``[[R, V], [0, I]]`` (``R``: ``k × k``) on torch/JAX.

    Certified on the device (``RᵀR ≈ I``, ``det R > 0``, the bottom rows exact); where the
    certificate fails, ``exact`` on a host copy words the error.
    """
    arr = _foreign_square(x, name, m)
    xp = arrays.namespace(arr)
    tol = _tol(arr, tol)
    R = arr[..., :k, :k]
    if k == 3:
        ok = _foreign_rotation_ok(R, tol)
    else:
        err = xp.max(xp.abs(arrays.mT(R) @ R - arrays.eye(k, R)), axis=(-1, -2))
        det = R[..., 0, 0] * R[..., 1, 1] - R[..., 0, 1] * R[..., 1, 0]
        ok = arrays.all_true((err <= tol) & (det > 0.0))
    if m > k:
        bottom = arrays.like(np.eye(m)[k:], arr)
        ok_b = arrays.all_true(xp.all(arr[..., k:, :] == bottom, axis=(-1, -2)))
        ok = False if ok_b is False else ok
    if ok is False:
        exact(arrays.to_numpy(arr).astype(np.float64), name, tol)
    return arr


def _foreign_similarity(x: Any, name: str, tol: float) -> Any:
    """Validate Sim(3) matrices ``[sR t; 0 1]`` on torch/JAX (see :func:`similarity`).

    Certified on the device: the bottom row exactly ``[0, 0, 0, 1]``, ``det(A/m) > 0`` with
    ``A = sR`` and ``m = max|A|`` (``s³`` itself would under- or overflow), and
    ``A/s`` orthonormal within ``tol`` for ``s = m·det(A/m)^(1/3)``. Where the certificate
    fails, :func:`similarity` on a host copy words the error (argument, batch index, size).
    """
    arr = _foreign_square(x, name, 4)
    xp = arrays.namespace(arr)
    tol = _tol(arr, tol)
    A = arr[..., :3, :3]
    m = xp.max(xp.abs(A), axis=(-1, -2))
    nonzero = m > 0.0
    An = A / xp.where(nonzero, m, arrays.like(1.0, m))[..., None, None]
    det = xp.sum(xp.linalg.cross(An[..., :, 0], An[..., :, 1]) * An[..., :, 2], axis=-1)
    positive = nonzero & (det > 0.0)
    R = An / (xp.where(positive, det, arrays.like(1.0, det)) ** (1.0 / 3.0))[..., None, None]
    err = xp.max(xp.abs(arrays.mT(R) @ R - arrays.eye(3, R)), axis=(-1, -2))
    bottom = xp.all(arr[..., 3, :] == arrays.like(_E4, arr), axis=-1)
    if arrays.all_true(positive & (err <= tol) & bottom) is False:
        similarity(arrays.to_numpy(arr).astype(np.float64), name, tol)
    return arr


def _foreign_quaternion(x: Any, name: str, tol: float) -> Any:
    """:func:`quaternion` on torch/JAX: ``| ‖q‖² − 1 | ≤ tol`` certified on the device.

    ``‖q‖² − 1 ≈ 2(‖q‖ − 1)``: the squared norm (no square root) within ``tol`` certifies the norm
    within ``tol/2``; where it fails the host copy decides with numpy's exact test and message.
    """
    arr = _foreign_vector(x, name, 4)
    xp = arrays.namespace(arr)
    tol = _tol(arr, tol)
    if arrays.all_true(xp.abs(xp.sum(arr * arr, axis=-1) - 1.0) <= tol) is False:
        quaternion(arrays.to_numpy(arr).astype(np.float64), name, tol)
    return arr
