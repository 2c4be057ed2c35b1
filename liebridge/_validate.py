"""Input validation shared by every public function.

Every check raises ``ValueError`` (or ``TypeError`` for a non-numeric input) naming the argument,
the first offending batch index and the size of the violation. Nothing is mutated: arrays are
converted with :func:`numpy.asarray` and copied only when a dtype change forces it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

#: Tolerance on ``‖RᵀR − I‖_max`` and ``|det R − 1|`` accepted for a rotation matrix.
ROTATION_TOL = 1e-6
#: Tolerance on ``| ‖q‖ − 1 |`` accepted for a unit quaternion.
QUATERNION_TOL = 1e-6


def _batch_index(mask: npt.NDArray[np.bool_]) -> tuple[int, ...]:
    """Return the first batch index where ``mask`` is true (``()`` for an unbatched input)."""
    idx = np.argwhere(mask)
    return tuple(int(i) for i in idx[0]) if idx.size else ()


def as_float_array(x: Any, name: str) -> FloatArray:
    """Convert ``x`` to a float64 array without mutating it, rejecting non-numeric input.

    Complex input is a ``TypeError`` too: numpy's cast would silently drop the imaginary part.
    """
    if np.iscomplexobj(x):
        raise TypeError(f"{name}: expected a real numeric array, got complex values")
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(
            f"{name}: expected a numeric array, got {type(x).__name__} ({exc})"
        ) from None
    return arr


def check_finite(arr: FloatArray, name: str, core_ndim: int | None = None) -> None:
    """Raise if ``arr`` holds NaN or Inf, naming the first offending index.

    With ``core_ndim`` (the number of trailing non-batch axes: 1 for vectors, 2 for matrices) the
    message splits the index into the batch index and the entry inside the element.
    """
    if not np.isfinite(arr).all():
        idx = _batch_index(~np.isfinite(arr))
        if core_ndim is None:
            raise ValueError(f"{name}: contains NaN or Inf at index {idx}")
        split = len(idx) - core_ndim
        raise ValueError(
            f"{name}: contains NaN or Inf at batch index {idx[:split]}, entry {idx[split:]}"
        )


def vector(x: Any, name: str, dim: int) -> FloatArray:
    """Validate a batch of ``dim``-vectors, shape ``(..., dim)``."""
    arr = as_float_array(x, name)
    if arr.ndim < 1 or arr.shape[-1] != dim:
        raise ValueError(f"{name}: expected shape (..., {dim}), got {arr.shape}")
    check_finite(arr, name, core_ndim=1)
    return arr


def square(x: Any, name: str, dim: int) -> FloatArray:
    """Validate a batch of ``dim × dim`` matrices, shape ``(..., dim, dim)``."""
    arr = as_float_array(x, name)
    if arr.ndim < 2 or arr.shape[-2:] != (dim, dim):
        raise ValueError(f"{name}: expected shape (..., {dim}, {dim}), got {arr.shape}")
    check_finite(arr, name, core_ndim=2)
    return arr


def check_rotation(R: FloatArray, name: str, tol: float = ROTATION_TOL) -> None:
    """Raise unless every ``R[...]`` is orthonormal with det +1 within ``tol``."""
    err = np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max(axis=(-1, -2))
    if (err > tol).any():
        i = _batch_index(np.asarray(err > tol))
        raise ValueError(
            f"{name}: not a rotation at batch index {i}: max|RᵀR − I| = {float(err[i]):.3g} "
            f"> tolerance {tol:g} (use liebridge.lie.so3.project to project explicitly)"
        )
    det = np.linalg.det(R)
    if (det < 0).any():
        i = _batch_index(np.asarray(det < 0))
        raise ValueError(
            f"{name}: det(R) = {float(det[i]):.3g} < 0 at batch index {i} (a reflection)"
        )


def rotation(x: Any, name: str, tol: float = ROTATION_TOL) -> FloatArray:
    """Validate a batch of rotation matrices, shape ``(..., 3, 3)``."""
    arr = square(x, name, 3)
    check_rotation(arr, name, tol)
    return arr


def pose(x: Any, name: str, tol: float = ROTATION_TOL) -> FloatArray:
    """Validate a batch of homogeneous SE(3) matrices, shape ``(..., 4, 4)``."""
    arr = square(x, name, 4)
    check_rotation(arr[..., :3, :3], name, tol)
    bottom = np.abs(arr[..., 3, :] - np.array([0.0, 0.0, 0.0, 1.0])).max(axis=-1)
    if (bottom > 0).any():
        i = _batch_index(np.asarray(bottom > 0))
        raise ValueError(f"{name}: bottom row is not [0, 0, 0, 1] at batch index {i}")
    return arr


def quaternion(x: Any, name: str, tol: float = QUATERNION_TOL) -> FloatArray:
    """Validate a batch of unit quaternions, shape ``(..., 4)`` (the order is the caller's)."""
    arr = vector(x, name, 4)
    err = np.abs(np.linalg.norm(arr, axis=-1) - 1.0)
    if (err > tol).any():
        i = _batch_index(np.asarray(err > tol))
        raise ValueError(
            f"{name}: quaternion norm off by {float(err[i]):.3g} at batch index {i} "
            f"(tolerance {tol:g}); normalise it explicitly if that is intended"
        )
    return arr


def covariance(x: Any, name: str, dim: int, tol: float = 1e-9) -> FloatArray:
    """Validate a batch of symmetric positive semi-definite matrices, shape ``(..., dim, dim)``."""
    arr = square(x, name, dim)
    scale = np.maximum(np.abs(arr).max(axis=(-1, -2)), 1e-300)
    asym = np.abs(arr - np.swapaxes(arr, -1, -2)).max(axis=(-1, -2)) / scale
    if (asym > tol).any():
        i = _batch_index(np.asarray(asym > tol))
        raise ValueError(
            f"{name}: not symmetric at batch index {i}: relative asymmetry {float(asym[i]):.3g}"
        )
    sym = 0.5 * (arr + np.swapaxes(arr, -1, -2))
    lam = np.linalg.eigvalsh(sym)[..., 0]
    if (lam < -tol * scale).any():
        i = _batch_index(np.asarray(lam < -tol * scale))
        raise ValueError(
            f"{name}: not positive semi-definite at batch index {i}: "
            f"smallest eigenvalue {float(lam[i]):.3g}"
        )
    return arr
