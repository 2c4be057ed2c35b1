"""SE(3) kernel in canonical form: batched, float64, inputs never mutated.

Canonical conventions (identical to GTSAM's ``Pose3`` on the PyPI wheel, measured in the tests):

* a pose is a ``(..., 4, 4)`` homogeneous matrix ``T = [[R, t], [0, 1]]``; ``T_world_body`` maps
  body coordinates to world coordinates;
* a twist is ``ξ = (ω, v)``, **rotation first**, shape ``(..., 6)``;
* ``exp`` is the true SE(3) exponential: ``Exp(ξ) = [[Exp(ω), V(ω) v], [0, 1]]`` with
  ``V(ω) = so3.jl(ω)`` (so the translation of ``Exp(ξ)`` is *not* ``v``);
* ``jr``: ``Exp(ξ + δ) ≈ Exp(ξ)·Exp(jr(ξ) δ)`` (GTSAM ``Pose3.ExpmapDerivative``);
  ``jl``: ``Exp(ξ + δ) ≈ Exp(jl(ξ) δ)·Exp(ξ)``; ``jl(ξ) = jr(−ξ) = Ad(Exp ξ)·jr(ξ)``;
* ``adjoint(T) = [[R, 0], [hat(t) R, R]]`` in (ω, v): ``T·Exp(ξ)·T⁻¹ = Exp(Ad_T ξ)``.
  (In (v, ω) order it is ``[[R, hat(t) R], [0, R]]`` — the block layout follows the order.)

The Jacobians are closed form, from Barfoot's Q-matrix (*State Estimation for Robotics*, 2nd ed.,
eq. 7.86, written there for (ρ, φ) = (v, ω)), rearranged to (ω, v):
``jl(ξ) = [[Jl(ω), 0], [Q(v, ω), Jl(ω)]]`` and
``jl(ξ)⁻¹ = [[Jl⁻¹, 0], [−Jl⁻¹ Q Jl⁻¹, Jl⁻¹]]`` (block inverse, no 6×6 inversion).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from . import _compiled, so3
from . import _matrix_group as _mg
from .record import Group, Kernels, register_shipped
from .series import (
    angle,
    jinv_coeff,
    one_minus_cos_over_t2,
    q_coeff2,
    q_coeff3,
    sinc,
    t_minus_sin_over_t3,
)

__all__ = [
    "act",
    "ad",
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


_BOTTOM = np.array([0.0, 0.0, 0.0, 1.0])


def _assemble(R: FloatArray, t: FloatArray) -> FloatArray:
    if arrays.is_foreign(
        R,
    ) or arrays.is_foreign(t):
        bottom = arrays.like(_BOTTOM, R)
        top = arrays.namespace(R).concat([R, t[..., None]], axis=-1)
        return arrays.blocks(
            [[top], [arrays.namespace(R).broadcast_to(bottom, (*top.shape[:-2], 1, 4))]]
        )
    T = np.zeros((*R.shape[:-2], 4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = t
    T[..., 3, 3] = 1.0
    return T


def _blocks(a: FloatArray, b: FloatArray, c: FloatArray, d: FloatArray) -> FloatArray:
    """Return ``[[a, b], [c, d]]`` from four ``(..., 3, 3)`` blocks (broadcast)."""
    if arrays.any_foreign(a, b, c, d):
        return arrays.blocks([[a, b], [c, d]])
    shape = np.broadcast_shapes(a.shape, b.shape, c.shape, d.shape)
    out = np.empty((*shape[:-2], 6, 6))
    out[..., :3, :3] = a
    out[..., :3, 3:] = b
    out[..., 3:, :3] = c
    out[..., 3:, 3:] = d
    return out


#: Batch elements per block in :func:`_blocked` (the temporaries of a block stay in cache).
_BLOCK = 4096


def _blocked(
    kernel: Callable[[FloatArray], FloatArray],
    x: FloatArray,
    core_in: int,
    core_out: tuple[int, ...],
) -> FloatArray:
    """Apply ``kernel`` to a large batch in blocks of :data:`_BLOCK` elements.

    The same kernel, evaluated on cache-sized slices of the flattened batch and written into one
    output: its many whole-vector operations then run on data in cache instead of streaming
    the full batch through memory each time. Small batches call the kernel directly.
    """
    if arrays.is_foreign(x):  # one expression on the device: no blocks
        return kernel(x)
    batch = x.shape[: x.ndim - core_in]
    n = x.size // max(1, int(np.prod(x.shape[x.ndim - core_in :])))
    if n <= 2 * _BLOCK:
        return kernel(x)
    flat = x.reshape((n, *x.shape[x.ndim - core_in :]))
    out = np.empty((n, *core_out))
    for start in range(0, n, _BLOCK):
        out[start : start + _BLOCK] = kernel(flat[start : start + _BLOCK])
    return out.reshape((*batch, *core_out))


def _exp(xi: FloatArray) -> FloatArray:
    out = _compiled.run_any_layout(_compiled.SE3_EXP, xi)
    return out if out is not None else _blocked(_exp_block, xi, 1, (4, 4))


def _log(T: FloatArray) -> FloatArray:
    out = _compiled.run_any_layout(_compiled.SE3_LOG, T)
    return out if out is not None else _blocked(_log_block, T, 2, (6,))


def _exp_block(xi: FloatArray) -> FloatArray:
    """``Exp(ξ)`` written entry by entry on batch-length vectors (see ``so3._poly_entries``).

    ``R = I + A·hat(ω) + B·hat(ω)²``; ``t = V(ω)·v = A·v + B·ω × v + C·(ω·v)·ω`` (from
    ``V = I + B·hat(ω) + C·hat(ω)²``, ``hat(ω)² = ωωᵀ − θ²I`` and ``1 − Cθ² = A``).
    """
    w, v0, v1, v2 = xi[..., :3], xi[..., 3], xi[..., 4], xi[..., 5]
    w0, w1, w2 = xi[..., 0], xi[..., 1], xi[..., 2]
    th, t2 = angle(w)
    A, B, C = sinc(th, t2), one_minus_cos_over_t2(th, t2), t_minus_sin_over_t3(th, t2)
    r = so3._poly_entries(w, A, B)
    Bw0, Bw1, Bw2 = B * w0, B * w1, B * w2
    Cd = C * (w0 * v0 + w1 * v1 + w2 * v2)
    t = [
        A * v0 + (Bw1 * v2 - Bw2 * v1) + Cd * w0,
        A * v1 + (Bw2 * v0 - Bw0 * v2) + Cd * w1,
        A * v2 + (Bw0 * v1 - Bw1 * v0) + Cd * w2,
    ]
    return arrays.matrix([*r[0:3], t[0], *r[3:6], t[1], *r[6:9], t[2], 0.0, 0.0, 0.0, 1.0], 4, 4)


def _log_block(T: FloatArray) -> FloatArray:
    """``(ω, V(ω)⁻¹ t)``; ``V⁻¹ t = t − ½·ω × t + D·ω × (ω × t)`` on batch-length vectors."""
    w = so3._log(T[..., :3, :3])
    w0, w1, w2 = w[..., 0], w[..., 1], w[..., 2]
    t0, t1, t2 = T[..., 0, 3], T[..., 1, 3], T[..., 2, 3]
    D = jinv_coeff(*angle(w))
    c0, c1, c2 = w1 * t2 - w2 * t1, w2 * t0 - w0 * t2, w0 * t1 - w1 * t0  # ω × t
    u = [
        t0 - 0.5 * c0 + D * (w1 * c2 - w2 * c1),
        t1 - 0.5 * c1 + D * (w2 * c0 - w0 * c2),
        t2 - 0.5 * c2 + D * (w0 * c1 - w1 * c0),
    ]
    if arrays.is_foreign(T):
        xp = arrays.namespace(T)
        return xp.concat([w, xp.stack(u, axis=-1)], axis=-1)
    out = np.empty((*T.shape[:-2], 6))
    out[..., :3] = w
    out[..., 3], out[..., 4], out[..., 5] = u
    return out


def _inverse(T: FloatArray) -> FloatArray:
    Rt = arrays.mT(T[..., :3, :3])
    return _assemble(Rt, -arrays.matvec(Rt, T[..., :3, 3]))


def _adjoint(T: FloatArray) -> FloatArray:
    R = T[..., :3, :3]
    return _blocks(R, 0.0 * R, so3._hat(T[..., :3, 3]) @ R, R)


def _q(w: FloatArray, v: FloatArray) -> FloatArray:
    """Barfoot's ``Q(ρ = v, φ = w)`` (lower-left block of SE(3)'s left Jacobian), closed form.

    The textbook form sums products of ``P = hat(w)`` and ``U = hat(v)``:
    ``Q = ½U + c₁(PU + UP + PUP) + c₂(P²U + UP² − 3PUP) + c₃(PUP² + P²UP)``
    (``c₁ = (θ − sin θ)/θ³``, ``c₂``, ``c₃`` from :mod:`liebridge.lie.series`). With
    ``hat(a)·hat(b) = b·aᵀ − (a·b)·I``, ``s = w·v`` and ``a·bᵀ − b·aᵀ = hat(b × a)`` it is a
    symmetric part plus a skew one, each a few outer products instead of eight batched 3×3
    matrix products::

        Q = c₁(v wᵀ + w vᵀ) − 2c₃s·w wᵀ + 2s(c₃θ² − c₁)·I + hat((½ − c₂θ²)·v + s(2c₂ − c₁)·w)
    """
    th, th2 = angle(w)
    c1 = t_minus_sin_over_t3(th, th2)
    c2 = q_coeff2(th, th2)
    c3 = q_coeff3(th, th2)
    w0, w1, w2 = w[..., 0], w[..., 1], w[..., 2]
    v0, v1, v2 = v[..., 0], v[..., 1], v[..., 2]
    s = w0 * v0 + w1 * v1 + w2 * v2
    diag = 2.0 * s * (c3 * th2 - c1)
    ka, kb = 0.5 - c2 * th2, s * (2.0 * c2 - c1)
    u0, u1, u2 = ka * v0 + kb * w0, ka * v1 + kb * w1, ka * v2 + kb * w2
    m = -2.0 * c3 * s
    w_, v_ = (w0, w1, w2), (v0, v1, v2)
    sym = [
        [c1 * (v_[i] * w_[j] + w_[i] * v_[j]) + m * w_[i] * w_[j] for j in range(3)]
        for i in range(3)
    ]
    return arrays.matrix(
        [
            sym[0][0] + diag, sym[0][1] - u2, sym[0][2] + u1,
            sym[1][0] + u2, sym[1][1] + diag, sym[1][2] - u0,
            sym[2][0] - u1, sym[2][1] + u0, sym[2][2] + diag,
        ],
        3,
        3,
    )  # fmt: skip


def _jl(xi: FloatArray) -> FloatArray:
    w = xi[..., :3]
    J = so3._jl(w)
    return _blocks(J, 0.0 * J, _q(w, xi[..., 3:]), J)


def _jl_inv(xi: FloatArray) -> FloatArray:
    w = xi[..., :3]
    Ji = so3._jl_inv(w)
    return _blocks(Ji, 0.0 * Ji, -Ji @ _q(w, xi[..., 3:]) @ Ji, Ji)


def hat(xi: Any) -> FloatArray:
    """Map a twist ``(ω, v)`` ``(..., 6)`` to ``[[hat(ω), v], [0, 0]]``, ``(..., 4, 4)``."""
    xi = validate.vector(xi, "xi", 6)
    x, y, z, a, b, c = (xi[..., k] for k in range(6))
    return arrays.matrix([0.0, -z, y, a, z, 0.0, -x, b, -y, x, 0.0, c, 0.0, 0.0, 0.0, 0.0], 4, 4)


def vee(X: Any) -> FloatArray:
    """Inverse of :func:`hat`: ``(..., 4, 4)`` → ``(ω, v)`` ``(..., 6)``."""
    X = validate.square(X, "X", 4)
    return arrays.concat([so3.vee(X[..., :3, :3]), X[..., :3, 3]], axis=-1)


def exp(xi: Any) -> FloatArray:
    """SE(3) exponential of ``ξ = (ω, v)`` ``(..., 6)`` → ``(..., 4, 4)``.

    ``Exp(ξ) = [[Exp(ω), V(ω) v], [0, 1]]`` with ``V = so3.jl``. GTSAM ``Pose3.Expmap``.
    """
    out = (
        None if arrays.is_foreign(xi) else _compiled.run(_compiled.SE3_EXP, xi)
    )  # the compiled pass where built, else None
    if out is not None:
        return out
    return validate.finite_output(_exp(validate.tangent(xi, "xi", 6)), "se3.exp")


def log(T: Any) -> FloatArray:
    """SE(3) logarithm ``(..., 4, 4)`` → ``(ω, v)`` ``(..., 6)``, ``‖ω‖ ∈ [0, π]``.

    ``ω = so3.log(R)``, ``v = V(ω)⁻¹ t`` with ``V⁻¹ = so3.jl_inv`` (finite up to θ = π).
    GTSAM ``Pose3.Logmap``.
    """
    out = (
        None if arrays.is_foreign(T) else _compiled.run(_compiled.SE3_LOG, T)
    )  # the compiled pass where built, else None
    if out is not None:
        return out
    return validate.finite_output(_log(validate.pose(T, "T")), "se3.log")


def inverse(T: Any) -> FloatArray:
    """Group inverse ``[[Rᵀ, −Rᵀ t], [0, 1]]``: ``inverse(T_world_body) = T_body_world``."""
    return validate.finite_output(_inverse(validate.pose(T, "T")), "se3.inverse")


def compose(T1: Any, T2: Any) -> FloatArray:
    """Group product ``T1·T2`` (broadcast): ``compose(T_a_b, T_b_c) = T_a_c``."""
    return _mg.compose(T1, T2, validate.pose, ("T1", "T2"), "se3.compose")


def act(T: Any, p: Any) -> FloatArray:
    """Apply ``T`` to points: ``R p + t``; ``act(T_world_body, p_body) = p_world``, ``(..., 3)``."""
    return _mg.act(T, p, validate.pose, 3, ("T", "p"), "se3.act")


def adjoint(T: Any) -> FloatArray:
    """Adjoint ``Ad_T = [[R, 0], [hat(t) R, R]]`` in (ω, v), ``(..., 6, 6)``.

    Defining identity: ``T·Exp(ξ)·T⁻¹ = Exp(Ad_T ξ)``; ``Ad_{T1 T2} = Ad_{T1} Ad_{T2}``.
    GTSAM ``Pose3.AdjointMap``.
    """
    out = (
        None if arrays.is_foreign(T) else _compiled.run(_compiled.SE3_ADJOINT, T)
    )  # the compiled pass where built, else None
    if out is not None:
        return out
    return validate.finite_output(_adjoint(validate.pose(T, "T")), "se3.adjoint")


def ad(xi: Any) -> FloatArray:
    """Small adjoint ``ad_ξ = [[hat(ω), 0], [hat(v), hat(ω)]]`` in (ω, v), ``(..., 6, 6)``.

    ``ad_ξ η = [ξ, η]`` (Lie bracket); ``d/ds Ad(Exp(sξ))|₀ = ad_ξ``. GTSAM ``Pose3.adjointMap``.
    """
    xi = validate.vector(xi, "xi", 6)
    W = so3._hat(xi[..., :3])
    return _blocks(W, arrays.zeros(tuple(W.shape), W), so3._hat(xi[..., 3:]), W)


def jr(xi: Any) -> FloatArray:
    """Right Jacobian ``Exp(ξ + δ) ≈ Exp(ξ)·Exp(jr(ξ) δ)``, ``(..., 6, 6)``; ``jr(ξ) = jl(−ξ)``."""
    x = validate.tangent(xi, "xi", 6)
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported just below
        out = _jl(-x)
    return validate.finite_output(out, "se3.jr")


def jl(xi: Any) -> FloatArray:
    """Left Jacobian ``Exp(ξ + δ) ≈ Exp(jl(ξ) δ)·Exp(ξ)``, ``(..., 6, 6)``, Barfoot's Q-form."""
    x = validate.tangent(xi, "xi", 6)
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported just below
        out = _jl(x)
    return validate.finite_output(out, "se3.jl")


def jr_inv(xi: Any) -> FloatArray:
    """Inverse right Jacobian (closed-form block inverse); GTSAM ``Pose3.LogmapDerivative``."""
    x = validate.tangent(xi, "xi", 6)
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported just below
        out = _jl_inv(-x)
    return validate.finite_output(out, "se3.jr_inv")


def jl_inv(xi: Any) -> FloatArray:
    """Inverse left Jacobian (closed-form block inverse), ``(..., 6, 6)``."""
    x = validate.tangent(xi, "xi", 6)
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported just below
        out = _jl_inv(x)
    return validate.finite_output(out, "se3.jl_inv")


def interpolate(T0: Any, T1: Any, tau: Any) -> FloatArray:
    """Geodesic interpolation ``T0·Exp(τ·Log(T0⁻¹ T1))``; ``τ = 0 → T0``, ``τ = 1 → T1``.

    ``tau`` broadcasts against the batch shape of ``T0``/``T1``; values outside [0, 1]
    extrapolate along the same screw.
    """
    ops = (_log, _exp, _inverse)

    def tangent(xi: Any, name: str) -> FloatArray:
        return validate.tangent(xi, name, 6)

    return _mg.interpolate(
        T0, T1, tau, validate.pose, tangent, ops, ("T0", "T1"), "se3.interpolate"
    )


# ----------------------------------------------------------------------------- the record
def _jr(xi: FloatArray) -> FloatArray:
    return _jl(-xi)


def _jr_inv(xi: FloatArray) -> FloatArray:
    return _jl_inv(-xi)


GROUP = register_shipped(
    Group(
        name="se3", dim=6, matrix=4, rot=slice(0, 3), vecs=(slice(3, 6),), cols=(3,),
        scale=None, element=validate.pose,
        kernels=Kernels(
            exp=_exp, log=_log, inverse=_inverse, adjoint=_adjoint, jr_inv=_jr_inv,
            jl_inv=_jl_inv, jr=_jr, jl=_jl,
        ),
        charts=("se3", "so3xr3_body", "so3xr3_world"),
        chart_aliases={"split_body": "so3xr3_body", "split_world": "so3xr3_world"},
        probe=_exp(np.array([0.4, -0.7, 0.5, 1.5, -2.0, 0.8])), label="SE(3)",
        note="and SO(3): a 3×3 rotation given to these",
        tangent_doc="(ω, v)",
        array_api=True,
    )
)  # fmt: skip
