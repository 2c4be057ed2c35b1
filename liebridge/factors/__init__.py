"""GTSAM factors in any convention, the optimizer and IMU preintegration (a façade).

Old path: ``lb.factors`` keeps working (earlier releases); new code writes ``lb.gtsam``, ``lb.imu``.

The code lives in :mod:`liebridge.gtsam` (``between``, ``prior``, ``optimize``) and
:mod:`liebridge.imu` (``preintegrate``, ``preintegrate_windows``, ``ImuPreintegrator``, ``imu``,
``imu_kernel``); this module re-exports it under the import path of earlier releases.
"""

from ..gtsam import ISAM2, OptimizeResult, between, optimize, prior
from ..imu import (
    ImuDelta,
    ImuPreintegrator,
    PreintegratedCombined,
    PreintegratedImu,
    PreintegratedWindows,
    combined_imu,
    combined_imu_residual,
    imu,
    imu_kernel,
    imu_residual,
    preintegrate,
    preintegrate_combined,
    preintegrate_windows,
)

__all__ = [
    "ISAM2",
    "ImuDelta",
    "ImuPreintegrator",
    "OptimizeResult",
    "PreintegratedCombined",
    "PreintegratedImu",
    "PreintegratedWindows",
    "between",
    "combined_imu",
    "combined_imu_residual",
    "imu",
    "imu_kernel",
    "imu_residual",
    "optimize",
    "preintegrate",
    "preintegrate_combined",
    "preintegrate_windows",
    "prior",
]
