"""Scalar coefficient functions of the SO(3)/SE(3) closed forms, with their Taylor series.

Every function takes ``θ = ‖ω‖`` (an array, broadcast element-wise) and switches to its Taylor
series below :data:`SMALL_ANGLE`, the one threshold of the package. The series are the exact
Maclaurin coefficients (generated from factorials and Bernoulli numbers) up to θ¹⁶, so their
truncation error at the threshold is below 1e-20 relative. The threshold is deliberately large
(0.5 rad): the closed forms of Barfoot's Q-matrix coefficients lose about ``120·eps/θ⁴`` to
cancellation (``q_coeff3``: terms of size 2θ for a result θ⁵/60), which just above 0.5 rad is
4e-13 relative (measured) and at the textbook 1e-4 would be catastrophic. Closed forms
avoid cancellation where possible (``1 − cos θ = 2 sin²(θ/2)``, ``cot(θ/2)`` instead of
``(1 + cos θ)/sin θ``), so that no coefficient produces NaN anywhere on ``[0, π]``.
Checked against 50-digit arithmetic in ``tests/test_lie_series.py``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import arrays

FloatArray = npt.NDArray[np.float64]

#: Below this angle (radians) every coefficient uses its Taylor series.
SMALL_ANGLE = 0.5

# Maclaurin coefficients in powers of θ² (generated; see the module docstring).
SINC_SERIES = (
    1.0,
    -0.16666666666666666,
    0.008333333333333333,
    -0.0001984126984126984,
    2.7557319223985893e-06,
    -2.505210838544172e-08,
    1.6059043836821613e-10,
    -7.647163731819816e-13,
    2.8114572543455206e-15,
)
ONE_MINUS_COS_OVER_T2_SERIES = (
    0.5,
    -0.041666666666666664,
    0.001388888888888889,
    -2.48015873015873e-05,
    2.755731922398589e-07,
    -2.08767569878681e-09,
    1.1470745597729725e-11,
    -4.779477332387385e-14,
    1.5619206968586225e-16,
)
T_MINUS_SIN_OVER_T3_SERIES = (
    0.16666666666666666,
    -0.008333333333333333,
    0.0001984126984126984,
    -2.7557319223985893e-06,
    2.505210838544172e-08,
    -1.6059043836821613e-10,
    7.647163731819816e-13,
    -2.8114572543455206e-15,
    8.22063524662433e-18,
)
Q_COEFF2_SERIES = (
    0.041666666666666664,
    -0.001388888888888889,
    2.48015873015873e-05,
    -2.755731922398589e-07,
    2.08767569878681e-09,
    -1.1470745597729725e-11,
    4.779477332387385e-14,
    -1.5619206968586225e-16,
    4.110317623312165e-19,
)
Q_COEFF3_SERIES = (
    0.008333333333333333,
    -0.0003968253968253968,
    8.267195767195768e-06,
    -1.0020843354176688e-07,
    8.029521918410807e-10,
    -4.58829823909189e-12,
    1.9680200780418645e-14,
    -6.576508197299464e-17,
    1.7615646957052136e-19,
)
JINV_COEFF_SERIES = (
    0.08333333333333333,
    0.001388888888888889,
    3.306878306878307e-05,
    8.267195767195768e-07,
    2.08767569878681e-08,
    5.284190138687493e-10,
    1.3382536530684679e-11,
    3.3896802963225827e-13,
    8.586062056277845e-15,
)


def _horner(t2: FloatArray, c: tuple[float, ...]) -> FloatArray:
    acc = t2 * 0.0 + c[-1] if arrays.is_foreign(t2) else np.full_like(t2, c[-1])
    for ck in c[-2::-1]:
        acc = acc * t2 + ck
    return acc


def _where_small(
    theta: FloatArray,
    coeffs: tuple[float, ...],
    closed: Callable[[FloatArray, Any], FloatArray],
    t2: FloatArray | None = None,
) -> FloatArray:
    """``closed(θ)`` for ``θ ≥ SMALL_ANGLE``, the Maclaurin series below it.

    The closed form is evaluated with the small entries replaced by 1 (no division by 0) and the
    series only on the small entries (a boolean gather): no work, and no overflow of high powers
    of a large θ, in a branch that is thrown away. On torch/JAX arrays both branches are evaluated
    on every entry and selected with ``where`` (traceable; the thrown-away branch sees only safe
    values, so its gradient is finite and multiplied by 0), the series in ``t2 = θ²`` when given
    (the kernels pass ``ω·ω``, whose derivatives at 0 are exact, unlike those of ``‖ω‖²``).
    """
    if arrays.is_foreign(theta):
        xp = arrays.namespace(theta)
        small = theta < SMALL_ANGLE
        safe = xp.where(small, arrays.like(1.0, theta), theta)
        series = _horner(theta * theta if t2 is None else t2, coeffs)
        return xp.where(small, series, closed(safe, xp))
    theta = np.asarray(theta, dtype=np.float64)
    small = theta < SMALL_ANGLE
    out = np.array(closed(np.where(small, 1.0, theta), np), dtype=np.float64)
    if small.any():
        t = theta[small]
        out[small] = _horner(t * t, coeffs)
    return out


def angle(w: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``(θ, θ²)`` of rotation vectors ``(..., 3)``: ``θ = ‖ω‖``, ``θ² = ω·ω``.

    On torch/JAX arrays ``θ`` is ``sqrt`` of ``θ²`` where ``θ² > 0`` and exactly 0 elsewhere,
    through a ``where`` whose other branch is safe, so that its gradient at ω = 0 is 0, not the
    NaN of ``‖·‖``'s derivative there (the bug of PyPose #395, kornia #4404).
    """
    if arrays.is_foreign(w):
        xp = arrays.namespace(w)
        t2 = xp.sum(w * w, axis=-1)
        pos = t2 > 0.0
        th = xp.where(pos, xp.sqrt(xp.where(pos, t2, arrays.like(1.0, t2))), arrays.like(0.0, t2))
        return th, t2
    w0, w1, w2 = w[..., 0], w[..., 1], w[..., 2]
    t2 = w0 * w0 + w1 * w1 + w2 * w2  # (the order the compiled passes sum in)
    return np.sqrt(t2), t2


def sinc(theta: FloatArray, t2: FloatArray | None = None) -> FloatArray:
    """``A(θ) = sin θ / θ`` (``t2``: ``θ²`` for the series on torch/JAX, see :func:`angle`)."""
    return _where_small(theta, SINC_SERIES, lambda s, xp: xp.sin(s) / s, t2)


def one_minus_cos_over_t2(theta: FloatArray, t2: FloatArray | None = None) -> FloatArray:
    """``B(θ) = (1 − cos θ) / θ²``."""
    return _where_small(
        theta, ONE_MINUS_COS_OVER_T2_SERIES, lambda s, xp: 2.0 * (xp.sin(0.5 * s) / s) ** 2, t2
    )


def t_minus_sin_over_t3(theta: FloatArray, t2: FloatArray | None = None) -> FloatArray:
    """``C(θ) = (θ − sin θ) / θ³``."""
    return _where_small(theta, T_MINUS_SIN_OVER_T3_SERIES, lambda s, xp: (s - xp.sin(s)) / s**3, t2)


def jinv_coeff(theta: FloatArray, t2: FloatArray | None = None) -> FloatArray:
    """``D(θ) = 1/θ² − (1 + cos θ)/(2θ sin θ) = 1/θ² − cot(θ/2)/(2θ)``; finite at θ = π (1/π²)."""
    return _where_small(
        theta,
        JINV_COEFF_SERIES,
        lambda s, xp: 1.0 / (s * s) - xp.cos(0.5 * s) / (2.0 * s * xp.sin(0.5 * s)),
        t2,
    )


def q_coeff2(theta: FloatArray, t2: FloatArray | None = None) -> FloatArray:
    """``(θ² + 2 cos θ − 2) / (2θ⁴)`` of Barfoot's SE(3) Q-matrix."""
    return _where_small(
        theta,
        Q_COEFF2_SERIES,
        lambda s, xp: (s * s - 4.0 * xp.sin(0.5 * s) ** 2) / (2.0 * s**4),
        t2,
    )


def q_coeff3(theta: FloatArray, t2: FloatArray | None = None) -> FloatArray:
    """``(2θ − 3 sin θ + θ cos θ) / (2θ⁵)`` of Barfoot's SE(3) Q-matrix."""
    return _where_small(
        theta,
        Q_COEFF3_SERIES,
        lambda s, xp: (2.0 * s - 3.0 * xp.sin(s) + s * xp.cos(s)) / (2.0 * s**5),
        t2,
    )


# ------------------------------------------------------------------------ Sim(3): two variables
#: Below this ``|λ + iθ|`` the Sim(3) coefficients use Gauss–Legendre quadrature of their integrals.
SIM3_SMALL = 2.0
_GL_X, _GL_W = np.polynomial.legendre.leggauss(12)
_GL_T = 0.5 * (_GL_X + 1.0)  # nodes on [0, 1]
_GL_WT = 0.5 * _GL_W


def expm1_over_x(lam: FloatArray) -> FloatArray:
    """``(e^λ − 1)/λ`` (1 at λ = 0; ``expm1`` keeps full relative accuracy for small λ)."""
    lam = np.asarray(lam, dtype=np.float64)
    zero = lam == 0.0
    safe = np.where(zero, 1.0, lam)
    return np.asarray(np.where(zero, 1.0, np.expm1(safe) / safe), dtype=np.float64)


def sim3_coeffs(theta: FloatArray, lam: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Coefficients of Sim(3)'s ``W(ω, λ) = a I + b hat(ω) + c hat(ω)²`` (``t = W u`` in ``Exp``).

    ``W = ∫₀¹ e^{λτ} Exp(τω) dτ``, so ``a = (e^λ − 1)/λ``, ``b = ∫₀¹ e^{λτ} sin(τθ)/θ dτ``,
    ``c = ∫₀¹ e^{λτ} (1 − cos τθ)/θ² dτ``. Closed forms (from ``∫ e^{zτ} = (e^z − 1)/z``,
    ``z = λ + iθ``, rearranged so that nothing divides by θ):
    ``b = (λ e^λ sinc θ − expm1 λ + e^λ θ² B(θ)) / (λ² + θ²)``,
    ``c = (a + e^λ (λ B(θ) − sinc θ)) / (λ² + θ²)``, ``B = (1 − cos θ)/θ²``.
    They cancel as ``|z| → 0``; there (``|z| <`` :data:`SIM3_SMALL`) the integrals are evaluated
    by 12-point Gauss–Legendre quadrature, whose error for an entire integrand with ``|z| ≤ 2``
    is below 1e-30 (so the result is exact to rounding; checked against 50-digit mpmath in
    ``tests/test_lie_kernels.py``). At λ = 0 they are SO(3)'s ``(1, B, C)``.
    """
    theta = np.asarray(theta, dtype=np.float64)
    lam = np.asarray(lam, dtype=np.float64)
    theta, lam = np.broadcast_arrays(theta, lam)
    r2 = lam * lam + theta * theta
    small = r2 < SIM3_SMALL * SIM3_SMALL
    th = np.where(small, 1.0, theta)
    la = np.where(small, 1.0, lam)
    e = np.exp(la)
    a = expm1_over_x(la)
    sc, B = sinc(th), one_minus_cos_over_t2(th)
    d = la * la + th * th
    b = (la * e * sc - np.expm1(la) + e * th * th * B) / d
    c = (a + e * (la * B - sc)) / d
    a, b, c = np.array(a), np.array(b), np.array(c)
    if small.any():
        ts, ls = theta[small][..., None], lam[small][..., None]
        tt = _GL_T * ts
        ex = np.exp(_GL_T * ls) * _GL_WT
        a[small] = ex.sum(axis=-1)
        b[small] = (ex * _GL_T * sinc(tt)).sum(axis=-1)
        c[small] = (ex * _GL_T * _GL_T * one_minus_cos_over_t2(tt)).sum(axis=-1)
    return a, b, c
