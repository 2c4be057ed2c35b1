"""The unit sphere S² (directions, gravity): geodesic exp/log, the tangent bases of two libraries.

S² is not a group; its charts are the Riemannian exponential at a point ``n`` (a unit
3-vector) read in an orthonormal basis of the tangent plane ``n^⊥``. Everything here is batched
``(..., 3)`` and works on unit vectors:

* ``exp(n, w) = cos‖w‖ n + sin‖w‖ w/‖w‖`` for ``w ⟂ n`` (the point at angle ``‖w‖`` along the
  great circle leaving ``n`` in the direction ``w``), and ``log(n, m)`` its inverse,
  ``θ/sin θ (m − (n·m) n)``, ``θ = atan2(‖n × m‖, n·m)`` (``m ≠ −n``);
* ``dlog(n, m)``: the 3×3 derivative of ``log(n, ·)`` at ``m``;
* ``unit3_basis(n)``: GTSAM's ``Unit3::basis()`` (gtsam/geometry/Unit3.cpp, GTSAM 4.3: the axis
  of ``n``'s smallest absolute component ``a``, ``b1 = normalize(n × a)``, ``b2 = n × b1``;
  measured against the GTSAM 4.3 wheel in the tests). ``Unit3.retract(v) = exp(n, B v)`` and
  ``Unit3.localCoordinates(m) = Bᵀ log(n, m)``;
* ``mtk_basis(n, axis)``: MTK/IKFoM's ``S2::S2_Bx`` (IKFoM_toolkit/mtk/types/S2.hpp, as vendored
  in hku-mars/FAST_LIO ``include/IKFoM_toolkit``), the first two columns of the rotation taking
  the coordinate axis ``S2_typ`` (1 = x, 2 = y, 3 = z) to ``n``. MTK's ``boxplus(δ)`` rotates the
  stored vector by ``Exp(B δ)`` (``B δ`` is a rotation *axis*, perpendicular to ``n``), so it
  moves ``n`` along ``(B δ) × n = −[n]ₓ B δ``: MTK's chart is ``exp`` read in the basis
  ``−[n]ₓ B``. False: MTK's ``δ`` is the direction of motion (it is the axis; the motion is
  rotated by 90° from it).

Every function takes numpy, torch and JAX arrays (:mod:`liebridge.arrays`) and returns the
caller's array type, device and dtype, differentiable: on torch/JAX the branches are ``where``
selections whose discarded side sees only safe values (the Taylor series near ``θ = 0``, MTK's
fallback at ``n = −axis``), the norms are ``sqrt`` of a dot product guarded at 0 (finite
gradients at ``w = 0`` and ``m = n``), and the value checks (unit norm, ``w ⟂ n``, not
antipodal, MTK's singular direction) are one reduction on the device, a host copy being made
only to word a failed check with numpy's message (argument, batch index, size). Under tracing
(``jax.jit``, ``torch.compile``) values are unknown and only shapes are checked. numpy keeps its
own code below (the same formulas).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from .series import angle as _safe_norm

__all__ = ["dlog", "exp", "log", "mtk_basis", "unit3_basis", "unit_vector"]

#: MTK's ``tolerance<double>()`` (mtk/src/mtkmath.hpp): its basis switches branch there.
MTK_TOLERANCE = 1e-11
#: Below this angle ``θ/sin θ`` and its derivative use their Taylor series.
_SMALL = 1e-3


def unit_vector(n: Any, name: str = "n", tol: float = validate.ROTATION_TOL) -> FloatArray:
    """Validate ``(..., 3)`` unit vectors (``| ‖n‖ − 1 | ≤ tol``), naming the batch index.

    float32 arrays are held to ``max(tol, 64 ulp)``. Returns the array as given (a torch/JAX
    array stays one).
    """
    arr = validate.vector(n, name, 3)
    if arrays.is_foreign(arr):
        xp = arrays.namespace(arr)
        tol = max(tol, 64.0 * arrays.eps(arr))
        if arrays.all_true(xp.abs(_safe_norm(arr)[0] - 1.0) <= tol) is False:
            _check_unit(arrays.to_numpy(arr).astype(np.float64), name, tol)
        return arr
    _check_unit(arr, name, tol)
    return arr


def _check_unit(arr: FloatArray, name: str, tol: float) -> None:
    err = np.abs(np.linalg.norm(arr, axis=-1) - 1.0)
    bad = err > tol
    if bad.any():
        i = validate.batch_index(bad)
        raise ValueError(
            f"{name}: not a unit vector at batch index {i}: | ‖n‖ − 1 | = {float(err[i]):.3g} "
            f"(tolerance {tol:g})"
        )


def _dot(a: FloatArray, b: FloatArray) -> FloatArray:
    return np.asarray(np.einsum("...i,...i->...", a, b), dtype=np.float64)


def exp(n: Any, w: Any) -> FloatArray:
    """Geodesic exponential at ``n`` of the tangent vector ``w`` (``(..., 3)``, ``w ⟂ n``).

    ``cos‖w‖ n + sin‖w‖ w/‖w‖`` (``sin θ/θ`` by its series below 1e-3 rad); ``w`` must be
    tangent, ``|n·w| ≤ 1e-9 (1 + ‖w‖)`` (float32: 64 ulp).
    """
    if arrays.any_foreign(n, w):
        return _exp_generic(*arrays.common(n, w))
    return _exp_np(n, w)


def _exp_generic(n: Any, w: Any) -> Any:
    n = unit_vector(n)
    w = validate.vector(w, "w", 3)
    xp = arrays.namespace(n, w)
    t, t2 = _safe_norm(w)
    tol = max(1e-9, 64.0 * arrays.eps(w))
    if arrays.all_true(xp.abs(arrays.dot(n, w)) <= tol * (1.0 + t)) is False:
        _exp_np(arrays.to_numpy(n), arrays.to_numpy(w))  # words numpy's error
    small = t < _SMALL
    ts = xp.where(small, arrays.like(1.0, t), t)
    sinc = xp.where(small, 1.0 - t2 / 6.0 + t2 * t2 / 120.0, xp.sin(ts) / ts)
    return xp.cos(t)[..., None] * n + sinc[..., None] * w


def _exp_np(n: Any, w: Any) -> FloatArray:
    n = unit_vector(n)
    w = validate.vector(w, "w", 3)
    t = np.linalg.norm(w, axis=-1)
    off = np.abs(_dot(n, w))
    bad = off > 1e-9 * (1.0 + t)
    if bad.any():
        i = validate.batch_index(bad)
        raise ValueError(
            f"w: not tangent at n (w ⟂ n) at batch index {i}: |n·w| = {float(off[i]):.3g}"
        )
    small = t < _SMALL
    ts = np.where(small, 1.0, t)
    sinc = np.where(small, 1.0 - t**2 / 6.0 + t**4 / 120.0, np.sin(ts) / ts)
    return np.asarray(np.cos(t)[..., None] * n + sinc[..., None] * w, dtype=np.float64)


def _angle(n: FloatArray, m: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    c = _dot(n, m)
    s = np.linalg.norm(np.cross(n, m), axis=-1)
    return np.arctan2(s, c), c, s


def _check_not_antipodal(theta: FloatArray, name: str) -> None:
    bad = theta > np.pi - 1e-6
    if bad.any():
        i = validate.batch_index(bad)
        raise ValueError(
            f"{name}: the two directions are antipodal at batch index {i} (angle "
            f"{float(theta[i]):.9g} rad): the logarithm of S² is undefined there"
        )


def _angle_generic(n: Any, m: Any, where: str) -> tuple[Any, Any, Any]:
    """``(θ, cos θ, sin θ)`` on torch/JAX, the antipodal check certified on the device."""
    xp = arrays.namespace(n, m)
    c = arrays.dot(n, m)
    s, _ = _safe_norm(xp.linalg.cross(n, m))  # gradient 0, not NaN, at m = n
    theta = xp.atan2(s, c)
    if arrays.all_true(theta <= np.pi - 1e-6) is False:
        nn, mm = arrays.to_numpy(n), arrays.to_numpy(m)
        _check_not_antipodal(_angle(*np.broadcast_arrays(nn, mm))[0], where)
    return theta, c, s


def _theta_over_sin(theta: Any, s: Any, xp: Any) -> tuple[Any, Any, Any]:
    """``(small, sin θ guarded, θ/sin θ)``: the series below :data:`_SMALL`, ``where``-safe."""
    small = theta < _SMALL
    ss = xp.where(small, 1.0 + 0.0 * s, s)
    t2 = theta * theta
    return small, ss, xp.where(small, 1.0 + t2 / 6.0 + 7.0 * t2 * t2 / 360.0, theta / ss)


def log(n: Any, m: Any) -> FloatArray:
    """Inverse of :func:`exp`: the ``w ⟂ n``, ``‖w‖ < π``, with ``exp(n, w) = m``.

    ``θ/sin θ (m − (n·m) n)``, ``θ = atan2(‖n × m‖, n·m)``. Raises ``ValueError`` where the two
    directions are antipodal (``θ > π − 1e-6``: the logarithm is undefined), naming the batch
    index.
    """
    if arrays.any_foreign(n, m):
        n, m = arrays.common(n, m)
        n, m = unit_vector(n), unit_vector(m, "m")
        xp = arrays.namespace(n, m)
        theta, c, s = _angle_generic(n, m, "log")
        k = _theta_over_sin(theta, s, xp)[2]
        return k[..., None] * (m - c[..., None] * n)
    n, m = unit_vector(n), unit_vector(m, "m")
    theta, c, s = _angle(n, m)
    _check_not_antipodal(theta, "log")
    small = theta < _SMALL
    ss = np.where(small, 1.0, s)
    k = np.where(small, 1.0 + theta**2 / 6.0 + 7.0 * theta**4 / 360.0, theta / ss)
    return np.asarray(k[..., None] * (m - c[..., None] * n), dtype=np.float64)


def dlog(n: Any, m: Any) -> FloatArray:
    """``∂ log(n, m)/∂m`` (``(..., 3, 3)``), to be applied to tangent directions at ``m``.

    With ``c = n·m``, ``θ = acos c``, ``k = θ/sin θ``:
    ``k (I − n nᵀ) − k'(θ)/sin θ · (m − c n) nᵀ``, ``k'/sin θ = (sin θ − θ cos θ)/sin³θ``
    (series ``1/3 + 2θ²/15`` near 0).
    """
    if arrays.any_foreign(n, m):
        n, m = arrays.common(n, m)
        n, m = unit_vector(n), unit_vector(m, "m")
        xp = arrays.namespace(n, m)
        theta, c, s = _angle_generic(n, m, "dlog")
        small, ss, k = _theta_over_sin(theta, s, xp)
        kp = xp.where(small, 1.0 / 3.0 + 2.0 * theta**2 / 15.0, (s - theta * c) / ss**3)
        P = arrays.eye(3, n) - n[..., :, None] * n[..., None, :]
        r = m - c[..., None] * n
        return k[..., None, None] * P - kp[..., None, None] * r[..., :, None] * n[..., None, :]
    n, m = unit_vector(n), unit_vector(m, "m")
    theta, c, s = _angle(n, m)
    _check_not_antipodal(theta, "dlog")
    small = theta < _SMALL
    ss = np.where(small, 1.0, s)
    k = np.where(small, 1.0 + theta**2 / 6.0 + 7.0 * theta**4 / 360.0, theta / ss)
    kp = np.where(small, 1.0 / 3.0 + 2.0 * theta**2 / 15.0, (s - theta * c) / ss**3)
    P = np.eye(3) - n[..., :, None] * n[..., None, :]
    r = m - c[..., None] * n
    return np.asarray(
        k[..., None, None] * P - kp[..., None, None] * r[..., :, None] * n[..., None, :],
        dtype=np.float64,
    )


def unit3_basis(n: Any) -> FloatArray:
    """GTSAM's ``Unit3::basis()`` at unit ``n``: ``(..., 3, 2)``, columns ``(b1, b2)``.

    ``b1 = normalize(n × a)`` with ``a`` the axis of ``n``'s smallest absolute component (the
    first of equal ones), ``b2 = n × b1``. No singularity: ``‖n × a‖ ≥ √(2/3)``. The choice of
    ``a`` is piecewise constant: gradients flow through ``n`` within each piece.
    """
    n = unit_vector(n)
    if arrays.is_foreign(n):
        xp = arrays.namespace(n)
        a = xp.abs(n)
        mx, my, mz = a[..., 0], a[..., 1], a[..., 2]
        use_x = (mx <= my) & (mx <= mz)
        use_y = ~use_x & (my <= mx) & (my <= mz)
        n0, n1, n2 = n[..., 0], n[..., 1], n[..., 2]
        z = 0.0 * n0
        # n × e_x = (0, n2, −n1), n × e_y = (−n2, 0, n0), n × e_z = (n1, −n0, 0)
        B1 = xp.stack(
            [
                xp.where(use_x, z, xp.where(use_y, -n2, n1)),
                xp.where(use_x, n2, xp.where(use_y, z, -n0)),
                xp.where(use_x, -n1, xp.where(use_y, n0, z)),
            ],
            axis=-1,
        )
        b1 = B1 / xp.sqrt(arrays.dot(B1, B1))[..., None]
        b2 = xp.linalg.cross(n, b1)
        return xp.stack([b1, b2], axis=-1)
    a = np.abs(n)
    mx, my, mz = a[..., 0], a[..., 1], a[..., 2]
    axis = np.zeros(n.shape)
    use_x = (mx <= my) & (mx <= mz)
    use_y = ~use_x & (my <= mx) & (my <= mz)
    axis[..., 0] = use_x
    axis[..., 1] = use_y
    axis[..., 2] = ~use_x & ~use_y
    B1 = np.cross(n, axis)
    b1 = B1 / np.linalg.norm(B1, axis=-1, keepdims=True)
    b2 = np.cross(n, b1)
    return np.asarray(np.stack([b1, b2], axis=-1), dtype=np.float64)


def mtk_basis(n: Any, axis: int, length: float = 1.0) -> FloatArray:
    """MTK's ``S2::S2_Bx`` for ``S2_typ = axis`` (1, 2, 3) at the stored vector ``length · n``.

    ``(..., 3, 2)``. Transcribed from IKFoM_toolkit/mtk/types/S2.hpp; in unit terms, for
    ``S2_typ = 1`` (FAST-LIO's gravity, ``S2<double, 98090, 10000, 1>``) and ``n₀ + 1 > tol``:
    ``b1 = (−n₁, 1 − n₁²/(1 + n₀), −n₁n₂/(1 + n₀))``, ``b2 = (−n₂, −n₁n₂/(1 + n₀),
    1 − n₂²/(1 + n₀))``; at ``n = −axis`` MTK's fixed fallback ``b1 = (0, 0, 1)``,
    ``b2 = (0, −1, 0)`` (a valid basis only for ``S2_typ = 1``: raised for the others).
    """
    if axis not in (1, 2, 3):
        raise ValueError(f"axis: MTK's S2_typ is 1, 2 or 3, got {axis!r}")
    n = unit_vector(n)
    i = axis - 1
    j, k = [(1, 2), (0, 2), (0, 1)][i]
    ni, nj, nk = n[..., i], n[..., j], n[..., k]
    if arrays.is_foreign(n):
        return _mtk_generic(n, axis, length)
    regular = length * ni + length > MTK_TOLERANCE
    den = np.where(regular, 1.0 + ni, 1.0)
    B = np.zeros((*n.shape, 2))
    # S2_Bx: rows (j, k) are I − [n_j, n_k]ᵀ[n_j, n_k]/(1 + n_i); row i is −(n_j, n_k)
    B[..., i, 0], B[..., i, 1] = -nj, -nk
    B[..., j, 0], B[..., j, 1] = 1.0 - nj * nj / den, -nj * nk / den
    B[..., k, 0], B[..., k, 1] = -nj * nk / den, 1.0 - nk * nk / den
    fallback = np.zeros((3, 2))
    fallback[1, 1], fallback[2, 0] = -1.0, 1.0
    B = np.where(regular[..., None, None], B, fallback)
    if axis != 1 and not regular.all():
        idx = tuple(int(q) for q in np.argwhere(~regular)[0]) if regular.ndim else ()
        raise ValueError(
            f"n: at batch index {idx} the direction is −axis {axis}, where MTK's S2_Bx "
            f"(S2_typ {axis}) falls back to a basis that is not tangent to the sphere"
        )
    return np.asarray(B, dtype=np.float64)


def _mtk_generic(n: Any, axis: int, length: float) -> Any:
    """:func:`mtk_basis` on torch/JAX: the fallback selected by ``where`` (its branch safe)."""
    xp = arrays.namespace(n)
    i = axis - 1
    j, k = [(1, 2), (0, 2), (0, 1)][i]
    ni, nj, nk = n[..., i], n[..., j], n[..., k]
    regular = length * ni + length > MTK_TOLERANCE
    if axis != 1 and arrays.all_true(regular) is False:
        mtk_basis(arrays.to_numpy(n), axis, length)  # words numpy's error
    den = xp.where(regular, 1.0 + ni, arrays.like(1.0, ni))  # the fallback's side: 1, not 0
    rows: dict[int, list[Any]] = {
        i: [-nj, -nk],
        j: [1.0 - nj * nj / den, -nj * nk / den],
        k: [-nj * nk / den, 1.0 - nk * nk / den],
    }
    B = arrays.matrix([e for r in range(3) for e in rows[r]], 3, 2)
    fallback = np.zeros((3, 2))
    fallback[1, 1], fallback[2, 0] = -1.0, 1.0
    return xp.where(regular[..., None, None], B, arrays.like(fallback, n))
