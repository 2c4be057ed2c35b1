"""GTSAM glue: ``Values`` ↔ arrays, marginals in any convention, factors, the optimizer.

Layer above :mod:`liebridge.conventions`, :mod:`liebridge.check` and :mod:`liebridge.io`; below
:mod:`liebridge.imu` and the command line. ``glue`` moves poses between numpy and ``gtsam.Values``;
``build`` measures which preset the installed GTSAM build implements; ``marginals`` converts
``gtsam.Marginals`` to any convention; ``pose_factors`` builds between/prior factors in any
convention, whose residual maths lives once in ``factor_math``; ``optimize`` runs
Levenberg–Marquardt from Python and evaluates liebridge's factors batched; ``graph`` is
:class:`ConventionGraph`, a factor graph whose measurements carry their convention; ``isam2``
is :class:`ISAM2`, GTSAM's iSAM2 with liebridge's factors linearized batched; ``autodiff`` is
:func:`autodiff_factor`, a factor from a residual written in JAX or torch (Jacobians by automatic
differentiation, batched by the optimizer; the framework is imported only when used).
"""

from .autodiff import autodiff_factor
from .build import gtsam_convention, gtsam_convention_of
from .glue import from_pose3, from_values, to_pose3, to_values
from .graph import ConventionGraph
from .groups import GTSAM_GROUPS, GtsamGroup, gtsam_group
from .groups import register as register_group
from .isam2 import ISAM2
from .marginals import marginals
from .optimize import OptimizeResult, optimize
from .pose_factors import between, prior
from .registration import registration_factor

__all__ = [
    "GTSAM_GROUPS",
    "ISAM2",
    "ConventionGraph",
    "GtsamGroup",
    "OptimizeResult",
    "autodiff_factor",
    "between",
    "from_pose3",
    "from_values",
    "gtsam_convention",
    "gtsam_convention_of",
    "gtsam_group",
    "marginals",
    "optimize",
    "prior",
    "register_group",
    "registration_factor",
    "to_pose3",
    "to_values",
]
