"""IMU preintegration (Forster et al., GTSAM's manifold variant) and the IMU factor.

``inputs`` validates parameters, bias and samples; ``kernel`` is the vectorized maths (numpy, with
the optional compiled ``_imu_ext`` for the per-sample sums); ``preintegration`` is the public API;
``factor`` is GTSAM's ``ImuFactor`` residual as a custom factor with analytic Jacobians.
"""

from .combined import PreintegratedCombined, preintegrate_combined
from .combined_factor import combined_imu, combined_imu_residual
from .factor import imu, imu_residual
from .preintegration import (
    ImuDelta,
    ImuPreintegrator,
    PreintegratedImu,
    imu_kernel,
    preintegrate,
)
from .windows import PreintegratedWindows, preintegrate_windows

__all__ = [
    "ImuDelta",
    "ImuPreintegrator",
    "PreintegratedCombined",
    "PreintegratedImu",
    "PreintegratedWindows",
    "combined_imu",
    "combined_imu_residual",
    "imu",
    "imu_kernel",
    "imu_residual",
    "preintegrate",
    "preintegrate_combined",
    "preintegrate_windows",
]
