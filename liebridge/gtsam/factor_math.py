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
from ..lie import GROUPS, Group
from ..lie import group as lie_group

Fn = Callable[[FloatArray], FloatArray]


def _ops(conv: Convention) -> tuple[Fn, Fn]:
    """Return the group's unchecked inverse and adjoint (GTSAM's tangent order), from its record."""
    k = conv.record.kernels
    return k.inverse, k.adjoint


def relative(
    T_world_i: FloatArray, T_world_j: FloatArray | None, group: str | Group = "se3"
) -> FloatArray:
    """``H = T_i⁻¹·T_j`` for a between factor, ``T_i`` for a prior (``T_world_j`` None)."""
    if T_world_j is None:
        return T_world_i
    return lie_group(group).kernels.inverse(T_world_i) @ T_world_j


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


# ------------------------------------------------------------------ coupled charts
# Conventions whose chart is their group's own exponential (``gtsam``, ``barfoot``, ``sophus``,
# ``manif`` on SE(3); ``gtsam_pose2``, ``sophus_se2``, ... on the others) differ only in side and
# storage order, and the formulas above then share one logarithm. With ``ξ = Log(Z⁻¹H)`` (right)
# or ``Log(H·Z⁻¹)`` (left), in the group's canonical order:
#
# * right: ``e = P·ξ``, ``J_j = P·Jr⁻¹(ξ)``, ``J_i = −J_j·Ad(H⁻¹)`` (``D·M = P·Jr⁻¹(ξ)·Pᵀ·P``);
# * left:  ``e = P·ξ``, ``J_j = P·Jl⁻¹(ξ)·Ad(H)``, ``J_i = −P·Jl⁻¹(ξ)`` (``M(H) = P·Ad(H)``, and
#   ``Ad(H)·Ad(H⁻¹) = I``);
#
# ``P`` the storage-order permutation, folded into the square-root information by the caller
# (``R·e = (R·P)·ξ``). The same numbers as :func:`residual` and :func:`jacobians` (tested to
# 1e-12), read from the group record's kernels, in one pass: the general path recomputes the
# logarithm inside ``local_jacobian``.


def is_coupled_chart(conv: Convention) -> bool:
    """Tell whether ``conv`` uses its group's own exponential (one logarithm per factor)."""
    g = GROUPS.get(conv.group)
    return (
        g is not None
        and type(conv) is Convention
        and conv.embed is None
        and conv.chart == g.coupled_chart
        and conv.stores == "pose"  # a stored inverse (dpvo) takes the general path
    )


def order_permutation(conv: Convention) -> list[int]:
    """Return the indices ``p`` with ``e = ξ[p]`` (ξ in the group's canonical order)."""
    return [int(i) for i in conv.record.perm(conv.order)]


def coupled_chart_log(conv: Convention, Z_inv: FloatArray, H: FloatArray) -> FloatArray:
    """``ξ = Log(Z⁻¹H)`` (right side) or ``Log(H·Z⁻¹)`` (left), canonical order; ``e = ξ[perm]``."""
    return conv.record.kernels.log(Z_inv @ H if conv.side == "right" else H @ Z_inv)


def coupled_chart_jacobians(
    conv: Convention,
    xi: FloatArray,
    H: FloatArray,
    between: bool,
    sqrt_info: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray | None]:
    """``(W·J_ξ_i, W·J_ξ_j)``: ξ's Jacobians (canonical rows) in GTSAM's tangent columns.

    ``W = sqrt_info`` (``(..., m, n)``, e.g. ``R·P`` to whiten the convention's residual) or the
    identity; rows are then ξ's, not the convention's (``J_e = J_ξ[perm]``). The second entry is
    None for a prior (``H = T_i``: the first is then ``W·J_ξ_H``). ``W`` is applied before the
    adjoint: one batched product fewer than whitening afterwards.
    """
    k = conv.record.kernels
    left = conv.side == "left"
    W = k.jl_inv(xi) if left else k.jr_inv(xi)
    if sqrt_info is not None:
        W = sqrt_info @ W
    if left:
        J_H = W @ k.adjoint(H)
        return (-W, J_H) if between else (J_H, None)
    if not between:
        return W, None
    return -(W @ k.adjoint(k.inverse(H))), W
