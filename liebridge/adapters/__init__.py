"""Translation of tangents, covariances, information matrices and Jacobians between conventions.

The conversion functions are re-exported at the top level (``liebridge.tangent_map`` ...).
"""

from . import g2o, poses, trajectory_io
from .convert import (
    convert_covariance,
    convert_information,
    convert_jacobian,
    convert_tangent,
    is_exactly_linear,
    tangent_map,
)

__all__ = [
    "convert_covariance",
    "convert_information",
    "convert_jacobian",
    "convert_tangent",
    "g2o",
    "is_exactly_linear",
    "poses",
    "tangent_map",
    "trajectory_io",
]
