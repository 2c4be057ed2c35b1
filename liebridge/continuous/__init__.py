"""Continuous time: interpolation with Jacobians, deskew and cumulative B-splines, named.

* :func:`interpolate` — ``T(τ)`` between two poses, coupled SE(3) (``"se3"``) or SLERP + LERP
  (``"split"``), with Jacobians with respect to both endpoints and τ in any SE(3) convention;
* :func:`deskew` — a LiDAR scan moved to the sensor frame at a named reference time, models
  ``"kiss_icp"``, ``"ct_icp"`` and ``"generic"``, with the Jacobians of each point;
* :class:`Spline` — uniform cumulative B-splines (coupled or split, product or sum form) with
  velocities and accelerations whose frames are named, knot Jacobians, fitting, and the spline
  presets ``basalt``, ``kontiki`` and ``gtsam_cumulative``.

See ``docs/continuous-time.md``.
"""

from .deskew import DESKEW_MODELS, Deskewed, deskew
from .interpolate import METHODS, Interpolated, interpolate
from .spline import (
    BASALT,
    GTSAM_CUMULATIVE,
    KONTIKI,
    SPLINE_PRESETS,
    Acceleration,
    Spline,
    SplineJacobians,
    SplinePreset,
    Velocity,
    convert_knot_covariance,
    convert_velocity,
)

__all__ = [
    "BASALT",
    "DESKEW_MODELS",
    "GTSAM_CUMULATIVE",
    "KONTIKI",
    "METHODS",
    "SPLINE_PRESETS",
    "Acceleration",
    "Deskewed",
    "Interpolated",
    "Spline",
    "SplineJacobians",
    "SplinePreset",
    "Velocity",
    "convert_knot_covariance",
    "convert_velocity",
    "deskew",
    "interpolate",
]
