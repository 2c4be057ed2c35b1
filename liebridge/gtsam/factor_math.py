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

Every array has leading batch dimensions: the single-factor GTSAM callback passes a batch of one,
the optimizer's batched evaluation passes all factors of one (kind, convention) group.
No validation here (:mod:`liebridge.conventions.unchecked`): the factor constructors validate.
"""

from __future__ import annotations

from .._validate import FloatArray
from ..conventions import Convention, unchecked
from ..lie import unchecked as U


def relative(T_world_i: FloatArray, T_world_j: FloatArray | None) -> FloatArray:
    """``H = T_i⁻¹·T_j`` for a between factor, ``T_i`` for a prior (``T_world_j`` None)."""
    if T_world_j is None:
        return T_world_i
    return U.se3_inverse(T_world_i) @ T_world_j


def residual(conv: Convention, Z: FloatArray, H: FloatArray) -> FloatArray:
    """``e = conv.local(Z, H)``, ``(..., 6)`` in the convention's order and coordinates."""
    return unchecked.local(conv, Z, H)


def jacobians(
    conv: Convention, Z: FloatArray, H: FloatArray, between: bool
) -> tuple[FloatArray, FloatArray | None]:
    """``(J_e_i, J_e_j)`` in GTSAM's tangent columns; ``J_e_j`` is None for a prior.

    For a prior, ``J_e_i = D·M(H)``; for a between factor ``J_e_j = D·M(H)`` and
    ``J_e_i = −J_e_j·Ad(H⁻¹)`` (see the module docstring).
    """
    J_e_H = unchecked.local_jacobian(conv, Z, H) @ unchecked.from_canonical(conv, H)
    if not between:
        return J_e_H, None
    return -J_e_H @ U.se3_adjoint(U.se3_inverse(H)), J_e_H
