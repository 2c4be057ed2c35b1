"""Convention descriptors as data, presets for real libraries, and detection.

>>> from liebridge import conventions as C
>>> C.SOPHUS.fields
('right', 'trans_first', 'se3', 'exp')
>>> C.get("sophus") is C.SOPHUS
True
"""

from . import unchecked
from .convention import CANONICAL, Convention, group_input
from .convert import (
    convert_covariance,
    convert_information,
    convert_jacobian,
    convert_tangent,
    is_exactly_linear,
    tangent_map,
)
from .detect import ConventionNotDetected, detect_convention, matches_so3
from .presets import (
    BARFOOT,
    CERES_EIGEN_QUATERNION,
    CERES_POSE,
    CERES_QUATERNION,
    G2O,
    G2O_EXPMAP,
    GTSAM,
    GTSAM_CAYLEY,
    JAXLIE,
    MANIF,
    MR_BODY,
    MR_SPACE,
    PINOCCHIO,
    PINOCCHIO_R3XSO3,
    PRESETS,
    PYPOSE,
    PYTRANSFORM3D_GLOBAL,
    PYTRANSFORM3D_LOCAL,
    ROS,
    SOPHUS,
    SYMFORCE,
    THESEUS,
)
from .registry import ConventionLike, get, matching_presets, names

__all__ = [
    "BARFOOT",
    "CANONICAL",
    "CERES_EIGEN_QUATERNION",
    "CERES_POSE",
    "CERES_QUATERNION",
    "G2O",
    "G2O_EXPMAP",
    "GTSAM",
    "GTSAM_CAYLEY",
    "JAXLIE",
    "MANIF",
    "MR_BODY",
    "MR_SPACE",
    "PINOCCHIO",
    "PINOCCHIO_R3XSO3",
    "PRESETS",
    "PYPOSE",
    "PYTRANSFORM3D_GLOBAL",
    "PYTRANSFORM3D_LOCAL",
    "ROS",
    "SOPHUS",
    "SYMFORCE",
    "THESEUS",
    "Convention",
    "ConventionLike",
    "ConventionNotDetected",
    "convert_covariance",
    "convert_information",
    "convert_jacobian",
    "convert_tangent",
    "detect_convention",
    "get",
    "group_input",
    "is_exactly_linear",
    "matches_so3",
    "matching_presets",
    "names",
    "tangent_map",
    "unchecked",
]
