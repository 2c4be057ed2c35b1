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
