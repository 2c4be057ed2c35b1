"""liebridge: explicit Lie-group conventions and exact translation between them.

The canonical form is GTSAM's: poses ``(..., 4, 4)``, rotation-first twists ``ξ = (ω, v)``,
right perturbation ``X·Exp(ξ)``, true SE(3) exponential.
"""

from . import check, conventions, lie
from .adapters import (
    convert_covariance,
    convert_information,
    convert_jacobian,
    convert_tangent,
    is_exactly_linear,
    tangent_map,
)
from .conventions import Convention, detect_convention

__version__ = "0.1.0"

__all__ = [
    "Convention",
    "__version__",
    "check",
    "conventions",
    "convert_covariance",
    "convert_information",
    "convert_jacobian",
    "convert_tangent",
    "detect_convention",
    "is_exactly_linear",
    "lie",
    "tangent_map",
]
