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

Matrix → quaternion uses :class:`scipy.spatial.transform.Rotation` on numpy arrays (Markley's
method, robust at every angle including π); quaternion → matrix is the closed polynomial form.

Every function also takes torch tensors and JAX arrays and returns the caller's array type, dtype
and device, differentiable (no host round trip, no in-place write, no branch on values): there
:func:`from_matrix` is the same selection as scipy's (Shepperd/Markley: the largest of ``R₀₀``,
``R₁₁``, ``R₂₂``, ``tr R`` picks the formula, the first of equal ones) written with ``where``,
after a Newton step of the polar decomposition (scipy projects a non-orthogonal matrix onto
``SO(3)`` first), and :func:`slerp` is written with ``sinc`` series (finite gradients where the
two inputs are equal).
"""

from __future__ import annotations

from typing import Any, Literal, cast

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from .series import sinc

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


def _index(order: str) -> tuple[int, int, int, int]:
    """Positions of ``(w, x, y, z)`` in storage (``jpl`` is stored ``(x, y, z, w)``)."""
    return (0, 1, 2, 3) if order == "wxyz" else (3, 0, 1, 2)


def _parts(q: Any, order: str) -> tuple[Any, Any, Any, Any]:
    """``(w, x, y, z)`` of ``q`` stored in ``order``, as batch arrays (views, no copy)."""
    i = _index(order)
    return q[..., i[0]], q[..., i[1]], q[..., i[2]], q[..., i[3]]


def _pack(w: Any, x: Any, y: Any, z: Any, order: str) -> Any:
    """Return the ``(..., 4)`` array of ``(w, x, y, z)`` stored in ``order``."""
    return arrays.vector([w, x, y, z] if order == "wxyz" else [x, y, z, w])


def to_matrix(q: Any, *, order: QuatOrder) -> FloatArray:
    """Convert a unit quaternion ``(..., 4)`` in ``order`` to a rotation ``(..., 3, 3)``.

    ``R = I + 2w·hat(u) + 2·hat(u)²`` for ``q = (w, u)`` (Hamilton); ``order="jpl"`` returns
    Trawny's ``C(q̄)``, the transpose of that. The norm must be 1 within
    :data:`liebridge._validate.QUATERNION_TOL` (a non-unit quaternion is an error naming the
    batch index and the norm); normalise explicitly otherwise. Tempting and false: reading an
    ``xyzw`` array with ``order="wxyz"`` (a different rotation, no error: the top swap of
    learned-SLAM code).
    """
    order = _check_order(order)
    w, x, y, z = _parts(validate.quaternion(q, "q"), order)
    entries = [
        1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
        2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
        2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y),
    ]  # fmt: skip
    if order == "jpl":  # C(q̄) = Rᵀ: the entries transposed
        entries = [entries[3 * (k % 3) + k // 3] for k in range(9)]
    return arrays.matrix(entries, 3, 3)


def _polar(r: list[list[Any]]) -> list[list[Any]]:
    """One Newton step ``R ← (R + R⁻ᵀ)/2`` of the polar decomposition, on entries (torch/JAX).

    ``R⁻ᵀ = cof(R)/det R`` (cofactors: the rows ``r₁×r₂``, ``r₂×r₀``, ``r₀×r₁``). The step
    squares the distance to the polar factor ``U Vᵀ`` (the one scipy projects onto): from a
    matrix orthonormal within 1e-6 (what validation accepts; a symmetric error ``E`` of at most
    5e-7) to ``E²/2`` ≈ 1e-13, below the 1e-12 the quaternion is held to; an orthonormal matrix
    stays where it is, to rounding. No SVD (whose gradient is singular at equal singular values,
    i.e. at every rotation). Entry by entry (batch-length arrays), the layout backends fuse best.
    """
    (a, b, c), (d, e, f), (g, h, i) = r
    cof = [
        [e * i - f * h, f * g - d * i, d * h - e * g],
        [h * c - i * b, i * a - g * c, g * b - h * a],
        [b * f - c * e, c * d - a * f, a * e - b * d],
    ]
    inv_det = 1.0 / (a * cof[0][0] + b * cof[0][1] + c * cof[0][2])
    return [[0.5 * (r[k][j] + cof[k][j] * inv_det) for j in range(3)] for k in range(3)]


def _shepperd(r: list[list[Any]]) -> tuple[Any, Any, Any, Any]:
    """``(w, x, y, z)`` of a rotation's entries (torch/JAX), ``w ≥ 0``: scipy's selection.

    The candidate of the largest of ``R₀₀, R₁₁, R₂₂, tr R`` (the first of equal ones, as
    ``argmax``) has the largest component ``4q_i² ≥ 1``: it is normalised after the selection, so
    no discarded candidate is divided (at the identity three of them are 0) and the gradient is
    finite everywhere, at θ = 0 and θ = π included.
    """
    xp = arrays.namespace(r[0][0])
    tr = r[0][0] + r[1][1] + r[2][2]
    k0 = (r[0][0] >= r[1][1]) & (r[0][0] >= r[2][2]) & (r[0][0] >= tr)
    k1 = ~k0 & (r[1][1] >= r[2][2]) & (r[1][1] >= tr)
    k2 = ~k0 & ~k1 & (r[2][2] >= tr)
    s01, s02, s12 = r[1][0] + r[0][1], r[2][0] + r[0][2], r[2][1] + r[1][2]
    d0, d1, d2 = r[2][1] - r[1][2], r[0][2] - r[2][0], r[1][0] - r[0][1]
    cands = [  # (x, y, z, w) of each case, as scipy's _from_matrix_orthogonal
        (1 - tr + 2 * r[0][0], s01, s02, d0),
        (s01, 1 - tr + 2 * r[1][1], s12, d1),
        (s02, s12, 1 - tr + 2 * r[2][2], d2),
        (d0, d1, d2, 1 + tr),
    ]
    x, y, z, w = (
        xp.where(k0, c0, xp.where(k1, c1, xp.where(k2, c2, c3)))
        for c0, c1, c2, c3 in zip(*cands, strict=True)
    )
    n = xp.sqrt(x * x + y * y + z * z + w * w)  # ≥ 1 for the selected candidate
    n = xp.where(w < 0.0, -n, n)  # the hemisphere w ≥ 0 (w = 0: the candidate's own sign)
    return w / n, x / n, y / n, z / n


def from_matrix(R: Any, *, order: QuatOrder) -> FloatArray:
    """Rotation ``(..., 3, 3)`` → unit quaternion ``(..., 4)`` with ``w ≥ 0``, in ``order``.

    Uses scipy's ``Rotation.from_matrix`` (Markley's method), which is exact at θ = π.
    ``order="jpl"`` returns the JPL ``(x, y, z, w)`` with Trawny's ``C(q̄) = R``. At a half turn
    (``w = 0``) the sign is that of the selected formula's largest component (positive), as
    scipy's. On torch/JAX arrays the same selection runs with ``where`` (differentiable, finite
    gradients at the identity and at half turns; the hemisphere flip makes ``q`` itself
    discontinuous at ``w = 0``, as every ``w ≥ 0`` choice is).
    """
    order = _check_order(order)
    R = validate.rotation(R, "R")
    if arrays.is_foreign(R):
        jpl = order == "jpl"  # C(q̄) = R: the quaternion of Rᵀ
        r = [[R[..., j, k] if jpl else R[..., k, j] for j in range(3)] for k in range(3)]
        w, x, y, z = _shepperd(_polar(r))
        return _pack(w, x, y, z, order)
    if order == "jpl":
        R = np.swapaxes(R, -1, -2)
    flat = R.reshape(-1, 3, 3)
    from scipy.spatial.transform import Rotation  # lazy: importing scipy.spatial costs ~0.8 s

    q = Rotation.from_matrix(flat).as_quat()  # xyzw
    q = canonical(q, order="xyzw").reshape((*R.shape[:-2], 4))
    return q if order != "wxyz" else np.roll(q, 1, axis=-1)


def multiply(q1: Any, q2: Any, *, order: QuatOrder) -> FloatArray:
    """Quaternion product ``q1 ⊗ q2`` of unit quaternions (broadcast).

    ``to_matrix(q1 ⊗ q2) = to_matrix(q1) @ to_matrix(q2)`` in every order: Hamilton's product for
    ``wxyz``/``xyzw``, the JPL product (Trawny eq. 8) for ``jpl``, which equals the Hamilton
    product of the same numbers in the other order, ``q2 ⊗_H q1``.
    """
    order = _check_order(order)
    if order == "jpl":
        return multiply(q2, q1, order="xyzw")
    if arrays.any_foreign(q1, q2):  # a numpy operand next to a tensor: the tensor's type
        q1, q2 = arrays.common(q1, q2)
    a = validate.quaternion(q1, "q1")
    b = validate.quaternion(q2, "q2")
    validate.batch_shape(("q1", tuple(a.shape[:-1])), ("q2", tuple(b.shape[:-1])))
    w1, x1, y1, z1 = _parts(a, order)
    w2, x2, y2, z2 = _parts(b, order)
    return _pack(
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        order,
    )


def conjugate(q: Any, *, order: QuatOrder) -> FloatArray:
    """Conjugate ``(w, −u)``: the inverse of a unit quaternion (the norm is checked)."""
    order = _check_order(order)
    q = validate.quaternion(q, "q")
    sign = [1.0, -1.0, -1.0, -1.0] if order == "wxyz" else [-1.0, -1.0, -1.0, 1.0]
    return q * (np.array(sign) if not arrays.is_foreign(q) else arrays.like(sign, q))


def canonical(q: Any, *, order: QuatOrder) -> FloatArray:
    """Choose the sign with ``w ≥ 0`` (``q`` and ``−q`` are the same unit-quaternion rotation).

    ``w = 0`` keeps its sign (a half turn has two quaternions with ``w = 0``: ``±u``).
    """
    order = _check_order(order)
    q = validate.quaternion(q, "q")
    w = q[..., _index(order)[0]]
    return arrays.namespace(q).where((w < 0)[..., None], -q, q)


def _slerp_generic(a: Any, b: Any, t: Any) -> Any:
    """:func:`slerp` on torch/JAX: the same arc, written for gradients.

    The angle between the 4-vectors is ``θ = 2·atan2(‖a − b‖, ‖a + b‖)`` (accurate at 0, where
    ``acos`` of the dot product is not), and the weights ``sin((1 − τ)θ)/sin θ =
    (1 − τ)·sinc((1 − τ)θ)/sinc θ`` (series in the squared arguments: exact derivatives at
    ``a = b``, no ``0/0``); ``sinc θ ≥ 2/π`` on the short arc.
    """
    xp = arrays.namespace(a, b)
    d = arrays.dot(a, b)
    b = xp.where((d < 0.0)[..., None], -b, b)
    m2 = arrays.dot(a - b, a - b)
    pos = m2 > 0.0
    m = xp.where(pos, xp.sqrt(xp.where(pos, m2, 1.0 + 0.0 * m2)), 0.0 * m2)
    half = arrays.atan2(m, xp.sqrt(arrays.dot(a + b, a + b)))
    theta = 2.0 * half
    u0, u1 = (1.0 - t) * theta, t * theta
    s = sinc(theta, 4.0 * half * half)
    w0 = (1.0 - t) * sinc(xp.abs(u0), u0 * u0) / s
    w1 = t * sinc(xp.abs(u1), u1 * u1) / s
    out = w0[..., None] * a + w1[..., None] * b
    return out / xp.sqrt(arrays.dot(out, out))[..., None]


def slerp(q0: Any, q1: Any, tau: Any, *, order: QuatOrder) -> FloatArray:
    """Spherical linear interpolation along the **short** arc.

    When ``q0·q1 < 0`` one input is negated first (otherwise the path would take the 360°-long
    way, pitfall P4 of docs/common-formula-errors.md). ``tau`` broadcasts against the batch shape.
    ``order`` names the storage of both inputs and of the result (the arc does not depend on it).
    """
    order = _check_order(order)
    if arrays.any_foreign(q0, q1, tau):
        q0, q1, tau = arrays.common(q0, q1, tau)
    a = validate.quaternion(q0, "q0")
    b = validate.quaternion(q1, "q1")
    if arrays.is_foreign(a):
        xp = arrays.namespace(a)
        t = tau if arrays.is_foreign(tau) else arrays.like(tau, a)
        t = t if t.dtype in (xp.float32, xp.float64) else xp.astype(t, a.dtype)
    else:
        t = validate.as_float_array(tau, "tau")
    validate.check_finite(t, "tau", core_ndim=0)
    validate.batch_shape(
        ("q0", tuple(a.shape[:-1])), ("q1", tuple(b.shape[:-1])), ("tau", tuple(t.shape))
    )
    if arrays.is_foreign(a):
        return validate.finite_output(_slerp_generic(a, b, t), "quaternion.slerp")
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


def hamilton_to_jpl(q: Any, *, order: HamiltonOrder) -> FloatArray:
    """Inverse of :func:`jpl_to_hamilton` (also a conjugation)."""
    validate.option(order, "order", ("wxyz", "xyzw"))
    return conjugate(q, order=order)
