"""Coefficient functions of the closed forms against 50-digit mpmath, across [0, π].

Each reference is the closed form evaluated by mpmath with 50 significant digits *in the result*:
the closed forms cancel catastrophically near 0 (``2θ − 3 sin θ + θ cos θ`` loses ~5·|log₁₀ θ|
digits), so the working precision is raised by that many digits; at θ = 0 the reference is the
limit (``mpmath.limit``). The kernel must match to a relative ``REL_TOL = 1e-12`` — the closed forms
lose ``eps·(size of the cancelling terms)/(result)``, at most ≈ 5e-13 for ``q_coeff3`` just above
``SMALL_ANGLE`` (its terms there are 2700× the result), and the series are truncated after θ¹⁶.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import _strategies as S
import mpmath
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from liebridge.lie import SMALL_ANGLE
from liebridge.lie import series as _series

pytestmark = pytest.mark.filterwarnings("error")

REL_TOL = 1e-12
DIGITS = 50

MpFn = Callable[[mpmath.mpf], mpmath.mpf]

#: name -> (kernel function, closed form in mpmath, Taylor coefficient table it uses below
#: SMALL_ANGLE, and the function whose Maclaurin series in θ that table lists in powers of θ²)
REFERENCES: dict[str, tuple[Callable[[np.ndarray], np.ndarray], MpFn, str]] = {
    "sinc": (_series.sinc, lambda t: mpmath.sin(t) / t, "SINC_SERIES"),
    "one_minus_cos_over_t2": (
        _series.one_minus_cos_over_t2,
        lambda t: (1 - mpmath.cos(t)) / t**2,
        "ONE_MINUS_COS_OVER_T2_SERIES",
    ),
    "t_minus_sin_over_t3": (
        _series.t_minus_sin_over_t3,
        lambda t: (t - mpmath.sin(t)) / t**3,
        "T_MINUS_SIN_OVER_T3_SERIES",
    ),
    "jinv_coeff": (
        _series.jinv_coeff,
        lambda t: 1 / t**2 - (1 + mpmath.cos(t)) / (2 * t * mpmath.sin(t)),
        "JINV_COEFF_SERIES",
    ),
    "q_coeff2": (
        _series.q_coeff2,
        lambda t: (t**2 + 2 * mpmath.cos(t) - 2) / (2 * t**4),
        "Q_COEFF2_SERIES",
    ),
    "q_coeff3": (
        _series.q_coeff3,
        lambda t: (2 * t - 3 * mpmath.sin(t) + t * mpmath.cos(t)) / (2 * t**5),
        "Q_COEFF3_SERIES",
    ),
}


def _reference(fn: MpFn, theta: float) -> float:
    if theta == 0.0:
        with mpmath.workdps(DIGITS):
            return float(mpmath.limit(fn, 0))
    extra = int(max(0.0, -6.0 * math.log10(theta))) + 10
    with mpmath.workdps(DIGITS + extra):
        return float(fn(mpmath.mpf(theta)))


def _grid() -> np.ndarray:
    around = SMALL_ANGLE + np.array([-1e-3, -1e-6, -1e-9, 1e-9, 1e-6, 1e-3])
    neighbours = [np.nextafter(SMALL_ANGLE, 0.0), np.nextafter(SMALL_ANGLE, 1.0)]
    return np.unique(
        np.concatenate(
            [
                np.asarray(S.EDGE_ANGLES),
                np.geomspace(1e-10, math.pi, 60),
                np.linspace(0.0, math.pi, 41),
                around,
                neighbours,
            ]
        )
    )


@pytest.mark.parametrize("name", sorted(REFERENCES))
def test_against_mpmath_on_grid(name: str) -> None:
    fn, ref_fn, _ = REFERENCES[name]
    theta = _grid()
    ours = fn(theta)  # batched: one call for the whole grid
    ref = np.array([_reference(ref_fn, float(t)) for t in theta])
    rel = np.abs(ours - ref) / np.abs(ref)
    worst = int(np.argmax(rel))
    assert rel[worst] <= REL_TOL, f"{name}: rel err {rel[worst]:.3g} at θ={theta[worst]!r}"


@pytest.mark.parametrize("name", sorted(REFERENCES))
@given(theta=st.floats(0.0, math.pi))
def test_against_mpmath_random(name: str, theta: float) -> None:
    fn, ref_fn, _ = REFERENCES[name]
    ours = float(fn(np.array(theta)))
    ref = _reference(ref_fn, theta)
    assert abs(ours - ref) <= REL_TOL * abs(ref), (ours, ref)


def _maclaurin(fn: MpFn, n: int) -> list[float]:
    """First ``n`` Maclaurin coefficients of ``fn`` by the Cauchy integral on the unit circle.

    The trapezoidal rule with M points on ``|z| = 1`` is exact up to aliasing ``O(ρ^−M)``, ρ being
    the distance to the nearest singularity (2π for ``jinv_coeff``, none for the others): with
    M = 64 that is < 1e-50, and the removable singularity at 0 is never evaluated.
    """
    m = 64
    with mpmath.workdps(40):
        zs = [mpmath.expjpi(mpmath.mpf(2 * k) / m) for k in range(m)]
        fs = [fn(z) for z in zs]
        return [
            float(mpmath.re(sum(f / z**j for f, z in zip(fs, zs, strict=True)) / m))
            for j in range(n)
        ]


@pytest.mark.parametrize("name", sorted(REFERENCES))
def test_series_coefficients_are_the_maclaurin_coefficients(name: str) -> None:
    # the tabulated c_k (coefficient of θ^{2k}, used below SMALL_ANGLE) against the Maclaurin
    # coefficients of the closed form, to double rounding
    _, ref_fn, table = REFERENCES[name]
    coeffs = getattr(_series, table)
    taylor = _maclaurin(ref_fn, 2 * len(coeffs))
    for k, c in enumerate(coeffs):
        assert abs(c - taylor[2 * k]) <= 2e-16 * abs(c), (name, k, c, taylor[2 * k])
        assert abs(taylor[2 * k + 1]) <= 1e-30  # even functions: no odd powers


@pytest.mark.parametrize("name", sorted(REFERENCES))
def test_continuous_at_small_angle(name: str) -> None:
    # the series and the closed form agree where they meet
    fn = REFERENCES[name][0]
    below, above = fn(np.array([np.nextafter(SMALL_ANGLE, 0.0), SMALL_ANGLE]))
    assert abs(below - above) <= 1e-13 * abs(above)


@pytest.mark.parametrize("name", sorted(REFERENCES))
def test_finite_and_shape_preserving(name: str) -> None:
    fn = REFERENCES[name][0]
    theta = np.linspace(0.0, math.pi, 12).reshape(3, 4)
    out = fn(theta)
    assert out.shape == (3, 4)
    assert out.dtype == np.float64
    assert np.isfinite(out).all()
    np.testing.assert_array_equal(out[1, 2], fn(theta[1, 2]))
