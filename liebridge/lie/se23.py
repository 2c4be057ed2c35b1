"""SE₂(3) (extended pose) kernel in canonical form (GTSAM ``NavState``): batched, float64.

Canonical conventions (identical to GTSAM 4.3's ``NavState`` group operations, measured):

* an element is ``(..., 5, 5)`` ``X = [[R, p, v], [0, 1, 0], [0, 0, 1]]`` (GTSAM
  ``NavState.matrix()``): attitude ``R = R_world_body``, position and velocity in the world frame;
* a tangent is ``ξ = (ω, ρ_p, ρ_v)``, shape ``(..., 9)`` (GTSAM's ``NavState`` order);
* ``Exp(ξ) = [[Exp(ω), Jl(ω) ρ_p, Jl(ω) ρ_v], [0, I₂]]`` — the coupled exponential (GTSAM
  ``NavState.Expmap``). **GTSAM's ``NavState.retract`` is not ``X·Exp``**: it is component-wise,
  ``(R·Exp(δθ), p + R·δp, v + R·δv)`` (the ``gtsam_navstate`` convention);
* ``jl(ξ) = [[Jl, 0, 0], [Q(ω, ρ_p), Jl, 0], [Q(ω, ρ_v), 0, Jl]]`` (Barfoot's Q of SE(3) per
  vector), ``jr(ξ) = jl(−ξ)``; inverses by block inversion;
* ``adjoint(X) = [[R, 0, 0], [hat(p)R, R, 0], [hat(v)R, 0, R]]`` (GTSAM ``NavState.AdjointMap``).

Series and the exact branch at θ = π come from :mod:`liebridge.lie.so3`/:mod:`~liebridge.lie.se3`.
``act`` applies the element's pose part to points, ``R x + p``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from . import _matrix_group as _mg
from . import se3, so3
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
DIM, MATRIX = 9, 5


def _assemble(R: FloatArray, p: FloatArray, vel: FloatArray) -> FloatArray:
    if arrays.any_foreign(R, p, vel):
        xp = arrays.namespace(R, p, vel)
        batch = tuple(
            np.broadcast_shapes(tuple(R.shape[:-2]), tuple(p.shape[:-1]), tuple(vel.shape[:-1]))
        )
        top = xp.concat(
            [xp.broadcast_to(R, (*batch, 3, 3)), xp.broadcast_to(p[..., None], (*batch, 3, 1)),
             xp.broadcast_to(vel[..., None], (*batch, 3, 1))], axis=-1,
        )  # fmt: skip
        bottom = arrays.like(np.eye(5)[3:], top)
        return xp.concat([top, xp.broadcast_to(bottom, (*batch, 2, 5))], axis=-2)
    shape = np.broadcast_shapes(R.shape[:-2], p.shape[:-1], vel.shape[:-1])
    X = np.zeros((*shape, 5, 5))
    X[..., :3, :3] = R
    X[..., :3, 3] = p
    X[..., :3, 4] = vel
    X[..., 3, 3] = X[..., 4, 4] = 1.0
    return X


def _mv(A: FloatArray, x: FloatArray) -> FloatArray:
    return arrays.matvec(A, x)


def _exp(xi: FloatArray) -> FloatArray:
    w = xi[..., :3]
    J = so3._jl(w)
    return _assemble(so3._exp(w), _mv(J, xi[..., 3:6]), _mv(J, xi[..., 6:]))


def _log(X: FloatArray) -> FloatArray:
    w = so3._log(X[..., :3, :3])
    Ji = so3._jl_inv(w)
    parts = [w, _mv(Ji, X[..., :3, 3]), _mv(Ji, X[..., :3, 4])]
    return arrays.concat(parts, -1)


def _inverse(X: FloatArray) -> FloatArray:
    Rt = arrays.mT(X[..., :3, :3])
    return _assemble(Rt, -_mv(Rt, X[..., :3, 3]), -_mv(Rt, X[..., :3, 4]))


def _lower(D: FloatArray, L1: FloatArray, L2: FloatArray) -> FloatArray:
    """``[[D, 0, 0], [L1, D, 0], [L2, 0, D]]`` from ``(..., 3, 3)`` blocks."""
    Z = 0.0 * D
    return arrays.blocks([[D, Z, Z], [L1, D, Z], [L2, Z, D]])


def _adjoint(X: FloatArray) -> FloatArray:
    R = X[..., :3, :3]
    return _lower(R, so3._hat(X[..., :3, 3]) @ R, so3._hat(X[..., :3, 4]) @ R)


def _jl(xi: FloatArray) -> FloatArray:
    w = xi[..., :3]
    return _lower(so3._jl(w), se3._q(w, xi[..., 3:6]), se3._q(w, xi[..., 6:]))


def _jl_inv(xi: FloatArray) -> FloatArray:
    w = xi[..., :3]
    Ji = so3._jl_inv(w)
    return _lower(Ji, -Ji @ se3._q(w, xi[..., 3:6]) @ Ji, -Ji @ se3._q(w, xi[..., 6:]) @ Ji)


def _jr(xi: FloatArray) -> FloatArray:
    return _jl(-xi)


def _jr_inv(xi: FloatArray) -> FloatArray:
    return _jl_inv(-xi)


def _tangent(xi: Any, name: str = "xi") -> FloatArray:
    return validate.tangent(xi, name, 9, slice(0, 3))


def hat(xi: Any) -> FloatArray:
    """``(ω, ρ_p, ρ_v)`` → ``[[hat(ω), ρ_p, ρ_v], [0, 0, 0], [0, 0, 0]]``, ``(..., 5, 5)``."""
    xi = validate.vector(xi, "xi", 9)
    x, y, z, p0, p1, p2, v0, v1, v2 = (xi[..., k] for k in range(9))
    return arrays.matrix(
        [0.0, -z, y, p0, v0, z, 0.0, -x, p1, v1, -y, x, 0.0, p2, v2] + [0.0] * 10, 5, 5
    )


def vee(X: Any) -> FloatArray:
    """Inverse of :func:`hat`: ``(..., 5, 5)`` → ``(ω, ρ_p, ρ_v)``."""
    X = validate.square(X, "X", 5)
    return arrays.concat([so3.vee(X[..., :3, :3]), X[..., :3, 3], X[..., :3, 4]], axis=-1)


def exp(xi: Any) -> FloatArray:
    """SE₂(3) exponential ``(..., 9)`` → ``(..., 5, 5)``. GTSAM ``NavState.Expmap``."""
    return validate.finite_output(_exp(_tangent(xi)), "se23.exp")


def log(X: Any) -> FloatArray:
    """SE₂(3) logarithm → ``(ω, ρ_p, ρ_v)``, ``‖ω‖ ∈ [0, π]``. GTSAM ``NavState.Logmap``."""
    return validate.finite_output(_log(validate.extended_pose(X, "X")), "se23.log")


def jr(xi: Any) -> FloatArray:
    """Right Jacobian ``Exp(ξ + δ) ≈ Exp(ξ)·Exp(jr δ)``, ``(..., 9, 9)``."""
    return validate.finite_output(_jr(_tangent(xi)), "se23.jr")


def jl(xi: Any) -> FloatArray:
    """Left Jacobian ``Exp(ξ + δ) ≈ Exp(jl δ)·Exp(ξ)``, ``(..., 9, 9)``."""
    return validate.finite_output(_jl(_tangent(xi)), "se23.jl")


def jr_inv(xi: Any) -> FloatArray:
    """Inverse right Jacobian (closed-form block inverse), ``(..., 9, 9)``."""
    return validate.finite_output(_jr_inv(_tangent(xi)), "se23.jr_inv")


def jl_inv(xi: Any) -> FloatArray:
    """Inverse left Jacobian (closed-form block inverse), ``(..., 9, 9)``."""
    return validate.finite_output(_jl_inv(_tangent(xi)), "se23.jl_inv")


def adjoint(X: Any) -> FloatArray:
    """``Ad_X`` in ``(ω, ρ_p, ρ_v)``: ``X·Exp(ξ)·X⁻¹ = Exp(Ad_X ξ)``. GTSAM ``AdjointMap``."""
    return validate.finite_output(_adjoint(validate.extended_pose(X, "X")), "se23.adjoint")


def inverse(X: Any) -> FloatArray:
    """``[[Rᵀ, −Rᵀp, −Rᵀv], [0, I₂]]``."""
    return validate.finite_output(_inverse(validate.extended_pose(X, "X")), "se23.inverse")


def compose(X1: Any, X2: Any) -> FloatArray:
    """``X1·X2`` (broadcast): ``(R1R2, p1 + R1p2, v1 + R1v2)``."""
    return _mg.compose(X1, X2, validate.extended_pose, ("X1", "X2"), "se23.compose")


def act(X: Any, x: Any) -> FloatArray:
    """Apply the pose part to points: ``R x + p``, ``(..., 3)``."""
    return _mg.act(X, x, validate.extended_pose, 3, ("X", "x"), "se23.act")


def interpolate(X0: Any, X1: Any, tau: Any) -> FloatArray:
    """Geodesic ``X0·Exp(τ·Log(X0⁻¹X1))``; ``τ`` broadcasts against the batch."""
    ops = (_log, _exp, _inverse)
    return _mg.interpolate(
        X0, X1, tau, validate.extended_pose, _tangent, ops, ("X0", "X1"), "se23.interpolate"
    )


# ----------------------------------------------------------------------------- the record
GROUP = register_shipped(
    Group(
        name="se23", dim=9, matrix=5, rot=slice(0, 3), vecs=(slice(3, 6), slice(6, 9)),
        cols=(3, 4), scale=None, element=validate.extended_pose,
        kernels=Kernels(
            exp=_exp, log=_log, inverse=_inverse, adjoint=_adjoint, jr_inv=_jr_inv,
            jl_inv=_jl_inv, jr=_jr, jl=_jl,
        ),
        probe=_exp(np.array([0.4, -0.7, 0.5, 1.5, -2.0, 0.8, -0.6, 1.1, 0.7])),
        label="SE₂(3)", tangent_doc="(ω, ρ_p, ρ_v)",
        note="extended pose / navigation state", array_api=True,
    )
)  # fmt: skip
