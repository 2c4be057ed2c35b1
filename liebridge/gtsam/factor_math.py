"""The residual and Jacobians of liebridge's between/prior factors, batched: the one code path.

A factor's measurement ``Z`` is a pose (convention-free); its convention says what the residual
is: ``e = conv.local(Z, H)`` with ``H = T_i⁻¹·T_j`` (between) or ``H = T_i`` (prior). The Jacobians
are taken with respect to **GTSAM's** perturbation of each variable (``T·Exp(ξ)``, ξ = (ω, v)),
because GTSAM retracts its variables its own way, whatever the convention of the residual:

``J_j = D·M(H)`` and ``J_i = −D·M(H)·Ad(H⁻¹)`` (between), ``J = D·M(H)`` (prior), with
``D = conv.local_jacobian(Z, H)`` (in the convention's own chart at ``H``) and
``M(H) = conv.from_canonical(H)`` (GTSAM's tangent → the convention's). For the ``gtsam`` preset
this is GTSAM's own ``H2 = Jr⁻¹(e)``, ``H1 = −Jr⁻¹(e)·Ad(H⁻¹)``
(``BetweenFactor::evaluateError`` with ``Pose3::between``/``Logmap`` derivatives,
``gtsam/slam/BetweenFactor.h``). Tempting and false: ``(−Ad(H⁻¹), I)`` — exact only at zero
residual.

The same formulas hold in every matrix Lie group with GTSAM's right perturbation ``X·Exp(ξ)``
(to first order: GTSAM's ``NavState.retract`` is the split body chart, which agrees with
``X·Exp(ξ)`` to first order, so Jacobian columns are the same): ``Pose2`` (ξ = (vx, vy, ω)),
``Similarity3`` (ξ = (ω, u, λ)), ``NavState`` (ξ = (ω, ρ_p, ρ_v)). The group is the convention's
(``conv.group``); inverse and adjoint come from :mod:`liebridge.lie.unchecked`. For a convention
with an embedding (``ros_pose2``: (x, y, yaw) inside ROS's 6-vector) the residual is the group's
coordinates of the convention's tangent (its ``embed.index`` entries, in that order).

Every array has leading batch dimensions: the single-factor GTSAM callback passes a batch of one,
the optimizer's batched evaluation passes all factors of one (kind, convention) group.
No validation here (:mod:`liebridge.conventions.unchecked`): the factor constructors validate.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .._validate import FloatArray
from ..conventions import Convention, unchecked
from ..lie import series
from ..lie import unchecked as U

Fn = Callable[[FloatArray], FloatArray]

#: group -> (unchecked inverse, unchecked adjoint in GTSAM's tangent order)
GROUP_OPS: dict[str, tuple[Fn, Fn]] = {
    "se3": (U.se3_inverse, U.se3_adjoint),
    "se2": (U.se2_inverse, U.se2_adjoint),
    "sim3": (U.sim3_inverse, U.sim3_adjoint),
    "se23": (U.se23_inverse, U.se23_adjoint),
}


def _ops(conv: Convention) -> tuple[Fn, Fn]:
    return GROUP_OPS[conv.group]


def relative(T_world_i: FloatArray, T_world_j: FloatArray | None, group: str = "se3") -> FloatArray:
    """``H = T_i⁻¹·T_j`` for a between factor, ``T_i`` for a prior (``T_world_j`` None)."""
    if T_world_j is None:
        return T_world_i
    return GROUP_OPS[group][0](T_world_i) @ T_world_j


def _rows(conv: Convention, A: FloatArray) -> FloatArray:
    """Pick the group's coordinates (an embedding's rows) of a convention-tangent array."""
    if conv.embed is None:
        return A
    return np.asarray(A[..., list(conv.embed.index), :], dtype=np.float64)


def residual(conv: Convention, Z: FloatArray, H: FloatArray) -> FloatArray:
    """``e = conv.local(Z, H)``, ``(..., n)`` in the convention's order and coordinates."""
    e = unchecked.local(conv, Z, H)
    return e if conv.embed is None else _rows(conv, e[..., None])[..., 0]


def jacobians(
    conv: Convention, Z: FloatArray, H: FloatArray, between: bool
) -> tuple[FloatArray, FloatArray | None]:
    """``(J_e_i, J_e_j)`` in GTSAM's tangent columns; ``J_e_j`` is None for a prior.

    For a prior, ``J_e_i = D·M(H)``; for a between factor ``J_e_j = D·M(H)`` and
    ``J_e_i = −J_e_j·Ad(H⁻¹)`` (see the module docstring).
    """
    J_e_H = _rows(conv, unchecked.local_jacobian(conv, Z, H) @ unchecked.from_canonical(conv, H))
    if not between:
        return J_e_H, None
    inverse, adjoint = _ops(conv)
    return -J_e_H @ adjoint(inverse(H)), J_e_H


# ------------------------------------------------------------------ SE(3)-exponential charts
# Conventions whose chart is the SE(3) exponential (``gtsam``, ``barfoot``, ``sophus``, ``manif``:
# ``conv.chart == "se3"``) differ only in side and storage order, and the formulas above then
# share one logarithm. With ``ξ = Log(Z⁻¹H)`` (right) or ``Log(H·Z⁻¹)`` (left), in (ω, v):
#
# * right: ``e = P·ξ``, ``J_j = P·Jr⁻¹(ξ)``, ``J_i = −J_j·Ad(H⁻¹)`` (``D·M = P·Jr⁻¹(ξ)·Pᵀ·P``);
# * left:  ``e = P·ξ``, ``J_j = P·Jl⁻¹(ξ)·Ad(H)``, ``J_i = −P·Jl⁻¹(ξ)`` (``M(H) = P·Ad(H)``, and
#   ``Ad(H)·Ad(H⁻¹) = I``);
#
# ``P`` the storage-order permutation, folded into the square-root information by the caller
# (``R·e = (R·P)·ξ``). The same numbers as :func:`residual` and :func:`jacobians` (tested to
# 1e-12), in one pass: the generic path recomputes the logarithm inside ``local_jacobian``.


def is_se3_chart(conv: Convention) -> bool:
    """Tell whether ``conv`` is an SE(3) convention with the exponential chart (fused path)."""
    return conv.group == "se3" and conv.chart == "se3" and conv.embed is None and not conv.generic


def order_permutation(conv: Convention) -> list[int]:
    """Return the indices ``p`` with ``e = ξ[p]`` (ξ in GTSAM's (ω, v) order)."""
    return [0, 1, 2, 3, 4, 5] if conv.order == "rot_first" else [3, 4, 5, 0, 1, 2]


def se3_q(w: FloatArray, v: FloatArray) -> FloatArray:
    """Barfoot's ``Q(ρ = v, φ = w)`` (lower-left block of SE(3)'s left Jacobian), closed form.

    ``liebridge.lie.se3`` sums products of ``P = hat(w)`` and ``U = hat(v)``:
    ``Q = ½U + c₁(PU + UP + PUP) + c₂(P²U + UP² − 3PUP) + c₃(PUP² + P²UP)``
    (``c₁ = (θ − sin θ)/θ³``, ``c₂``, ``c₃`` from :mod:`liebridge.lie.series`). With
    ``hat(a)·hat(b) = b·aᵀ − (a·b)·I``, ``s = w·v`` and ``a·bᵀ − b·aᵀ = hat(b × a)`` it is a
    symmetric part plus a skew one, each a few outer products instead of eight batched 3×3
    matrix products::

        Q = c₁(v wᵀ + w vᵀ) − 2c₃s·w wᵀ + 2s(c₃θ² − c₁)·I + hat((½ − c₂θ²)·v + s(2c₂ − c₁)·w)
    """
    th2 = np.einsum("...i,...i->...", w, w)
    th = np.sqrt(th2)
    c1 = series.t_minus_sin_over_t3(th)
    c2 = series.q_coeff2(th)
    c3 = series.q_coeff3(th)
    s = np.einsum("...i,...i->...", w, v)
    wv = w[..., :, None] * v[..., None, :]
    out = c1[..., None, None] * (wv + np.swapaxes(wv, -1, -2))
    out -= (2.0 * c3 * s)[..., None, None] * (w[..., :, None] * w[..., None, :])
    diag = 2.0 * s * (c3 * th2 - c1)
    for k in range(3):
        out[..., k, k] += diag
    u = (0.5 - c2 * th2)[..., None] * v + (s * (2.0 * c2 - c1))[..., None] * w
    out[..., 0, 1] -= u[..., 2]
    out[..., 0, 2] += u[..., 1]
    out[..., 1, 0] += u[..., 2]
    out[..., 1, 2] -= u[..., 0]
    out[..., 2, 0] -= u[..., 1]
    out[..., 2, 1] += u[..., 0]
    return out


def se3_jl_inv(xi: FloatArray) -> FloatArray:
    """SE(3) ``Jl⁻¹(ξ)``, ξ = (ω, v): ``[[Jl⁻¹(ω), 0], [−Jl⁻¹(ω)·Q·Jl⁻¹(ω), Jl⁻¹(ω)]]``."""
    w = xi[..., :3]
    Ji = U.so3_jl_inv(w)
    out = np.zeros((*xi.shape[:-1], 6, 6))
    out[..., :3, :3] = Ji
    out[..., 3:, 3:] = Ji
    out[..., 3:, :3] = -Ji @ se3_q(w, xi[..., 3:]) @ Ji
    return out


def se3_chart_log(conv: Convention, Z_inv: FloatArray, H: FloatArray) -> FloatArray:
    """``ξ = Log(Z⁻¹H)`` (right side) or ``Log(H·Z⁻¹)`` (left), (ω, v); ``e = ξ[perm]``."""
    return U.se3_log(Z_inv @ H if conv.side == "right" else H @ Z_inv)


def se3_chart_jacobians(
    conv: Convention,
    xi: FloatArray,
    H: FloatArray,
    between: bool,
    sqrt_info: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray | None]:
    """``(W·J_ξ_i, W·J_ξ_j)``: ξ's Jacobians (GTSAM's (ω, v) rows) in GTSAM's tangent columns.

    ``W = sqrt_info`` (``(..., m, 6)``, e.g. ``R·P`` to whiten the convention's residual) or the
    identity; rows are then ξ's, not the convention's (``J_e = J_ξ[perm]``). The second entry is
    None for a prior (``H = T_i``: the first is then ``W·J_ξ_H``). ``W`` is applied before the
    adjoint: one batched product fewer than whitening afterwards.
    """
    left = conv.side == "left"
    W = se3_jl_inv(xi if left else -xi)  # Jl⁻¹(ξ), or Jr⁻¹(ξ) = Jl⁻¹(−ξ)
    if sqrt_info is not None:
        W = sqrt_info @ W
    if left:
        J_H = W @ U.se3_adjoint(H)
        return (-W, J_H) if between else (J_H, None)
    if not between:
        return W, None
    return -(W @ U.se3_adjoint(U.se3_inverse(H))), W
