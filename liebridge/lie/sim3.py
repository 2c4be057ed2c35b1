"""Sim(3) kernel in canonical form (GTSAM ``Similarity3``'s tangent): batched, float64.

Canonical conventions:

* an element is the ``(..., 4, 4)`` matrix ``X = [[sR, t], [0, 1]]`` with ``s > 0`` (Sophus
  ``Sim3::matrix()``, Umeyama, evo, COLMAP): ``act(X, p) = sRp + t``. **GTSAM's
  ``Similarity3(R, t_g, s).matrix()`` is ``[[R, t_g], [0, 1/s]]``**, the same map scaled by
  ``1/s``: its translation argument is ``t_g = t/s``. Divide GTSAM's matrix by its ``[3, 3]``
  entry to get liebridge's; the validation rejects the other form with that hint;
* a tangent is ``ξ = (ω, u, λ)``, shape ``(..., 7)`` (GTSAM's order; ``λ`` = log-scale);
* ``hat(ξ) = [[hat(ω) + λI, u], [0, 0]]`` and ``Exp(ξ) = expm(hat ξ) = [[e^λ Exp(ω), W u], [0, 1]]``
  with ``W = ∫₀¹ e^{λτ} Exp(τω) dτ`` (:func:`liebridge.lie.series.sim3_coeffs`). GTSAM's
  algebra element ``[[hat ω, u], [0, −λ]]`` differs by ``λI₄``, which commutes, so
  ``Similarity3.Expmap(ξ)`` is the same similarity (measured: equal after normalising);
* ``adjoint(X) = [[R, 0, 0], [hat(t)R, sR, −t], [0, 0, 1]]``: ``X·Exp(ξ)·X⁻¹ = Exp(Ad_X ξ)``
  (GTSAM ``Similarity3.AdjointMap``, with its ``t_g`` replaced by ``t = s·t_g``);
* ``jl(ξ) = φ(ad_ξ)``, ``jr(ξ) = φ(−ad_ξ)``, ``φ(x) = (eˣ − 1)/x``; ``jl_inv``/``jr_inv`` are
  their inverses (``θ < 2π``). On every array type ``φ`` is closed form (one code path for
  numpy, torch and JAX), from the block structure of
  ``ad_ξ = [[hat ω, 0, 0], [hat u, hat ω + λI, −u], [0, 0, 0]]``:
  ``jl(ξ) = [[Jl(ω), 0, 0], [L, W, −φ₂(M) u], [0, 0, 1]]`` with ``M = hat ω + λI``,
  ``φ₂(x) = (eˣ − 1 − x)/x²`` and ``L`` linear in ``u`` (``_jl_parts`` derives it; quadrature
  below ``|λ + iθ| = 2``). No matrix exponential, no squarings: a fixed expression under tracing,
  with derivatives exact at ω = 0 and λ = 0. It agrees with 40-digit ``φ(ad_ξ)`` to 1e-14
  relative (scipy's ``expm`` of ``[[ad_ξ, I], [0, 0]]``, used before, to 2e-12 at λ = 30 with a
  30 m translation); the inverses are block inverses (SO(3)'s closed ``Jl⁻¹``, ``W⁻¹`` by
  ``linalg.inv``; the dense 7×7 inverse used before lost all accuracy for ``|λ| ≳ 45``).

The log is exact at θ = π (the rotation's log is :func:`liebridge.lie.so3.log`);
``s = cbrt(det(sR))`` (on numpy through a power-of-two scaling, on torch/JAX as
``m·det(A/m)^(1/3)`` with ``m`` the largest entry: ``s³`` would under- or overflow),
``λ = log s``, ``u = W⁻¹ t`` (``linalg.solve``).

Every function takes numpy, torch and JAX arrays and returns the caller's array type, device and
dtype, differentiable (``docs/tensors.md``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from . import _matrix_group as _mg
from . import se3, so3
from .record import Group, Kernels, register_shipped
from .series import _GL_T, _GL_WT, angle, one_minus_cos_over_t2, sim3_coeffs, sinc

__all__ = [
    "act",
    "adjoint",
    "compose",
    "exp",
    "hat",
    "interpolate",
    "inverse",
    "jl",
    "jl_inv",
    "jr",
    "jr_inv",
    "log",
    "vee",
]

#: Tangent dimension and matrix size.
DIM, MATRIX = 7, 4


def _mv(A: FloatArray, x: FloatArray) -> FloatArray:
    return np.einsum("...ij,...j->...i", A, x)


def _w_matrix(w: FloatArray, lam: FloatArray) -> FloatArray:
    a, b, c = sim3_coeffs(np.linalg.norm(w, axis=-1), lam)
    return so3._poly(w, b / a, c / a) * a[..., None, None]


def _assemble(A: FloatArray, t: FloatArray) -> FloatArray:
    X = np.zeros((*np.broadcast_shapes(A.shape[:-2], t.shape[:-1]), 4, 4))
    X[..., :3, :3] = A
    X[..., :3, 3] = t
    X[..., 3, 3] = 1.0
    return X


def _exp(xi: FloatArray) -> FloatArray:
    if arrays.is_foreign(xi):
        return _exp_foreign(xi)
    w, u, lam = xi[..., :3], xi[..., 3:6], xi[..., 6]
    W = _w_matrix(w, lam)
    return _assemble(np.exp(lam)[..., None, None] * so3._exp(w), _mv(W, u))


def _scale(X: FloatArray) -> FloatArray:
    # det(sR) = s³ under- or overflows for s below ≈ 1e-103 or above ≈ 1e102: take it of the
    # block divided by a power of two m ≥ its largest entry (exact), then s = m·cbrt(det(A/m))
    if arrays.is_foreign(X):
        return _scale_foreign(X)
    A = X[..., :3, :3]
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        big = np.max(np.abs(A), axis=(-1, -2))
        m = np.ldexp(1.0, np.frexp(np.where(np.isfinite(big) & (big > 0), big, 1.0))[1])
        s = m * np.cbrt(np.linalg.det(A / m[..., None, None]))
    return np.asarray(s, dtype=np.float64)


def _log(X: FloatArray) -> FloatArray:
    if arrays.is_foreign(X):
        return _log_foreign(X)
    s = _scale(X)
    w = so3._log(X[..., :3, :3] / s[..., None, None])
    lam = np.log(s)
    u = np.linalg.solve(_w_matrix(w, lam), X[..., :3, 3][..., None])[..., 0]
    return np.concatenate([w, u, lam[..., None]], axis=-1)


def _inverse(X: FloatArray) -> FloatArray:
    if arrays.is_foreign(X):
        return _inverse_foreign(X)
    s = _scale(X)[..., None, None]
    Ai = np.swapaxes(X[..., :3, :3] / s, -1, -2) / s  # (sR)⁻¹ = Rᵀ/s (never s², which overflows)
    return _assemble(Ai, -_mv(Ai, X[..., :3, 3]))


def _adjoint(X: FloatArray) -> FloatArray:
    if arrays.is_foreign(X):
        return _adjoint_foreign(X)
    s = _scale(X)
    A = X[..., :3, :3]
    R = A / s[..., None, None]
    t = X[..., :3, 3]
    out = np.zeros((*X.shape[:-2], 7, 7))
    out[..., :3, :3] = R
    out[..., 3:6, :3] = so3._hat(t) @ R
    out[..., 3:6, 3:6] = A
    out[..., 3:6, 6] = -t
    out[..., 6, 6] = 1.0
    return out


def _jl(xi: FloatArray) -> FloatArray:
    return _jl_foreign(xi)


def _jr(xi: FloatArray) -> FloatArray:
    return _jl_foreign(-xi)


def _jl_inv(xi: FloatArray) -> FloatArray:
    return _jl_inv_foreign(xi)


def _jr_inv(xi: FloatArray) -> FloatArray:
    return _jl_inv_foreign(-xi)


# ----------------------------------------------------------------------------- torch and JAX
# The same maps on torch/JAX arrays, written against the array API (liebridge.arrays): no host
# copy, no in-place write, no Python branch on values (every branch evaluated and selected by
# ``where``, the discarded one on safe values). The Jacobians below are numpy's too; numpy keeps
# its own code above for the rest (the power-of-two scaling of ``_scale``): the same maps, held
# equal by the tests.

#: Maclaurin coefficients of ``φ₁(λ) = (e^λ − 1)/λ = Σ λᵏ/(k+1)!`` and
#: ``φ₂(λ) = (e^λ − 1 − λ)/λ² = Σ λᵏ/(k+2)!``, used for ``|λ| < 1`` (truncation below 1e-19).
_PHI1_SERIES = tuple(1.0 / math.factorial(k + 1) for k in range(20))
_PHI2_SERIES = tuple(1.0 / math.factorial(k + 2) for k in range(20))
#: ``|z|² = λ² + θ²`` below which the coefficients are Gauss–Legendre quadratures (as numpy's).
_SMALL_Z2 = 4.0


def _horner(x: Any, coeffs: tuple[float, ...]) -> Any:
    acc = 0.0 * x + coeffs[-1]
    for c in coeffs[-2::-1]:
        acc = acc * x + c
    return acc


def _phi_real(lam: Any) -> tuple[Any, Any]:
    """``(φ₁(λ), φ₂(λ))`` element-wise: series for ``|λ| < 1``, ``expm1`` forms above."""
    xp = arrays.namespace(lam)
    small = xp.abs(lam) < 1.0
    one = arrays.like(1.0, lam)
    safe = xp.where(small, one, lam)
    ser = xp.where(small, lam, 0.0 * one)
    em1 = xp.expm1(safe)
    p1 = xp.where(small, _horner(ser, _PHI1_SERIES), em1 / safe)
    p2 = xp.where(small, _horner(ser, _PHI2_SERIES), (em1 - safe) / (safe * safe))
    return p1, p2


def _coeffs(th: Any, t2: Any, lam: Any) -> tuple[Any, Any, Any, Any, Any, Any]:
    """``(a₁, b₁, c₁, a₂, b₂, c₂)``: ``φₖ(M) = aₖ I + bₖ hat(ω) + cₖ hat(ω)²``, ``M = hat(ω) + λI``.

    ``φ₁(M) = W = ∫₀¹ e^{τM} dτ`` (:func:`liebridge.lie.series.sim3_coeffs`, the same closed forms
    and quadrature) and ``φ₂(M) = ∫₀¹ (1 − τ) e^{τM} dτ``. With ``z = λ + iθ`` and
    ``φ₂(z) = (φ₁(z) − 1)/z``, rearranged so that nothing divides by θ:
    ``b₂ = (1 − a₁ + λ b₁ + θ² c₁)/|z|²``, ``c₂ = (a₂ + λ c₁ − b₁)/|z|²``, ``a₂ = φ₂(λ)``.
    Below ``|z| = 2`` all six are 12-point Gauss–Legendre quadratures of their integrals (entire
    integrands: exact to rounding). ``t2 = ω·ω`` carries the series, so the derivatives at ω = 0
    are exact.
    """
    xp = arrays.namespace(t2, lam)
    one = arrays.like(1.0, t2)
    zero = 0.0 * one
    small = lam * lam + t2 < _SMALL_Z2
    # closed forms, |z| ≥ 2 (the small entries see θ = λ = 1)
    thc, t2c, la = xp.where(small, one, th), xp.where(small, one, t2), xp.where(small, one, lam)
    e = xp.exp(la)
    a1, a2 = _phi_real(la)
    sc, bb = sinc(thc, t2c), one_minus_cos_over_t2(thc, t2c)
    d = la * la + t2c
    b1 = (la * e * sc - xp.expm1(la) + e * t2c * bb) / d
    c1 = (a1 + e * (la * bb - sc)) / d
    b2 = (1.0 - a1 + la * b1 + t2c * c1) / d
    c2 = (a2 + la * c1 - b1) / d
    # quadrature, |z| < 2 (the others see θ = λ = 0)
    T, WT = arrays.like(_GL_T, t2), arrays.like(_GL_WT, t2)
    thq = xp.where(small, th, zero)[..., None]
    t2q = xp.where(small, t2, zero)[..., None]
    ex = xp.exp(T * xp.where(small, lam, zero)[..., None]) * WT
    ex2 = ex * (1.0 - T)
    S = T * sinc(T * thq, T * T * t2q)
    C = T * T * one_minus_cos_over_t2(T * thq, T * T * t2q)
    quad = [ex, ex * S, ex * C, ex2, ex2 * S, ex2 * C]
    closed = (a1, b1, c1, a2, b2, c2)
    a1, b1, c1, a2, b2, c2 = (
        xp.where(small, xp.sum(q, axis=-1), c) for q, c in zip(quad, closed, strict=True)
    )
    return a1, b1, c1, a2, b2, c2


def _poly3(w: Any, a: Any, b: Any, c: Any) -> Any:
    """Return ``a I + b hat(w) + c hat(w)²`` (``hat(w)² = w wᵀ − (w·w) I``), ``(..., 3, 3)``."""
    w0, w1, w2 = w[..., 0], w[..., 1], w[..., 2]
    s0, s1, s2 = w0 * w0, w1 * w1, w2 * w2
    p01, p02, p12 = c * w0 * w1, c * w0 * w2, c * w1 * w2
    return arrays.matrix(
        [
            a - c * (s1 + s2), p01 - b * w2, p02 + b * w1,
            p01 + b * w2, a - c * (s0 + s2), p12 - b * w0,
            p02 - b * w1, p12 + b * w0, a - c * (s0 + s1),
        ],
        3,
        3,
    )  # fmt: skip


def _w_foreign(w: Any, lam: Any) -> Any:
    th, t2 = angle(w)
    a1, b1, c1, _, _, _ = _coeffs(th, t2, lam)
    return _poly3(w, a1, b1, c1)


def _exp_foreign(xi: Any) -> Any:
    xp = arrays.namespace(xi)
    w, u, lam = xi[..., :3], xi[..., 3:6], xi[..., 6]
    A = xp.exp(lam)[..., None, None] * so3._exp(w)
    return se3._assemble(A, arrays.matvec(_w_foreign(w, lam), u))


def _scale_foreign(X: Any) -> Any:
    """``s = cbrt(det(sR))`` as ``m·det(A/m)^(1/3)``, ``m = max|A|`` (no over/underflow of s³).

    ``det`` is the triple product of the columns; it is positive on a validated element. The
    result does not depend on ``m`` (so neither does its gradient, to rounding).
    """
    xp = arrays.namespace(X)
    A = X[..., :3, :3]
    m = xp.max(xp.abs(A), axis=(-1, -2))
    m = xp.where(m > 0.0, m, arrays.like(1.0, m))
    An = A / m[..., None, None]
    det = xp.sum(xp.linalg.cross(An[..., :, 0], An[..., :, 1]) * An[..., :, 2], axis=-1)
    return m * det ** (1.0 / 3.0)


def _log_foreign(X: Any) -> Any:
    xp = arrays.namespace(X)
    s = _scale_foreign(X)
    w = so3._log(X[..., :3, :3] / s[..., None, None])
    lam = xp.log(s)
    u = xp.linalg.solve(_w_foreign(w, lam), X[..., :3, 3][..., None])[..., 0]
    return xp.concat([w, u, lam[..., None]], axis=-1)


def _inverse_foreign(X: Any) -> Any:
    s = _scale_foreign(X)[..., None, None]
    Ai = arrays.mT(X[..., :3, :3] / s) / s  # (sR)⁻¹ = Rᵀ/s
    return se3._assemble(Ai, -arrays.matvec(Ai, X[..., :3, 3]))


def _adjoint_foreign(X: Any) -> Any:
    s = _scale_foreign(X)
    A = X[..., :3, :3]
    R = A / s[..., None, None]
    t = X[..., :3, 3]
    col, row = 0.0 * t[..., None], 0.0 * t[..., None, :]
    one = 1.0 + 0.0 * s[..., None, None]
    return arrays.blocks([[R, 0.0 * R, col], [so3._hat(t) @ R, A, -t[..., None]], [row, row, one]])


def _l_quadrature(w: Any, lam: Any, u: Any) -> Any:
    """``L = ∫₀¹ e^{λσ} Exp(σω) hat(u) (1 − σ) Jl((1 − σ)ω) dσ`` by 12-point Gauss–Legendre.

    (``∫₀^x Exp(ρω) dρ = x·Jl(xω)``.) An entire integrand: exact to rounding for ``|z| < 2``.
    """
    xp = arrays.namespace(w, lam, u)
    T, WT = arrays.like(_GL_T, lam), arrays.like(_GL_WT, lam)
    E = so3._exp(T[:, None] * w[..., None, :])  # (..., 12, 3, 3)
    G = so3._jl((1.0 - T)[:, None] * w[..., None, :])
    k = xp.exp(T * lam[..., None]) * WT * (1.0 - T)
    return xp.sum(k[..., None, None] * (E @ so3._hat(u)[..., None, :, :] @ G), axis=-3)


def _jl_parts(xi: Any) -> tuple[Any, Any, Any, Any]:
    """``(J, L, W, m)`` of ``jl(ξ) = [[J, 0, 0], [L, W, m], [0, 0, 1]]`` (``m`` a 3-vector).

    ``jl(ξ) = φ₁(ad_ξ) = ∫₀¹ Ad(Exp(τξ)) dτ`` with ``ad_ξ`` block lower-triangular: ``J`` is
    SO(3)'s ``Jl(ω)``, ``W = φ₁(M)`` (``M = hat(ω) + λI``), ``m = −φ₂(M) u`` and
    ``L = ∫₀¹∫₀^τ e^{λσ} Exp(σω) hat(u) Exp((τ − σ)ω) dσ dτ``, linear in ``u``. From
    ``jl·ad_ξ = ad_ξ·jl = Ad(Exp ξ) − I``: ``L·hat(ω) = P₁ = hat(t)R − W hat(u)`` and
    ``M L = P₂ = hat(t)R − hat(u) J`` (``t = W u``), and ``L ω = φ₂(M)(u × ω)``. Hence

    * ``|z| < 2``: ``L`` by quadrature (:func:`_l_quadrature`);
    * ``|z| ≥ 2``, ``θ ≥ 1``: ``L = (−P₁ hat(ω) + φ₂(M)(u × ω) ωᵀ)/θ²``;
    * ``|z| ≥ 2``, ``θ < 1`` (so ``|λ| > √3``): ``L = M⁻¹ P₂``,
      ``M⁻¹ = I/λ − hat(ω)/|z|² + hat(ω)²/(λ|z|²)``.

    Each branch is evaluated on every entry (the others' entries replaced by safe values) and
    selected with ``where``: no division by a small number, derivatives exact at ω = 0, λ = 0.
    """
    xp = arrays.namespace(xi)
    w, u, lam = xi[..., :3], xi[..., 3:6], xi[..., 6]
    th, t2 = angle(w)
    a1, b1, c1, a2, b2, c2 = _coeffs(th, t2, lam)
    W, F = _poly3(w, a1, b1, c1), _poly3(w, a2, b2, c2)
    R, J = so3._exp(w), so3._jl(w)
    Om, Um = so3._hat(w), so3._hat(u)
    HtR = so3._hat(arrays.matvec(W, u)) @ R
    one = arrays.like(1.0, t2)
    small = lam * lam + t2 < _SMALL_Z2
    big_angle = ~small & (t2 >= 1.0)
    f = arrays.matvec(F, xp.linalg.cross(u, w))
    t2a = xp.where(big_angle, t2, one)[..., None, None]
    LA = (f[..., :, None] * w[..., None, :] - (HtR - W @ Um) @ Om) / t2a
    lb = xp.where(small | big_angle, 2.0 * one, lam)
    db = lb * lb + t2
    LB = _poly3(w, 1.0 / lb, -1.0 / db, 1.0 / (lb * db)) @ (HtR - Um @ J)
    LQ = _l_quadrature(xp.where(small[..., None], w, 0.0 * w), xp.where(small, lam, 0.0 * one), u)
    L = xp.where(small[..., None, None], LQ, xp.where(big_angle[..., None, None], LA, LB))
    return J, L, W, -arrays.matvec(F, u)


def _jl_blocks(J: Any, L: Any, W: Any, m: Any) -> Any:
    col, row = 0.0 * m[..., None], 0.0 * m[..., None, :]
    one = 1.0 + 0.0 * m[..., :1, None]
    return arrays.blocks([[J, 0.0 * J, col], [L, W, m[..., None]], [row, row, one]])


def _jl_foreign(xi: Any) -> Any:
    return _jl_blocks(*_jl_parts(xi))


def _jl_inv_foreign(xi: Any) -> Any:
    """Block inverse: ``[[Jl⁻¹, 0, 0], [−W⁻¹ L Jl⁻¹, W⁻¹, −W⁻¹ m], [0, 0, 1]]``."""
    xp = arrays.namespace(xi)
    _, L, W, m = _jl_parts(xi)
    Ji = so3._jl_inv(xi[..., :3])
    Wi = xp.linalg.inv(W)
    return _jl_blocks(Ji, -(Wi @ L @ Ji), Wi, -arrays.matvec(Wi, m))


#: The log-scale range whose scale ``e^λ`` is a normal float64: below, it rounds to a subnormal or
#: to 0 (no similarity has scale 0); above, to Inf.
LOG_SCALE_MIN, LOG_SCALE_MAX = -708.3964185322641, 709.782712893384


def _log_scale_bound(x: FloatArray, name: str) -> None:
    """Raise unless every log-scale ``λ = x[..., 6]`` keeps ``e^λ`` a normal float64.

    On torch/JAX arrays: one reduction on the device, a host copy only to word the error; not
    checked under tracing (values unknown).
    """
    if arrays.is_foreign(x):
        lam_ = x[..., 6]
        if arrays.all_true((lam_ >= LOG_SCALE_MIN) & (lam_ <= LOG_SCALE_MAX)) is not False:
            return
        x = arrays.to_numpy(x).astype(np.float64)
    lam = x[..., 6]
    bad = ~((lam >= LOG_SCALE_MIN) & (lam <= LOG_SCALE_MAX))
    if bad.any():
        i = validate.batch_index(np.asarray(bad))
        v = float(lam[i])
        what = "underflows" if v < LOG_SCALE_MIN else "overflows"
        raise ValueError(
            f"{name}: log-scale λ = {v:.6g} at batch index {i} is outside "
            f"[{LOG_SCALE_MIN:.6g}, {LOG_SCALE_MAX:.6g}]: the scale e^λ {what} float64"
            + (" (no similarity has scale 0)" if v < LOG_SCALE_MIN else "")
        )


def _tangent(xi: Any, name: str = "xi") -> FloatArray:
    x = validate.tangent(xi, name, 7, slice(0, 3))
    _log_scale_bound(x, name)
    return x


def hat(xi: Any) -> FloatArray:
    """``(ω, u, λ)`` → ``[[hat(ω) + λI, u], [0, 0]]``, ``(..., 4, 4)``."""
    xi = validate.vector(xi, "xi", 7)
    if arrays.is_foreign(xi):
        w0, w1, w2, u0, u1, u2, lam = (xi[..., k] for k in range(7))
        return arrays.matrix(
            [lam, -w2, w1, u0, w2, lam, -w0, u1, -w1, w0, lam, u2, 0.0, 0.0, 0.0, 0.0], 4, 4
        )
    out = np.zeros((*xi.shape[:-1], 4, 4))
    out[..., :3, :3] = so3._hat(xi[..., :3]) + xi[..., 6, None, None] * np.eye(3)
    out[..., :3, 3] = xi[..., 3:6]
    return out


def vee(X: Any) -> FloatArray:
    """Inverse of :func:`hat`: ω from the skew part, ``λ = tr/3`` of the top-left block, ``u``."""
    X = validate.square(X, "X", 4)
    if arrays.is_foreign(X):
        xp = arrays.namespace(X)
        parts = [
            0.5 * (X[..., 2, 1] - X[..., 1, 2]),
            0.5 * (X[..., 0, 2] - X[..., 2, 0]),
            0.5 * (X[..., 1, 0] - X[..., 0, 1]),
            X[..., 0, 3],
            X[..., 1, 3],
            X[..., 2, 3],
            (X[..., 0, 0] + X[..., 1, 1] + X[..., 2, 2]) / 3.0,
        ]
        return validate.finite_output(xp.stack(parts, axis=-1), "sim3.vee")
    lam = np.trace(X[..., :3, :3], axis1=-2, axis2=-1) / 3.0
    return np.concatenate([so3.vee(X[..., :3, :3]), X[..., :3, 3], lam[..., None]], axis=-1)


def exp(xi: Any) -> FloatArray:
    """Sim(3) exponential ``(ω, u, λ)`` → ``[[e^λ Exp(ω), W u], [0, 1]]``, ``(..., 4, 4)``.

    Raises ``ValueError`` when the scale ``e^λ`` is not a normal float64 (``λ < −708``: it would
    round to a subnormal or to 0, a matrix that is no similarity), naming the batch index.
    """
    x = _tangent(xi)
    return validate.finite_output(_exp(x), "sim3.exp")


def log(X: Any) -> FloatArray:
    """Sim(3) logarithm → ``(ω, u, λ)``, ``‖ω‖ ∈ [0, π]``. GTSAM ``Similarity3.Logmap``."""
    return validate.finite_output(_log(validate.similarity(X, "X")), "sim3.log")


def jr(xi: Any) -> FloatArray:
    """Right Jacobian ``Exp(ξ + δ) ≈ Exp(ξ)·Exp(jr δ)``, ``(..., 7, 7)``."""
    return validate.finite_output(_jr(_tangent(xi)), "sim3.jr")


def jl(xi: Any) -> FloatArray:
    """Left Jacobian ``Exp(ξ + δ) ≈ Exp(jl δ)·Exp(ξ)``, ``(..., 7, 7)``."""
    return validate.finite_output(_jl(_tangent(xi)), "sim3.jl")


def jr_inv(xi: Any) -> FloatArray:
    """Inverse right Jacobian, ``(..., 7, 7)``."""
    return validate.finite_output(_jr_inv(_tangent(xi)), "sim3.jr_inv")


def jl_inv(xi: Any) -> FloatArray:
    """Inverse left Jacobian, ``(..., 7, 7)``."""
    return validate.finite_output(_jl_inv(_tangent(xi)), "sim3.jl_inv")


def adjoint(X: Any) -> FloatArray:
    """``Ad_X = [[R, 0, 0], [hat(t)R, sR, −t], [0, 0, 1]]`` in ``(ω, u, λ)``, ``(..., 7, 7)``."""
    return validate.finite_output(_adjoint(validate.similarity(X, "X")), "sim3.adjoint")


def inverse(X: Any) -> FloatArray:
    """``[[Rᵀ/s, −Rᵀt/s], [0, 1]]``."""
    return validate.finite_output(_inverse(validate.similarity(X, "X")), "sim3.inverse")


def compose(X1: Any, X2: Any) -> FloatArray:
    """``X1·X2`` (broadcast)."""
    return _mg.compose(X1, X2, validate.similarity, ("X1", "X2"), "sim3.compose")


def act(X: Any, p: Any) -> FloatArray:
    """``sRp + t`` for points ``(..., 3)`` (GTSAM ``transformFrom``)."""
    return _mg.act(X, p, validate.similarity, 3, ("X", "p"), "sim3.act")


def interpolate(X0: Any, X1: Any, tau: Any) -> FloatArray:
    """Geodesic ``X0·Exp(τ·Log(X0⁻¹X1))``; ``τ`` broadcasts against the batch."""
    ops = (_log, _exp, _inverse)
    return _mg.interpolate(
        X0, X1, tau, validate.similarity, _tangent, ops, ("X0", "X1"), "sim3.interpolate"
    )


# ----------------------------------------------------------------------------- the record
GROUP = register_shipped(
    Group(
        name="sim3", dim=7, matrix=4, rot=slice(0, 3), vecs=(slice(3, 6),), cols=(3,), scale=6,
        element=validate.similarity,
        kernels=Kernels(
            exp=_exp, log=_log, inverse=_inverse, adjoint=_adjoint, jr_inv=_jr_inv,
            jl_inv=_jl_inv, jr=_jr, jl=_jl, scale=_scale,
        ),
        probe=_exp(np.array([0.4, -0.7, 0.5, 1.5, -2.0, 0.8, 0.3])), label="Sim(3)",
        tangent_doc="(ω, u, λ)", tangent_check=_log_scale_bound, array_api=True,
    )
)  # fmt: skip
