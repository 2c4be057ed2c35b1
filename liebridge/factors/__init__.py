"""GTSAM factors written in any convention, and IMU preintegration."""

# IMU preintegration (Forster et al.) and its factor
from .imu import imu, imu_residual
from .preintegration import ImuDelta, ImuPreintegrator, PreintegratedImu, preintegrate

__all__ = [
    "ImuDelta",
    "ImuPreintegrator",
    "PreintegratedImu",
    "imu",
    "imu_residual",
    "preintegrate",
]
