"""GTSAM factors in any convention, the optimizer and IMU preintegration (a façade).

The code lives in :mod:`liebridge.gtsam` (``between``, ``prior``, ``optimize``) and
:mod:`liebridge.imu` (``preintegrate``, ``preintegrate_windows``, ``ImuPreintegrator``, ``imu``,
``imu_kernel``); this module re-exports it under the import path of earlier releases.
"""

from ..gtsam import ISAM2, OptimizeResult, between, optimize, prior
from ..imu import (
    ImuDelta,
    ImuPreintegrator,
    PreintegratedImu,
    PreintegratedWindows,
    imu,
    imu_kernel,
    imu_residual,
    preintegrate,
    preintegrate_windows,
)

__all__ = [
    "ISAM2",
    "ImuDelta",
    "ImuPreintegrator",
    "OptimizeResult",
    "PreintegratedImu",
    "PreintegratedWindows",
    "between",
    "imu",
    "imu_kernel",
    "imu_residual",
    "optimize",
    "preintegrate",
    "preintegrate_windows",
    "prior",
]
