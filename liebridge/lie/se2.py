"""SE(2) kernel in canonical form (GTSAM ``Pose2``): batched, float64, inputs never mutated.

Canonical conventions (identical to GTSAM 4.3's ``Pose2``, measured in the tests):

* a pose is a ``(..., 3, 3)`` matrix ``T = [[R, t], [0, 0, 1]]``; ``T_world_body`` maps body
  coordinates to world coordinates;
* a twist is ``ξ = (vx, vy, ω)``, **translation first** (GTSAM's ``Pose2`` order; SE(3)'s
  canonical twist is rotation first — each group's canonical order is GTSAM's);
* ``Exp(ξ) = [[Rot(ω), V(ω) v], [0, 1]]``, ``V(ω) = (sin ω/ω) I + ((1 − cos ω)/ω) J``,
  ``J = [[0, −1], [1, 0]]`` (so the translation of ``Exp(ξ)`` is *not* ``v``);
* ``jr``: ``Exp(ξ + δ) ≈ Exp(ξ)·Exp(jr(ξ) δ)`` (GTSAM ``Pose2.ExpmapDerivative``); ``jl(ξ) =
  jr(−ξ)``;
* ``adjoint(T) = [[R, (t_y, −t_x)ᵀ], [0, 1]]``: ``T·Exp(ξ)·T⁻¹ = Exp(Ad_T ξ)`` (GTSAM
  ``Pose2.AdjointMap``).

The left Jacobian is Solà et al. (arXiv 1812.01537, eq. 163) written with the series-safe
coefficients of :mod:`liebridge.lie.series`: ``jl = [[V, c], [0, 1]]`` with
``c = (ρ₁ θC + ρ₂ B, −ρ₁ B + ρ₂ θC)``, ``B = (1 − cos θ)/θ²``, ``C = (θ − sin θ)/θ³``; its inverse
is the block inverse ``[[V⁻¹, −V⁻¹c], [0, 1]]`` with ``V⁻¹ = (A I − b J)/sinc²(θ/2)``.
The logarithm is exact on ``(−π, π]`` (``V⁻¹`` is finite up to and at π).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from . import _matrix_group as _mg
from .record import Group, Kernels, register_shipped
from .series import one_minus_cos_over_t2, sinc, t_minus_sin_over_t3

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
DIM, MATRIX = 3, 3
_ROT = slice(2, 3)


def _rot(th: FloatArray) -> FloatArray:
    xp = arrays.namespace(th)
    c, s = xp.cos(th), xp.sin(th)
    return arrays.matrix([c, -s, s, c], 2, 2)


def _ab(th: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Return ``A = sin θ/θ`` and ``b = (1 − cos θ)/θ`` (series-safe)."""
    at = arrays.namespace(th).abs(th)  # the series branch: even functions of |θ|, in θ² = θ·θ
    t2 = th * th
    return sinc(at, t2), th * one_minus_cos_over_t2(at, t2)


def _exp(xi: FloatArray) -> FloatArray:
    xp = arrays.namespace(xi)
    th = xi[..., 2]
    A, b = _ab(th)
    vx, vy = xi[..., 0], xi[..., 1]
    c, s = xp.cos(th), xp.sin(th)
    return arrays.matrix([c, -s, A * vx - b * vy, s, c, b * vx + A * vy, 0.0, 0.0, 1.0], 3, 3)


def _vinv(th: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Coefficients ``(p, q)`` of ``V(θ)⁻¹ = p I − q J``."""
    A, b = _ab(th)
    h = 0.5 * arrays.namespace(th).abs(th)
    d = sinc(h, 0.25 * th * th) ** 2  # A² + b²
    return A / d, b / d


def _log(T: FloatArray) -> FloatArray:
    th = arrays.atan2(T[..., 1, 0], T[..., 0, 0])
    p, q = _vinv(th)
    tx, ty = T[..., 0, 2], T[..., 1, 2]
    return arrays.vector([p * tx + q * ty, -q * tx + p * ty, th])


def _inverse(T: FloatArray) -> FloatArray:
    c, s, tx, ty = T[..., 0, 0], T[..., 1, 0], T[..., 0, 2], T[..., 1, 2]
    # [[Rᵀ, −Rᵀt], [0, 1]] with R = [[c, −s], [s, c]] (the stored entries, not re-derived)
    r00, r01, r10, r11 = T[..., 0, 0], T[..., 1, 0], T[..., 0, 1], T[..., 1, 1]
    del c, s
    return arrays.matrix(
        [r00, r01, -(r00 * tx + r01 * ty), r10, r11, -(r10 * tx + r11 * ty), 0.0, 0.0, 1.0], 3, 3
    )


def _adjoint(T: FloatArray) -> FloatArray:
    return arrays.matrix(
        [T[..., 0, 0], T[..., 0, 1], T[..., 1, 2], T[..., 1, 0], T[..., 1, 1], -T[..., 0, 2],
         0.0, 0.0, 1.0], 3, 3,
    )  # fmt: skip


def _jl(xi: FloatArray) -> FloatArray:
    th = xi[..., 2]
    at = arrays.namespace(xi).abs(th)
    t2 = th * th
    A, b = _ab(th)
    B = one_minus_cos_over_t2(at, t2)
    tC = th * t_minus_sin_over_t3(at, t2)
    r1, r2 = xi[..., 0], xi[..., 1]
    return arrays.matrix([A, -b, r1 * tC + r2 * B, b, A, -r1 * B + r2 * tC, 0.0, 0.0, 1.0], 3, 3)


def _jl_inv(xi: FloatArray) -> FloatArray:
    J = _jl(xi)
    p, q = _vinv(xi[..., 2])
    c0, c1 = J[..., 0, 2], J[..., 1, 2]
    return arrays.matrix(
        [p, q, -(p * c0 + q * c1), -q, p, -(-q * c0 + p * c1), 0.0, 0.0, 1.0], 3, 3
    )


def _jr(xi: FloatArray) -> FloatArray:
    return _jl(-xi)


def _jr_inv(xi: FloatArray) -> FloatArray:
    return _jl_inv(-xi)


def _tangent(xi: Any, name: str = "xi") -> FloatArray:
    return validate.tangent(xi, name, 3, _ROT)


def hat(xi: Any) -> FloatArray:
    """``(vx, vy, ω)`` → ``[[0, −ω, vx], [ω, 0, vy], [0, 0, 0]]``, ``(..., 3, 3)``."""
    xi = validate.vector(xi, "xi", 3)
    vx, vy, w = xi[..., 0], xi[..., 1], xi[..., 2]
    return arrays.matrix([0.0, -w, vx, w, 0.0, vy, 0.0, 0.0, 0.0], 3, 3)


def vee(X: Any) -> FloatArray:
    """Inverse of :func:`hat`: ``(..., 3, 3)`` → ``(vx, vy, ω)``."""
    X = validate.square(X, "X", 3)
    return arrays.vector([X[..., 0, 2], X[..., 1, 2], 0.5 * (X[..., 1, 0] - X[..., 0, 1])])


def exp(xi: Any) -> FloatArray:
    """SE(2) exponential of ``(vx, vy, ω)`` → ``(..., 3, 3)``. GTSAM ``Pose2.Expmap``."""
    return validate.finite_output(_exp(_tangent(xi)), "se2.exp")


def log(T: Any) -> FloatArray:
    """SE(2) logarithm → ``(vx, vy, ω)``, ``ω ∈ (−π, π]``. GTSAM ``Pose2.Logmap``."""
    return validate.finite_output(_log(validate.pose2(T, "T")), "se2.log")


def jr(xi: Any) -> FloatArray:
    """Right Jacobian ``Exp(ξ + δ) ≈ Exp(ξ)·Exp(jr δ)``, ``(..., 3, 3)``."""
    return validate.finite_output(_jr(_tangent(xi)), "se2.jr")


def jl(xi: Any) -> FloatArray:
    """Left Jacobian ``Exp(ξ + δ) ≈ Exp(jl δ)·Exp(ξ)``, ``(..., 3, 3)``."""
    return validate.finite_output(_jl(_tangent(xi)), "se2.jl")


def jr_inv(xi: Any) -> FloatArray:
    """Inverse right Jacobian (closed-form block inverse); GTSAM ``Pose2.LogmapDerivative``."""
    return validate.finite_output(_jr_inv(_tangent(xi)), "se2.jr_inv")


def jl_inv(xi: Any) -> FloatArray:
    """Inverse left Jacobian (closed-form block inverse), ``(..., 3, 3)``."""
    return validate.finite_output(_jl_inv(_tangent(xi)), "se2.jl_inv")


def adjoint(T: Any) -> FloatArray:
    """``Ad_T = [[R, (t_y, −t_x)ᵀ], [0, 1]]`` in ``(vx, vy, ω)``: ``T·Exp(ξ)·T⁻¹ = Exp(Ad_T ξ)``."""
    return _adjoint(validate.pose2(T, "T"))


def inverse(T: Any) -> FloatArray:
    """``[[Rᵀ, −Rᵀt], [0, 1]]``: ``inverse(T_world_body) = T_body_world``."""
    return _inverse(validate.pose2(T, "T"))


def compose(T1: Any, T2: Any) -> FloatArray:
    """``T1·T2`` (broadcast): ``compose(T_a_b, T_b_c) = T_a_c``."""
    return _mg.compose(T1, T2, validate.pose2, ("T1", "T2"), "se2.compose")


def act(T: Any, p: Any) -> FloatArray:
    """``R p + t`` for 2-D points ``(..., 2)``: ``act(T_world_body, p_body) = p_world``."""
    return _mg.act(T, p, validate.pose2, 2, ("T", "p"), "se2.act")


def interpolate(T0: Any, T1: Any, tau: Any) -> FloatArray:
    """Geodesic ``T0·Exp(τ·Log(T0⁻¹T1))``; ``τ`` broadcasts against the batch."""
    ops = (_log, _exp, _inverse)
    return _mg.interpolate(
        T0, T1, tau, validate.pose2, _tangent, ops, ("T0", "T1"), "se2.interpolate"
    )


# ----------------------------------------------------------------------------- the record
GROUP = register_shipped(
    Group(
        name="se2", dim=3, matrix=3, rot=_ROT, vecs=(slice(0, 2),), cols=(2,), scale=None,
        element=validate.pose2,
        kernels=Kernels(
            exp=_exp, log=_log, inverse=_inverse, adjoint=_adjoint, jr_inv=_jr_inv,
            jl_inv=_jl_inv, jr=_jr, jl=_jl,
        ),
        probe=_exp(np.array([1.5, -2.0, 0.8])), label="SE(2)", tangent_doc="(vx, vy, ω)",
        array_api=True,
    )
)  # fmt: skip
