"""The conversion functions and file formats under the import path of earlier releases (a façade).

Old path: ``lb.adapters`` keeps working; new code writes ``lb.conventions`` and ``lb.io``.

The code lives in :mod:`liebridge.conventions` (``tangent_map``, ``convert_*``,
``is_exactly_linear``) and :mod:`liebridge.io` (``g2o``, ``poses``, ``trajectory``).
"""

from ..conventions import (
    convert_covariance,
    convert_information,
    convert_jacobian,
    convert_tangent,
    is_exactly_linear,
    tangent_map,
)
from ..io import g2o, poses
from ..io import trajectory as trajectory_io

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
