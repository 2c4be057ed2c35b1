"""A user's module with a Jacobian copied from a paper in the other tangent order.

Run the doctor on it from the repository root::

    liebridge doctor jacobian examples/doctor_user_jacobian.py:transform

The module defines what the command reads: the function (``transform``), its Jacobian
(``transform_jacobian``), where to check it (``transform_point``) and the solver's convention
(``solver_convention``). The Jacobian below is the right-perturbation one in (v, ω) order —
Sophus's tangent — while the solver is GTSAM, whose tangent is (ω, v): the doctor says so and
gives the fix.
"""

from __future__ import annotations

import numpy as np

from liebridge.lie import se3, so3

P_BODY = np.array([0.5, -1.0, 2.0])

#: GTSAM retracts T·Exp(δ) with δ = (ω, v).
solver_convention = "gtsam"

#: A generic pose (never the identity: left and right agree there).
transform_point = se3.exp(np.array([0.3, -0.2, 0.1, 1.0, 2.0, 3.0]))


def transform(T_world_body: np.ndarray) -> np.ndarray:
    """``p_world = T_world_body · p_body``."""
    return T_world_body[:3, :3] @ P_BODY + T_world_body[:3, 3]


def transform_jacobian(T_world_body: np.ndarray) -> np.ndarray:
    """``∂p_world/∂δ`` for ``T·Exp(δ)``, written in (v, ω) order: ``[R, −R·hat(p)]``."""
    R = T_world_body[:3, :3]
    return np.hstack([R, -R @ so3.hat(P_BODY)])
