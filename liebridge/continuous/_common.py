"""Shared steps of the continuous-time package: time units, conventions, small batched SE(3) ops.

Time: a float array is read as **seconds**, an integer array as **integer nanoseconds**; the two
are never mixed in one call (a :class:`ValueError` names both arguments). Differences of integer
stamps are taken in ``int64`` before any conversion to float, so 1.7e18 ns epoch stamps keep
their nanoseconds.
"""

from __future__ import annotations

from math import comb, factorial
from typing import Any

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions import Convention, ConventionLike, get, single_group
from ..conventions import unchecked as cu
from ..lie import se3
from ..lie import unchecked as lu

TIME_UNITS: tuple[str, ...] = ("s", "ns")
NS_PER_S = 1_000_000_000


def time_array(x: Any, name: str) -> tuple[np.ndarray[Any, Any], str]:
    """Return ``(array, unit)``: float → seconds (float64), integer → nanoseconds (int64)."""
    if isinstance(x, (bool, np.bool_)):
        raise TypeError(f"{name}: expected a time (float seconds or integer nanoseconds), got bool")
    arr = np.asarray(x)
    if arr.dtype.kind in "iu":
        if arr.dtype.kind == "u" and arr.size and int(arr.max()) > np.iinfo(np.int64).max:
            raise ValueError(f"{name}: integer nanoseconds beyond int64")
        return arr.astype(np.int64, copy=False), "ns"
    if arr.dtype.kind == "b":
        raise TypeError(f"{name}: expected times (float seconds or integer nanoseconds), got bool")
    out = validate.as_float_array(arr, name)
    bad = ~np.isfinite(out)
    if bad.any():
        idx = validate.batch_index(bad)
        raise ValueError(
            f"{name}: non-finite time at index {idx} ({int(bad.sum())} of {out.size} entries)"
        )
    return out, "s"


def same_unit(unit_a: str, name_a: str, unit_b: str, name_b: str) -> None:
    """Raise on mixed time units (integer nanoseconds with float seconds)."""
    if unit_a != unit_b:
        desc = {"s": "float seconds", "ns": "integer nanoseconds"}
        raise ValueError(
            f"mixed time units: {name_a} is {desc[unit_a]} but {name_b} is {desc[unit_b]}; "
            f"convert one of them (ns = round(s * 1e9)) — liebridge never guesses the unit"
        )


def convention(conv: ConventionLike, name: str = "convention") -> Convention:
    """Return the SE(3) convention (preset name or object), or raise a clear error."""
    c = single_group(get(conv), name)
    if c.record is not se3.GROUP:
        raise ValueError(f"{name}: expected an SE(3) convention, got {c.name!r} (group {c.group})")
    return c


def to_conv_columns(
    J_can: FloatArray, conv: Convention, T_out: FloatArray | None, T_in: FloatArray
) -> FloatArray:
    """Express a canonical (GTSAM right, (ω, v)) Jacobian in ``conv``'s tangents.

    ``J_conv = from_canonical(conv, T_out) @ J_can @ to_canonical(conv, T_in)``; ``T_out`` None
    keeps the output rows as they are (a point, a residual).
    """
    if conv.name == "gtsam":
        return J_can
    J = J_can @ cu.to_canonical(conv, T_in)
    if T_out is not None:
        J = cu.from_canonical(conv, T_out) @ J
    return np.asarray(J, dtype=np.float64)


def hat3(w: FloatArray) -> FloatArray:
    """``[w]ₓ`` of a batch ``(..., 3)``."""
    return lu.so3_hat(w)


def se3_ad(xi: FloatArray) -> FloatArray:
    """``ad(ξ) = [[ω×, 0], [v×, ω×]]`` in ``(ω, v)`` (``ad(ξ) η = [ξ, η]``)."""
    W = hat3(xi[..., :3])
    V = hat3(xi[..., 3:])
    out = np.zeros((*xi.shape[:-1], 6, 6))
    out[..., :3, :3] = W
    out[..., 3:, 3:] = W
    out[..., 3:, :3] = V
    return out


def se3_jr(xi: FloatArray) -> FloatArray:
    """Right Jacobian ``jr(ξ) = jl(−ξ)``."""
    return np.asarray(lu.se3_jl(-xi), dtype=np.float64)


def se3_jr_inv(xi: FloatArray) -> FloatArray:
    """``jr(ξ)⁻¹ = jl(−ξ)⁻¹``."""
    return np.asarray(lu.se3_jl_inv(-xi), dtype=np.float64)


def blending_matrix(order: int) -> FloatArray:
    """Uniform B-spline matrix ``M[i, j]``: weight of knot ``j`` on ``uⁱ`` (Qin 2000)."""
    k = order
    M = np.zeros((k, k))
    for i in range(k):
        for j in range(k):
            s = sum(
                (-1) ** (m - j) * comb(k, m - j) * (k - m - 1) ** (k - 1 - i) for m in range(j, k)
            )
            M[i, j] = comb(k - 1, i) * s / factorial(k - 1)
    return M


def cumulative_basis(order: int, u: FloatArray, derivative: int = 0) -> FloatArray:
    """Cumulative basis ``b̃_j(u)`` (``j = 0..order−1``, ``b̃_0 ≡ 1``) or its u-derivative."""
    M = blending_matrix(order)
    Mc = np.cumsum(M[:, ::-1], axis=1)[:, ::-1]  # b̃_j = Σ_{l ≥ j} b_l
    powers = np.zeros((*u.shape, order))
    for i in range(derivative, order):
        powers[..., i] = factorial(i) / factorial(i - derivative) * u ** (i - derivative)
    return np.asarray(powers @ Mc, dtype=np.float64)
