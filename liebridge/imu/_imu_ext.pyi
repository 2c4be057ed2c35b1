"""Type stub of the optional compiled IMU kernel (``_imu_ext.c``)."""

from typing import Any

def block_sums(
    acc: Any,
    gyro: Any,
    dt: Any,
    bias: Any,
    rotate: bool,
    bRs: Any,
    coef: Any,
    K: int,
    small2: float,
    scratch: Any,
    out: Any,
    /,
) -> None:
    """Write the per-sample sums of one block into ``out`` (C-contiguous float64 buffers)."""

def window_sums(
    acc: Any,
    gyro: Any,
    dt: Any,
    starts: Any,
    bias: Any,
    rotate: bool,
    bRs: Any,
    coef: Any,
    K: int,
    small2: float,
    scratch: Any,
    out: Any,
    /,
) -> None:
    """``block_sums`` of each window ``[starts[w], starts[w+1])``, into row ``w`` of ``out``."""

def combined_integrate(
    acc: Any,
    gyro: Any,
    dt: Any,
    bias: Any,
    cov: Any,
    out: Any,
    /,
) -> None:
    """GTSAM's tangent combined preintegration of all samples into ``out`` (289 doubles).

    ``cov``: acc, gyro, integration, bias-acc, bias-omega covariances (5 × 9 doubles, row-major).
    ``out``: (θ, p, v), Δt, the 15×15 covariance, H_biasAcc (9×3), H_biasOmega (9×3).
    """
