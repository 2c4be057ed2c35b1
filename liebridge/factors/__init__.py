"""GTSAM factors in any convention, the optimizer and IMU preintegration (a façade).

The code lives in :mod:`liebridge.gtsam` (``between``, ``prior``, ``optimize``) and
:mod:`liebridge.imu` (``preintegrate``, ``ImuPreintegrator``, ``imu``, ``imu_kernel``); this module
re-exports it under the import path of earlier releases.
"""

from ..gtsam import ISAM2, OptimizeResult, between, optimize, prior
from ..imu import (
    ImuDelta,
    ImuPreintegrator,
    PreintegratedImu,
    imu,
    imu_kernel,
    imu_residual,
    preintegrate,
)

__all__ = [
    "ISAM2",
    "ImuDelta",
    "ImuPreintegrator",
    "OptimizeResult",
    "PreintegratedImu",
    "between",
    "imu",
    "imu_kernel",
    "imu_residual",
    "optimize",
    "preintegrate",
    "prior",
]
