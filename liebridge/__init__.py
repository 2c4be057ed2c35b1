"""liebridge: explicit Lie-group conventions and exact translation between them.

The canonical form is GTSAM's: poses ``(..., 4, 4)``, rotation-first twists ``ξ = (ω, v)``,
right perturbation ``X·Exp(ξ)``, true SE(3) exponential.

The packages, one floor each (``docs/design.md``): ``lb.lie`` (group kernels),
``lb.conventions`` (conventions as data and the conversions), ``lb.uncertain`` (uncertain
poses), ``lb.io`` (pose layouts, TUM/KITTI/EuRoC, g2o), ``lb.check``, ``lb.frames``, ``lb.traj``
(trajectory evaluation), ``lb.gtsam`` (the hub's glue, factors, optimizer, iSAM2), ``lb.imu``
and ``lb.ros`` (messages and bags; the ``ros`` extra is imported when a bag is opened).

The numpy core (``lie``, ``conventions``, ``io``, ``check``) is imported with ``liebridge``;
``uncertain``, ``frames``, ``traj``, ``ros``, ``gtsam``, ``imu`` load on first access, so
``import liebridge`` does not import gtsam. The old spellings ``lb.factors``, ``lb.adapters``,
``lb.g2o``, ``lb.poses``, ``lb.trajectory_io``, ``lb.gtsam_glue``, ``lb.marginals``,
``lb.ConventionGraph`` and ``lb.gtsam_convention`` keep working.
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
    "adapters",
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
    "frames",
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
    "ros",
    "tangent_map",
    "traj",
    "trajectory_io",
    "uncertain",
]

#: Names loaded on first access: ``(module, attribute or None for the module itself)``.
_LAZY: dict[str, tuple[str, str | None]] = {
    "uncertain": ("liebridge.uncertain", None),
    "frames": ("liebridge.frames", None),
    "traj": ("liebridge.traj", None),
    "ros": ("liebridge.ros", None),
    "adapters": ("liebridge.adapters", None),
    "gtsam_glue": ("liebridge.gtsam.glue", None),
    "factors": ("liebridge.factors", None),
    "imu": ("liebridge.imu", None),
    "gtsam": ("liebridge.gtsam", None),
    "ConventionGraph": ("liebridge.gtsam.graph", "ConventionGraph"),
    "marginals": ("liebridge.gtsam.marginals", "marginals"),
    "gtsam_convention": ("liebridge.gtsam.build", "gtsam_convention"),
    "batch": ("liebridge.batch", None),
    "registration": ("liebridge.registration", None),
}


def __getattr__(name: str) -> Any:
    """Load the packages that import gtsam, scipy or an extra on first access."""
    import importlib

    if name not in _LAZY:
        raise AttributeError(f"module 'liebridge' has no attribute {name!r}")
    module, attr = _LAZY[name]
    mod = importlib.import_module(module)
    return mod if attr is None else getattr(mod, attr)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
