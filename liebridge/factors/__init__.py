"""GTSAM factors written in any convention, and IMU preintegration.

``between``/``prior`` take covariances in any convention (native GTSAM factors where the
conversion is exact, custom factors with exact analytic Jacobians otherwise); ``optimize`` runs
Levenberg–Marquardt without GTSAM's per-callback ``Values`` copy and evaluates liebridge's pose
factors in one batched pass.
"""

# the IMU factor (GTSAM's ComponentWise ImuFactor residual)
from .imu import imu, imu_residual

# pose factors in any convention, and the optimizer that keeps them fast
from .optimize import OptimizeResult, optimize
from .pose_factors import between, prior

# on-manifold IMU preintegration (Forster et al.), vectorized over samples
from .preintegration import (
    ImuDelta,
    ImuPreintegrator,
    PreintegratedImu,
    imu_kernel,
    preintegrate,
)

__all__ = [
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
