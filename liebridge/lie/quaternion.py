"""Unit quaternions (Hamilton) with the storage order always explicit.

Every function takes ``order="wxyz"``, ``order="xyzw"`` or ``order="jpl"`` as a required keyword:
liebridge never guesses. ``wxyz``/``xyzw`` are **Hamilton** quaternions (``q(R1 R2) = q(R1) ⊗
q(R2)``, the convention of GTSAM, Eigen, Sophus, ROS, scipy, Ceres) stored scalar first / last.

``jpl`` is a **JPL** quaternion (Trawny & Roumeliotis, "Indirect Kalman Filter for 3D Attitude
Estimation", TR 2005-002, eq. 62; MSCKF-family VIO code such as OpenVINS,
``ov_core/src/types/JPLQuat.h``) stored ``(x, y, z, w)``, scalar last, with
``C(q̄) = (2q₄² − 1)I − 2q₄ hat(q) + 2 q qᵀ``. So ``to_matrix(q, order="jpl") ==
to_matrix(q, order="xyzw").T``: the same four numbers read as Hamilton give the **inverse**
rotation (OpenVINS's ``q_GtoI`` read as Hamilton is ``q_ItoG``). The JPL product satisfies
``C(q̄₁ ⊗ q̄₂) = C(q̄₁) C(q̄₂)`` (Trawny eq. 8-13). False: "JPL is Hamilton stored scalar last"
(that is ``xyzw``; the difference is the transpose, not the storage). :func:`jpl_to_hamilton` /
:func:`hamilton_to_jpl` convert the numbers (a conjugation).

Matrix → quaternion uses :class:`scipy.spatial.transform.Rotation` (Markley's method, robust at
every angle including π); quaternion → matrix is the closed polynomial form.
"""

from __future__ import annotations

from typing import Any, Literal, cast

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray

QuatOrder = Literal["wxyz", "xyzw", "jpl"]
HamiltonOrder = Literal["wxyz", "xyzw"]

__all__ = [
    "canonical",
    "conjugate",
    "from_matrix",
    "hamilton_to_jpl",
    "jpl_to_hamilton",
    "multiply",
    "slerp",
    "to_matrix",
]


def _check_order(order: str) -> QuatOrder:
    """Return the storage order normalised like every string option (``"XYZW"`` is ``"xyzw"``)."""
    return cast(QuatOrder, validate.option(order, "order", ("wxyz", "xyzw", "jpl")))


def _to_wxyz(q: FloatArray, order: str) -> FloatArray:
    """Storage → scalar first (a JPL quaternion keeps its four numbers: ``(w, x, y, z)``)."""
    order = _check_order(order)
    return q if order == "wxyz" else np.roll(q, 1, axis=-1)


def _from_wxyz(q: FloatArray, order: str) -> FloatArray:
    return q if order == "wxyz" else np.roll(q, -1, axis=-1)


@arrays.numpy_only
def to_matrix(q: Any, *, order: QuatOrder) -> FloatArray:
    """Convert a unit quaternion ``(..., 4)`` in ``order`` to a rotation ``(..., 3, 3)``.

    ``R = I + 2w·hat(u) + 2·hat(u)²`` for ``q = (w, u)`` (Hamilton); ``order="jpl"`` returns
    Trawny's ``C(q̄)``, the transpose of that. The norm must be 1 within
    :data:`liebridge._validate.QUATERNION_TOL` (a non-unit quaternion is an error naming the
    batch index and the norm); normalise explicitly otherwise.
    """
    order = _check_order(order)
    q = _to_wxyz(validate.quaternion(q, "q"), order)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.empty((*q.shape[:-1], 3, 3))
    R[..., 0, 0] = 1 - 2 * (y * y + z * z)
    R[..., 0, 1] = 2 * (x * y - w * z)
    R[..., 0, 2] = 2 * (x * z + w * y)
    R[..., 1, 0] = 2 * (x * y + w * z)
    R[..., 1, 1] = 1 - 2 * (x * x + z * z)
    R[..., 1, 2] = 2 * (y * z - w * x)
    R[..., 2, 0] = 2 * (x * z - w * y)
    R[..., 2, 1] = 2 * (y * z + w * x)
    R[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return np.ascontiguousarray(np.swapaxes(R, -1, -2)) if order == "jpl" else R


@arrays.numpy_only
def from_matrix(R: Any, *, order: QuatOrder) -> FloatArray:
    """Rotation ``(..., 3, 3)`` → unit quaternion ``(..., 4)`` with ``w ≥ 0``, in ``order``.

    Uses scipy's ``Rotation.from_matrix`` (Markley's method), which is exact at θ = π.
    ``order="jpl"`` returns the JPL ``(x, y, z, w)`` with Trawny's ``C(q̄) = R``.
    """
    order = _check_order(order)
    R = validate.rotation(R, "R")
    if order == "jpl":
        R = np.swapaxes(R, -1, -2)
    flat = R.reshape(-1, 3, 3)
    from scipy.spatial.transform import Rotation  # lazy: importing scipy.spatial costs ~0.8 s

    q = Rotation.from_matrix(flat).as_quat()  # xyzw
    q = canonical(q, order="xyzw").reshape((*R.shape[:-2], 4))
    return _from_wxyz(np.roll(q, 1, axis=-1), order)


@arrays.numpy_only
def multiply(q1: Any, q2: Any, *, order: QuatOrder) -> FloatArray:
    """Quaternion product ``q1 ⊗ q2`` of unit quaternions (broadcast).

    ``to_matrix(q1 ⊗ q2) = to_matrix(q1) @ to_matrix(q2)`` in every order: Hamilton's product for
    ``wxyz``/``xyzw``, the JPL product (Trawny eq. 8) for ``jpl``, which equals the Hamilton
    product of the same numbers in the other order, ``q2 ⊗_H q1``.
    """
    order = _check_order(order)
    if order == "jpl":
        return multiply(q2, q1, order="xyzw")
    a = _to_wxyz(validate.quaternion(q1, "q1"), order)
    b = _to_wxyz(validate.quaternion(q2, "q2"), order)
    validate.batch_shape(("q1", a.shape[:-1]), ("q2", b.shape[:-1]))
    w1, x1, y1, z1 = np.moveaxis(a, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(b, -1, 0)
    out = np.stack(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ],
        axis=-1,
    )
    return _from_wxyz(out, order)


@arrays.numpy_only
def conjugate(q: Any, *, order: QuatOrder) -> FloatArray:
    """Conjugate ``(w, −u)``: the inverse of a unit quaternion (the norm is checked)."""
    order = _check_order(order)
    q = _to_wxyz(validate.quaternion(q, "q"), order) * np.array([1.0, -1.0, -1.0, -1.0])
    return _from_wxyz(q, order)


@arrays.numpy_only
def canonical(q: Any, *, order: QuatOrder) -> FloatArray:
    """Choose the sign with ``w ≥ 0`` (``q`` and ``−q`` are the same unit-quaternion rotation)."""
    order = _check_order(order)
    q = validate.quaternion(q, "q")
    w = q[..., 0] if order == "wxyz" else q[..., 3]
    return np.where((w < 0)[..., None], -q, q)


@arrays.numpy_only
def slerp(q0: Any, q1: Any, tau: Any, *, order: QuatOrder) -> FloatArray:
    """Spherical linear interpolation along the **short** arc.

    When ``q0·q1 < 0`` one input is negated first (otherwise the path would take the 360°-long
    way, pitfall P4 of docs/common-formula-errors.md). ``tau`` broadcasts against the batch shape.
    """
    order = _check_order(order)
    a = validate.quaternion(q0, "q0")
    b = validate.quaternion(q1, "q1")
    t = validate.as_float_array(tau, "tau")
    validate.check_finite(t, "tau", core_ndim=0)
    validate.batch_shape(("q0", a.shape[:-1]), ("q1", b.shape[:-1]), ("tau", t.shape))
    dot = np.einsum("...i,...i->...", a, b)
    b = np.where((dot < 0)[..., None], -b, b)
    dot = np.clip(np.abs(dot), -1.0, 1.0)
    theta = np.arccos(dot)
    s = np.sin(theta)
    small = s < 1e-12
    s_ = np.where(small, 1.0, s)
    w0 = (np.sin((1.0 - t) * theta) / s_)[..., None]
    w1 = (np.sin(t * theta) / s_)[..., None]
    # (nearly) equal inputs: the chord a + τ·(b − a), normalised below, exact for a = b at any τ
    # ((1 − τ)·a + τ·b cancels to 0 for a large τ)
    out = np.where(small[..., None], a + t[..., None] * (b - a), w0 * a + w1 * b)
    out = out / np.linalg.norm(out, axis=-1, keepdims=True)
    return validate.finite_output(np.asarray(out, dtype=np.float64), "quaternion.slerp")


@arrays.numpy_only
def jpl_to_hamilton(q_jpl: Any, *, order: HamiltonOrder) -> FloatArray:
    """JPL quaternion → Hamilton quaternion of the same rotation matrix, same storage order.

    Trawny & Roumeliotis (2005, eq. 62) define ``C(q̄) = (2q₄² − 1)I − 2q₄ hat(q) + 2 q qᵀ``, which
    is ``to_matrix(q)ᵀ`` for the same four numbers read as Hamilton. So the Hamilton quaternion of
    the matrix ``C(q̄)`` is the conjugate. (JPL code usually stores ``xyzw``, scalar last.)
    ``order`` is the storage of both (``wxyz`` or ``xyzw``); for numbers already read with
    ``order="jpl"`` no conversion is needed.
    """
    validate.option(order, "order", ("wxyz", "xyzw"))
    return conjugate(q_jpl, order=order)


@arrays.numpy_only
def hamilton_to_jpl(q: Any, *, order: HamiltonOrder) -> FloatArray:
    """Inverse of :func:`jpl_to_hamilton` (also a conjugation)."""
    validate.option(order, "order", ("wxyz", "xyzw"))
    return conjugate(q, order=order)
