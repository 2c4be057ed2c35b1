"""Batched SO(3)/SE(3)/quaternion kernel in canonical (GTSAM) form.

``so3`` and ``se3`` take rotation-first tangents ``(ω, v)``, right Jacobians ``jr`` and left
``jl``; ``quaternion`` always takes an explicit storage ``order``.
"""

from . import quaternion, se3, so3
from .series import SMALL_ANGLE

__all__ = ["SMALL_ANGLE", "quaternion", "se3", "so3"]
