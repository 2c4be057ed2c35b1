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

import numpy as np
import numpy.typing as npt

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
    acc = np.full_like(t2, c[-1])
    for ck in c[-2::-1]:
        acc = acc * t2 + ck
    return acc


def _where_small(
    theta: FloatArray, coeffs: tuple[float, ...], closed: Callable[[FloatArray], FloatArray]
) -> FloatArray:
    """``closed(θ)`` for ``θ ≥ SMALL_ANGLE``, the Maclaurin series below it.

    The closed form is evaluated with the small entries replaced by 1 (no division by 0) and the
    series only on the small entries (a boolean gather): no work, and no overflow of high powers
    of a large θ, in a branch that is thrown away.
    """
    theta = np.asarray(theta, dtype=np.float64)
    small = theta < SMALL_ANGLE
    out = np.array(closed(np.where(small, 1.0, theta)), dtype=np.float64)
    if small.any():
        t = theta[small]
        out[small] = _horner(t * t, coeffs)
    return out


def sinc(theta: FloatArray) -> FloatArray:
    """``A(θ) = sin θ / θ``."""
    return _where_small(theta, SINC_SERIES, lambda s: np.sin(s) / s)


def one_minus_cos_over_t2(theta: FloatArray) -> FloatArray:
    """``B(θ) = (1 − cos θ) / θ²``."""
    return _where_small(
        theta, ONE_MINUS_COS_OVER_T2_SERIES, lambda s: 2.0 * (np.sin(0.5 * s) / s) ** 2
    )


def t_minus_sin_over_t3(theta: FloatArray) -> FloatArray:
    """``C(θ) = (θ − sin θ) / θ³``."""
    return _where_small(theta, T_MINUS_SIN_OVER_T3_SERIES, lambda s: (s - np.sin(s)) / s**3)


def jinv_coeff(theta: FloatArray) -> FloatArray:
    """``D(θ) = 1/θ² − (1 + cos θ)/(2θ sin θ) = 1/θ² − cot(θ/2)/(2θ)``; finite at θ = π (1/π²)."""
    return _where_small(
        theta,
        JINV_COEFF_SERIES,
        lambda s: 1.0 / (s * s) - np.cos(0.5 * s) / (2.0 * s * np.sin(0.5 * s)),
    )


def q_coeff2(theta: FloatArray) -> FloatArray:
    """``(θ² + 2 cos θ − 2) / (2θ⁴)`` of Barfoot's SE(3) Q-matrix."""
    return _where_small(
        theta, Q_COEFF2_SERIES, lambda s: (s * s - 4.0 * np.sin(0.5 * s) ** 2) / (2.0 * s**4)
    )


def q_coeff3(theta: FloatArray) -> FloatArray:
    """``(2θ − 3 sin θ + θ cos θ) / (2θ⁵)`` of Barfoot's SE(3) Q-matrix."""
    return _where_small(
        theta,
        Q_COEFF3_SERIES,
        lambda s: (2.0 * s - 3.0 * np.sin(s) + s * np.cos(s)) / (2.0 * s**5),
    )
