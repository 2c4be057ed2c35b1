"""Named frames: ``T_target_source`` as data, TF trees, axis conventions, calibration files.

* :class:`Transform` — a rigid transform with its two frame names (and optional covariance);
  composing mismatched frames raises naming both.
* :class:`TransformTree` — "``T_a_b`` at time ``t``" from a list of static and time-stamped
  transforms, with named interpolation (``"lerp_slerp"`` as tf2, or ``"geodesic"``).
* :mod:`~liebridge.frames.axes` — ENU/NED, FLU/FRD, camera optical (RDF), OpenGL (RUB) as
  constant rotations and transforms.
* :mod:`~liebridge.frames.calibration` — Kalibr ``camchain-imucam.yaml`` read/write and the
  camera–IMU extrinsic in the conventions of OKVIS, ORB-SLAM3, OpenVINS, Basalt, VINS-Fusion and
  OpenCV; LIO-SAM's lidar–IMU parameters.

See ``docs/frames-and-calibration.md``.
"""

from . import axes, calibration
from .axes import Axes, axes_transform
from .calibration import (
    SYSTEMS,
    CalibrationFile,
    KalibrCamchain,
    KalibrCamera,
    OrbSlam3PrecisionWarning,
    SystemExtrinsic,
    export_extrinsic,
    format_parameter,
    from_liosam,
    from_rvec_tvec,
    read_extrinsic,
    read_kalibr,
    read_timeshift,
    system_names,
    to_liosam,
    to_rvec_tvec,
    write_kalibr,
)
from .transform import FrameMismatchError, Transform
from .tree import FrameLookupError, StampedTransform, TransformTree

__all__ = [
    "SYSTEMS",
    "Axes",
    "CalibrationFile",
    "FrameLookupError",
    "FrameMismatchError",
    "KalibrCamchain",
    "KalibrCamera",
    "OrbSlam3PrecisionWarning",
    "StampedTransform",
    "SystemExtrinsic",
    "Transform",
    "TransformTree",
    "axes",
    "axes_transform",
    "calibration",
    "export_extrinsic",
    "format_parameter",
    "from_liosam",
    "from_rvec_tvec",
    "read_extrinsic",
    "read_kalibr",
    "read_timeshift",
    "system_names",
    "to_liosam",
    "to_rvec_tvec",
    "write_kalibr",
]
