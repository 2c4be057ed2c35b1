"""liebridge: explicit Lie-group conventions and exact translation between them.

The canonical form is GTSAM's: poses ``(..., 4, 4)``, rotation-first twists ``ξ = (ω, v)``,
right perturbation ``X·Exp(ξ)``, true SE(3) exponential.

The numpy core (``lie``, ``conventions``, the conversion functions, ``poses``, ``g2o`` reading,
``trajectory_io``, ``check``) does not import gtsam; ``gtsam_glue``, ``marginals``,
``ConventionGraph``, ``gtsam_convention`` and ``factors`` load it on first access.
"""

from typing import Any

from . import check, conventions, doctor, interop, io, lie
from .conventions import (
    Convention,
    convert_covariance,
    convert_information,
    convert_jacobian,
    convert_tangent,
    detect_convention,
    is_exactly_linear,
    tangent_map,
)
from .io import g2o, poses
from .io import trajectory as trajectory_io

__version__ = "0.1.0"

__all__ = [
    "Convention",
    "ConventionGraph",
    "__version__",
    "batch",
    "check",
    "conventions",
    "convert_covariance",
    "convert_information",
    "convert_jacobian",
    "convert_tangent",
    "detect_convention",
    "doctor",
    "factors",
    "g2o",
    "gtsam",
    "gtsam_convention",
    "gtsam_glue",
    "imu",
    "interop",
    "io",
    "is_exactly_linear",
    "lie",
    "marginals",
    "poses",
    "registration",
    "tangent_map",
    "trajectory_io",
]


def __getattr__(name: str) -> Any:
    """Load the GTSAM-dependent parts on first access."""
    import importlib

    lazy = {
        "gtsam_glue": ("liebridge.gtsam.glue", None),
        "batch": ("liebridge.batch", None),
        "factors": ("liebridge.factors", None),
        "imu": ("liebridge.imu", None),
        "gtsam": ("liebridge.gtsam", None),
        "registration": ("liebridge.registration", None),
        "ConventionGraph": ("liebridge.gtsam.graph", "ConventionGraph"),
        "marginals": ("liebridge.gtsam.marginals", "marginals"),
        "gtsam_convention": ("liebridge.gtsam.build", "gtsam_convention"),
    }
    if name not in lazy:
        raise AttributeError(f"module 'liebridge' has no attribute {name!r}")
    module, attr = lazy[name]
    mod = importlib.import_module(module)
    return mod if attr is None else getattr(mod, attr)
