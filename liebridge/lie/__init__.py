"""Batched Lie-group kernels in canonical (GTSAM) form, one module per group, one record each.

Every group is declared once, in ``lie/<group>.py``, as a :class:`Group` record registered in
:data:`GROUPS`; every other layer reads the record (:func:`group`). A user adds a group with
:func:`register` (see ``docs/design.md``, "Extending liebridge").

``so2``, ``se2``, ``so3``, ``se3``, ``sim3``, ``se23`` share the function names ``exp, log, hat,
vee, jr, jl, jr_inv, jl_inv, adjoint, compose, inverse, act, interpolate`` (the record's methods
are the same functions for any registered group); each group's tangent order is GTSAM's
(``Rot2`` θ; ``Pose2`` (vx, vy, ω); ``Rot3`` ω; ``Pose3`` (ω, v); ``Similarity3`` (ω, u, λ);
``NavState`` (ω, ρ_p, ρ_v)). ``quaternion`` always takes an explicit storage ``order``.
"""

from . import quaternion, s2, se2, se3, se23, sim3, so2, so3
from .record import GROUPS, KERNEL_NAMES, Group, Kernels, group, register
from .series import SMALL_ANGLE

__all__ = [
    "GROUPS",
    "KERNEL_NAMES",
    "SMALL_ANGLE",
    "Group",
    "Kernels",
    "group",
    "quaternion",
    "register",
    "s2",
    "se2",
    "se3",
    "se23",
    "sim3",
    "so2",
    "so3",
]
