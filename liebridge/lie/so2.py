"""SO(2) kernel in canonical form (GTSAM ``Rot2``): batched, float64, inputs never mutated.

* a rotation is a ``(..., 2, 2)`` matrix ``[[cos θ, −sin θ], [sin θ, cos θ]]``;
* the tangent is the angle ``(θ,)``, shape ``(..., 1)`` (a 1-vector, like every tangent);
* the group is commutative: ``jr = jl = jr_inv = jl_inv = adjoint = [[1]]``, and a left and a
  right perturbation are the same (``Rot2.retract(θ) = R·Exp(θ)`` in GTSAM 4.3, measured).

The logarithm is ``atan2(R₁₀, R₀₀) ∈ (−π, π]``: exact everywhere, no series needed (θ = π gives π).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from . import _matrix_group as _mg
from .record import Group, Kernels, register_shipped

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
DIM, MATRIX = 1, 2


def _exp(w: FloatArray) -> FloatArray:
    xp = arrays.namespace(w)
    th = w[..., 0]
    c, s = xp.cos(th), xp.sin(th)
    return arrays.matrix([c, -s, s, c], 2, 2)


def _log(R: FloatArray) -> FloatArray:
    return arrays.atan2(R[..., 1, 0], R[..., 0, 0])[..., None]


def _inverse(R: FloatArray) -> FloatArray:
    if arrays.is_foreign(R):
        return arrays.mT(R)
    return np.array(np.swapaxes(R, -1, -2), dtype=np.float64)


def _ones(w: FloatArray) -> FloatArray:
    if arrays.is_foreign(w):
        return w[..., None] * 0.0 + 1.0
    return np.ones((*w.shape[:-1], 1, 1))


def _adjoint(R: FloatArray) -> FloatArray:
    if arrays.is_foreign(R):
        return R[..., :1, :1] * 0.0 + 1.0
    return np.ones((*R.shape[:-2], 1, 1))


def _tangent(w: Any) -> FloatArray:
    return validate.tangent(w, "w", 1, slice(0, 1))


def hat(w: Any) -> FloatArray:
    """``(θ,)`` → ``[[0, −θ], [θ, 0]]``, ``(..., 2, 2)``."""
    w = validate.vector(w, "w", 1)
    return arrays.matrix([0.0, -w[..., 0], w[..., 0], 0.0], 2, 2)


def vee(W: Any) -> FloatArray:
    """Inverse of :func:`hat` (from the skew part), ``(..., 1)``."""
    W = validate.square(W, "W", 2)
    v = 0.5 * (W[..., 1, 0] - W[..., 0, 1])
    return (v if arrays.is_foreign(v) else np.asarray(v))[..., None]


def exp(w: Any) -> FloatArray:
    """``Exp(θ)``, ``(..., 1)`` → ``(..., 2, 2)``. GTSAM ``Rot2.Expmap``."""
    return validate.finite_output(_exp(_tangent(w)), "so2.exp")


def log(R: Any) -> FloatArray:
    """``Log(R) = atan2(R₁₀, R₀₀) ∈ (−π, π]``, ``(..., 1)``. GTSAM ``Rot2.Logmap``."""
    return _log(validate.rotation2(R, "R"))


def jr(w: Any) -> FloatArray:
    """Right Jacobian, ``[[1]]`` (commutative group), ``(..., 1, 1)``."""
    return _ones(_tangent(w))


def jl(w: Any) -> FloatArray:
    """Left Jacobian, ``[[1]]``, ``(..., 1, 1)``."""
    return _ones(_tangent(w))


def jr_inv(w: Any) -> FloatArray:
    """Inverse right Jacobian, ``[[1]]``."""
    return _ones(_tangent(w))


def jl_inv(w: Any) -> FloatArray:
    """Inverse left Jacobian, ``[[1]]``."""
    return _ones(_tangent(w))


def adjoint(R: Any) -> FloatArray:
    """``Ad_R = [[1]]``: ``R·Exp(θ)·R⁻¹ = Exp(θ)``, ``(..., 1, 1)``."""
    return _adjoint(validate.rotation2(R, "R"))


def inverse(R: Any) -> FloatArray:
    """``R⁻¹ = Rᵀ``."""
    return _inverse(validate.rotation2(R, "R"))


def compose(R1: Any, R2: Any) -> FloatArray:
    """``R1·R2`` (broadcast)."""
    A, B = validate.rotation2(R1, "R1"), validate.rotation2(R2, "R2")
    validate.batch_shape(("R1", tuple(A.shape[:-2])), ("R2", tuple(B.shape[:-2])))
    out = A @ B
    return out if arrays.is_foreign(out) else np.asarray(out, dtype=np.float64)


def act(R: Any, p: Any) -> FloatArray:
    """``R p`` for 2-D points ``(..., 2)``."""
    R = validate.rotation2(R, "R")
    p = validate.vector(p, "p", 2)
    validate.batch_shape(("R", tuple(R.shape[:-2])), ("p", tuple(p.shape[:-1])))
    return validate.finite_output(arrays.matvec(R, p), "so2.act")


def interpolate(R0: Any, R1: Any, tau: Any) -> FloatArray:
    """``R0·Exp(τ·Log(R0⁻¹R1))`` (the shorter arc; τ broadcasts)."""
    ops = (_log, _exp, _inverse)
    return _mg.interpolate(
        R0, R1, tau, validate.rotation2, lambda w, name: validate.tangent(w, name, 1, slice(0, 1)),
        ops, ("R0", "R1"), "so2.interpolate",
    )  # fmt: skip


# ----------------------------------------------------------------------------- the record
GROUP = register_shipped(
    Group(
        name="so2", dim=1, matrix=2, rot=slice(0, 1), vecs=(), cols=(), scale=None,
        element=validate.rotation2,
        kernels=Kernels(
            exp=_exp, log=_log, inverse=_inverse, adjoint=_adjoint, jr_inv=_ones, jl_inv=_ones,
            jr=_ones, jl=_ones,
        ),
        probe=_exp(np.array([0.9])), label="SO(2)", tangent_doc="(θ,)", array_api=True,
    )
)  # fmt: skip
