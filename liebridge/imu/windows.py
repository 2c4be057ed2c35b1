"""Preintegration of many keyframe windows of one IMU sequence in one call.

A VIO/LIO front end preintegrates 100–200 samples between consecutive keyframes, thousands of
times. :func:`preintegrate_windows` takes the whole sequence and the first sample index of every
window and returns every window's preintegrated measurements as stacked arrays
(:class:`PreintegratedWindows`), each equal to :func:`liebridge.imu.preintegrate` on that window
(GTSAM 4.3's ``PreintegratedImuMeasurementsManifold``; the conventions are those of
:mod:`liebridge.imu.preintegration`). ``result[k]`` is window ``k`` as a :class:`PreintegratedImu`
and :meth:`PreintegratedWindows.factors` builds one IMU factor per window.

With the compiled kernel the per-sample sums of all windows come from one C call and the
covariances and Jacobians are assembled batched over windows (:func:`liebridge.imu.kernel.
integrate_windows`), so no Python code runs per window; ``benchmarks/bench_imu_windows.py``
measures it against GTSAM's loop.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from .._validate import FloatArray
from .factor import imu
from .inputs import freeze_arrays, read_bias, read_params, read_samples
from .kernel import integrate_windows
from .preintegration import PreintegratedImu

__all__ = ["PreintegratedWindows", "preintegrate_windows"]


@dataclasses.dataclass(frozen=True, eq=False)
class PreintegratedWindows:
    """Preintegrated IMU measurements of ``m`` consecutive windows, stacked on a leading axis.

    Window ``k`` holds samples ``starts[k] … starts[k+1] − 1`` (the last one runs to the end of the
    sequence) and is integrated from the identity with the bias estimate ``bias_hat[k]``. Every
    field is that of :class:`PreintegratedImu` with a leading axis of length ``m``; ``self[k]``
    is window ``k`` as a :class:`PreintegratedImu`.

    Attributes
    ----------
    delta_R : ndarray, shape (m, 3, 3)
        R_ij of each window (frame ``j`` = body at the window's end, in frame ``i`` = its start).
    delta_p, delta_v : ndarray, shape (m, 3)
        Frame ``i``, gravity excluded.
    delta_t : ndarray, shape (m,)
    covariance : ndarray, shape (m, 9, 9)
        Order (rot, pos, vel), chart of ``NavState::retract`` (GTSAM's ``preintMeasCov``).
    dR_dbg, dp_dba, dp_dbg, dv_dba, dv_dbg : ndarray, shape (m, 3, 3)
        Bias Jacobians (GTSAM ``delRdelBiasOmega``, ``delPdelBiasAcc``, …).
    bias_hat : ndarray, shape (m, 6)
        Bias estimate of each window, order (acc, gyro).
    gravity : ndarray, shape (3,)
    starts, n_samples : ndarray of int64, shape (m,)
    """

    delta_R: FloatArray
    delta_p: FloatArray
    delta_v: FloatArray
    delta_t: FloatArray
    covariance: FloatArray
    dR_dbg: FloatArray
    dp_dba: FloatArray
    dp_dbg: FloatArray
    dv_dba: FloatArray
    dv_dbg: FloatArray
    bias_hat: FloatArray
    gravity: FloatArray
    starts: Any
    n_samples: Any

    def __post_init__(self) -> None:
        freeze_arrays(self, ints=("starts", "n_samples"))

    def __len__(self) -> int:
        return int(self.starts.shape[0])

    def __getitem__(self, k: int) -> PreintegratedImu:
        """Window ``k`` (negative indices count from the end) as a :class:`PreintegratedImu`."""
        m = len(self)
        if not isinstance(k, (int, np.integer)) or isinstance(k, bool):
            raise TypeError(f"k: expected an integer window index, got {type(k).__name__}")
        if not -m <= k < m:
            raise IndexError(f"k: window {k} out of range for {m} windows")
        return PreintegratedImu(
            delta_R=self.delta_R[k],
            delta_p=self.delta_p[k],
            delta_v=self.delta_v[k],
            delta_t=float(self.delta_t[k]),
            covariance=self.covariance[k],
            dR_dbg=self.dR_dbg[k],
            dp_dba=self.dp_dba[k],
            dp_dbg=self.dp_dbg[k],
            dv_dba=self.dv_dba[k],
            dv_dbg=self.dv_dbg[k],
            bias_hat=self.bias_hat[k],
            gravity=self.gravity,
            n_samples=int(self.n_samples[k]),
        )

    @property
    def bias_jacobian(self) -> FloatArray:
        """``(m, 9, 6)``: rows (rot, pos, vel), columns (acc, gyro), as in ``PreintegratedImu``."""
        m = len(self)
        J = np.zeros((m, 9, 6))
        J[:, 0:3, 3:6] = self.dR_dbg
        J[:, 3:6, 0:3], J[:, 3:6, 3:6] = self.dp_dba, self.dp_dbg
        J[:, 6:9, 0:3], J[:, 6:9, 3:6] = self.dv_dba, self.dv_dbg
        return J

    def factors(self, pose_keys: Any, vel_keys: Any, bias_keys: Any) -> list[Any]:
        """One :func:`liebridge.factors.imu` factor per window (GTSAM ``CustomFactor`` objects).

        Window ``k`` connects ``pose_keys[k], vel_keys[k]`` to ``pose_keys[k+1], vel_keys[k+1]``
        with bias ``bias_keys[k]``: GTSAM ``ImuFactor``'s residual (ComponentWise) and noise model
        (the window's ``covariance``), on the manifold preintegration.

        Parameters
        ----------
        pose_keys, vel_keys : sequence of int, length m + 1
            Keys of the ``Pose3`` and world-frame ``Vector3`` velocity at every window boundary.
        bias_keys : int or sequence of int, length m
            One bias key for all windows, or one per window.
        """
        m = len(self)
        pk, vk = list(pose_keys), list(vel_keys)
        one = isinstance(bias_keys, (int, np.integer))
        bk: list[Any] = [bias_keys] * m if one else list(bias_keys)
        for name, keys, want in (("pose_keys", pk, m + 1), ("vel_keys", vk, m + 1)):
            if len(keys) != want:
                raise ValueError(f"{name}: expected {want} keys ({m} windows + 1), got {len(keys)}")
        if len(bk) != m:
            raise ValueError(f"bias_keys: expected one key or {m} keys, got {len(bk)}")
        return [imu(pk[k], vk[k], pk[k + 1], vk[k + 1], bk[k], self[k]) for k in range(m)]


def _read_starts(starts: Any, n: int) -> Any:
    arr = np.asarray(starts)
    if arr.dtype.kind == "b" or (arr.dtype.kind not in "iu" and arr.size):
        if arr.dtype.kind == "f" and np.all(np.isfinite(arr)) and np.all(arr == np.round(arr)):
            arr = arr.astype(np.int64)
        else:
            raise TypeError(f"starts: expected integer sample indices, got dtype {arr.dtype}")
    if arr.ndim != 1 or arr.shape[0] == 0:
        raise ValueError(
            f"starts: expected a non-empty 1-D array of indices, got shape {arr.shape}"
        )
    arr = arr.astype(np.int64)
    if arr[0] < 0 or arr[-1] >= n:
        i = 0 if arr[0] < 0 else arr.shape[0] - 1
        raise ValueError(
            f"starts: starts[{i}] = {int(arr[i])} is outside [0, {n}) (N = {n} samples)"
        )
    step = np.diff(arr)
    if np.any(step <= 0):
        i = int(np.argmax(step <= 0)) + 1
        raise ValueError(
            f"starts: must be strictly increasing (every window non-empty), got "
            f"starts[{i - 1}] = {int(arr[i - 1])}, starts[{i}] = {int(arr[i])}"
        )
    return arr


def preintegrate_windows(
    acc: Any, gyro: Any, dt: Any, starts: Any, *, bias: Any, params: Any
) -> PreintegratedWindows:
    """Preintegrate every keyframe window of one IMU sequence, batched.

    ``result[k]`` equals ``preintegrate(acc[s:e], gyro[s:e], dt[s:e], bias=bias_k,
    params=params)`` with ``s = starts[k]`` and ``e = starts[k+1]`` (``N`` for the last window),
    i.e. GTSAM's ``PreintegratedImuMeasurementsManifold`` fed with that window's samples and
    ``resetIntegration`` between windows. Samples before ``starts[0]`` are not used.

    Parameters
    ----------
    acc, gyro : array_like, shape (N, 3)
        Accelerometer (m/s²) and gyroscope (rad/s) samples, sensor frame.
    dt : float or array_like, shape (N,)
        Duration each sample is held (s), > 0.
    starts : array_like of int, shape (m,)
        First sample index of each window, strictly increasing in ``[0, N)``.
    bias : gtsam.imuBias.ConstantBias, (acc, gyro) pair, array (6,) or array (m, 6)
        One bias estimate for all windows or one per window, order (acc, gyro).
    params : gtsam.PreintegrationParams

    Returns
    -------
    PreintegratedWindows

    Raises
    ------
    ValueError
        As :func:`liebridge.imu.preintegrate`; ``starts`` not strictly increasing or out of range
        (naming the index), a bias batch of the wrong length.
    TypeError
        ``starts`` not integers.
    """
    acc_, gyro_, dt_ = read_samples(acc, gyro, dt)
    st = _read_starts(starts, dt_.shape[0])
    P = read_params(params)
    m = st.shape[0]
    b = read_bias(bias)
    if b.shape == (6,):
        b = np.broadcast_to(b, (m, 6))
    elif b.shape != (m, 6):
        raise ValueError(f"bias: expected shape (6,) or ({m}, 6) for {m} windows, got {b.shape}")
    b = np.ascontiguousarray(b, dtype=np.float64)
    d = integrate_windows(acc_, gyro_, dt_, st, b, P)
    return PreintegratedWindows(
        delta_R=d.R,
        delta_p=d.p,
        delta_v=d.v,
        delta_t=d.delta_t,
        covariance=d.cov,
        dR_dbg=d.J[:, 0:3, 3:6],
        dp_dba=d.J[:, 3:6, 0:3],
        dp_dbg=d.J[:, 3:6, 3:6],
        dv_dba=d.J[:, 6:9, 0:3],
        dv_dbg=d.J[:, 6:9, 3:6],
        bias_hat=b,
        gravity=P.gravity,
        starts=st,
        n_samples=d.n,
    )
