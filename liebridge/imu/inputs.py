"""Inputs of IMU preintegration: GTSAM parameters, bias estimates and samples, validated.

Everything here only reads and checks; the arithmetic is in :mod:`._imu_kernel`. Errors name the
argument, the sample index and the offending value (``ValueError``), or the wrong type
(``TypeError``).
"""

from __future__ import annotations

import dataclasses
import threading
from typing import Any

import gtsam
import numpy as np

from .. import _validate as validate
from .._validate import FloatArray

__all__ = ["Params", "is_isotropic", "read_bias", "read_params", "read_samples"]


def is_isotropic(C: FloatArray) -> bool:
    """Whether the 3×3 matrix ``C`` is exactly a multiple of the identity."""
    return bool(np.all(C == C[0, 0] * np.eye(3)))


@dataclasses.dataclass(frozen=True)
class Params:
    """Numbers read once from a ``gtsam.PreintegrationParams``.

    The noise covariances are continuous-time densities in the *body* frame: with a rotated
    sensor, ``bRs Q bRsᵀ`` (an isotropic ``Q`` is kept bit for bit; rotation leaves it alone).
    With a lever arm the gyroscope covariance stays in the sensor frame (the general path applies
    ``bRs`` and the lever-arm coupling to the per-sample blocks instead).
    """

    gravity: FloatArray  # (3,) navigation frame
    acc_cov: FloatArray  # (3, 3)
    gyro_cov: FloatArray
    int_cov: FloatArray
    body_R_sensor: FloatArray | None  # (3, 3) or None
    lever_arm: FloatArray | None  # (3,) body frame, None when zero
    fast: bool  # isotropic gyroscope noise and no lever arm
    # the variance of each isotropic covariance (None when it is not a multiple of I)
    acc_var: float | None = None
    gyro_var: float | None = None
    int_var: float | None = None


def _variance(C: FloatArray) -> float | None:
    return float(C[0, 0]) if is_isotropic(C) else None


#: Validated parameters by the raw numbers they were read from (a few entries: one per distinct
#: set of parameters a program uses). ``gtsam.PreintegrationParams`` is mutable, so the key is
#: its values, read afresh at every call (about 3 µs), never the object's identity.
_PARAMS_CACHE: dict[bytes, Params] = {}
_PARAMS_CACHE_SIZE = 16
_PARAMS_CACHE_LOCK = threading.Lock()


def read_params(params: Any) -> Params:
    """Read and check a ``gtsam.PreintegrationParams`` (rejects a non-zero ``omegaCoriolis``).

    The checks (positive semi-definite covariances, rotation of ``body_P_sensor``) run once per
    distinct set of values; a call with values seen before costs about 5 µs instead of 60 µs.
    """
    if not isinstance(params, gtsam.PreintegrationParams):
        raise TypeError(
            f"params: expected a gtsam.PreintegrationParams, got {type(params).__name__}"
        )
    body_P_sensor = params.getBodyPSensor()
    coriolis = params.getOmegaCoriolis()
    raw = [
        params.n_gravity,
        params.getAccelerometerCovariance(),
        params.getGyroscopeCovariance(),
        params.getIntegrationCovariance(),
        () if body_P_sensor is None else body_P_sensor.matrix(),
        () if coriolis is None else coriolis,
    ]
    key = b"|".join(np.asarray(x, dtype=np.float64).tobytes() for x in raw)
    cached = _PARAMS_CACHE.get(key)
    if cached is not None:
        return cached
    P = _read_params(params, body_P_sensor, coriolis)
    with _PARAMS_CACHE_LOCK:
        if len(_PARAMS_CACHE) >= _PARAMS_CACHE_SIZE:
            _PARAMS_CACHE.pop(next(iter(_PARAMS_CACHE)))
        _PARAMS_CACHE[key] = P
    return P


def _read_params(params: Any, body_P_sensor: Any, coriolis: Any) -> Params:
    if coriolis is not None and np.any(np.asarray(coriolis) != 0.0):
        raise ValueError(
            f"params: omegaCoriolis = {np.asarray(coriolis).tolist()} is not supported "
            "(GTSAM then predicts in a rotating frame); set it to None or zero"
        )
    gravity = validate.vector(np.array(params.n_gravity, dtype=np.float64), "params.n_gravity", 3)
    if gravity.shape != (3,):
        raise ValueError(f"params.n_gravity: expected shape (3,), got {gravity.shape}")

    def cov(x: Any, name: str) -> FloatArray:
        c = validate.covariance(np.array(x, dtype=np.float64), name, 3)
        if c.shape != (3, 3):
            raise ValueError(f"{name}: expected shape (3, 3), got {c.shape}")
        return np.asarray(0.5 * (c + c.T))

    acc_cov = cov(params.getAccelerometerCovariance(), "params.accelerometerCovariance")
    gyro_cov = cov(params.getGyroscopeCovariance(), "params.gyroscopeCovariance")
    int_cov = cov(params.getIntegrationCovariance(), "params.integrationCovariance")
    bRs = lever = None
    if body_P_sensor is not None:
        bRs = validate.rotation(np.array(body_P_sensor.rotation().matrix()), "params.body_P_sensor")
        t = np.array(body_P_sensor.translation(), dtype=np.float64)
        lever = t if np.any(t != 0.0) else None
        if not is_isotropic(acc_cov):
            acc_cov = bRs @ acc_cov @ bRs.T
        if lever is None and not is_isotropic(gyro_cov):
            gyro_cov = bRs @ gyro_cov @ bRs.T
    for arr in (gravity, acc_cov, gyro_cov, int_cov, bRs, lever):
        if arr is not None:
            arr.flags.writeable = False
    return Params(
        gravity=gravity,
        acc_cov=acc_cov,
        gyro_cov=gyro_cov,
        int_cov=int_cov,
        body_R_sensor=bRs,
        lever_arm=lever,
        fast=lever is None and is_isotropic(gyro_cov),
        acc_var=_variance(acc_cov),
        gyro_var=_variance(gyro_cov),
        int_var=_variance(int_cov),
    )


def read_bias(bias: Any, name: str = "bias") -> FloatArray:
    """Return a bias as a ``(..., 6)`` array in (acc, gyro) order."""
    if isinstance(bias, gtsam.imuBias.ConstantBias):
        return np.array(bias.vector(), dtype=np.float64)
    if isinstance(bias, (tuple, list)) and len(bias) == 2:
        acc = validate.vector(bias[0], f"{name}[0] (accelerometer)", 3)
        gyro = validate.vector(bias[1], f"{name}[1] (gyroscope)", 3)
        acc, gyro = np.broadcast_arrays(acc, gyro)
        return np.concatenate([acc, gyro], axis=-1)
    return validate.vector(bias, f"{name} (acc, gyro)", 6)


def read_samples(acc: Any, gyro: Any, dt: Any) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Check samples (N, 3), (N, 3) and a scalar or (N,) ``dt > 0``; return float64 arrays."""
    acc_ = validate.as_float_array(acc, "acc")
    gyro_ = validate.as_float_array(gyro, "gyro")
    for arr, name in ((acc_, "acc"), (gyro_, "gyro")):
        if arr.ndim != 2 or arr.shape[1] != 3:
            raise ValueError(f"{name}: expected shape (N, 3), got {arr.shape}")
    n = acc_.shape[0]
    if gyro_.shape[0] != n:
        raise ValueError(f"gyro: {gyro_.shape[0]} samples but acc has {n}")
    if n == 0:
        raise ValueError("acc: no samples (N = 0)")
    validate.check_finite(acc_, "acc", core_ndim=1)
    validate.check_finite(gyro_, "gyro", core_ndim=1)
    dt_ = validate.as_float_array(dt, "dt")
    if dt_.ndim == 0:
        dt_ = np.full(n, float(dt_))
    elif dt_.shape != (n,):
        raise ValueError(f"dt: expected a scalar or shape ({n},) to match acc, got {dt_.shape}")
    validate.check_finite(dt_, "dt")
    bad = dt_ <= 0.0
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(
            f"dt: must be > 0, got dt[{i}] = {dt_[i]:.6g} ({int(bad.sum())} of {n} values ≤ 0)"
        )
    return acc_, gyro_, dt_


def freeze_arrays(obj: Any, *, scalars: tuple[str, ...] = (), ints: tuple[str, ...] = ()) -> None:
    """Make every array field of a frozen result dataclass a read-only float64 copy.

    Fields named in ``scalars`` are left as they are (``delta_t`` is made a float), those in
    ``ints`` become read-only int64 arrays. The result types of :mod:`liebridge.imu` share it.
    """
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if f.name in scalars:
            if f.name == "delta_t":
                object.__setattr__(obj, f.name, float(value))
            continue
        arr = np.array(value, dtype=np.int64 if f.name in ints else np.float64, copy=True)
        arr.flags.writeable = False
        object.__setattr__(obj, f.name, arr)
