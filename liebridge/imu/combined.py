"""Combined IMU preintegration: GTSAM's ``PreintegratedCombinedMeasurements`` (15×15 covariance).

Reproduces GTSAM 4.3's ``PreintegratedCombinedMeasurements`` (``gtsam/navigation/
CombinedImuFactor.cpp``, ``integrateMeasurement``) on its *tangent* preintegration
(``TangentPreintegration.cpp``, ``UpdatePreintegrated``), the only one GTSAM's
``CombinedImuFactor`` accepts. It differs from the manifold preintegration of
:func:`liebridge.imu.preintegrate` at second order (the rotation is integrated as
``θ ← θ + J_r(θ)⁻¹ ω dt`` instead of the exact product ``ΔR ← ΔR Exp(ω dt)``).

Conventions
-----------
* The preintegrated vector is ``(θ, p, v)`` with ``ΔR = Exp(θ)``, ``Δp = p``, ``Δv = v`` in frame
  ``i`` (the body frame at the first sample), gravity excluded (``deltaRij``, ``deltaPij``,
  ``deltaVij``).
* ``covariance`` (15×15) is ``preintMeasCov()``, order ``(θ, p, v, b_a, b_g)``: the first nine in
  the tangent coordinates of the preintegrated vector (additive on ``(θ, p, v)``), the last six the
  bias random walk accumulated over the window (``biasAccCovariance·Δt``,
  ``biasOmegaCovariance·Δt`` plus its correlation with the deltas). Per sample
  ``Σ ← F Σ Fᵀ + G Q Gᵀ/dt + diag(0, iCov dt, 0, Q_ba dt, Q_bg dt)`` with GTSAM's ``F``, whose bias
  columns hold the *measurement* Jacobians ``+B``, ``+C`` (GTSAM's sign, kept).
* ``bias_jacobian`` (9×6) is ``d(θ, p, v)/d(b_a, b_g)`` of the preintegrated vector
  (``preintegrated_H_biasAcc``, ``preintegrated_H_biasOmega``).

The rotation recursion is nonlinear and sequential, so the work is one loop over the samples: in C
(``combined_integrate`` in ``_imu_ext.c``) where the compiled kernel is built, else the same loop
in Python (:func:`_python_loop`, the dense ``F Σ Fᵀ`` reference the compiled loop is tested
against; about 2,000× slower). The C loop propagates ``Σ`` in 3×3 blocks using the structure of
``F``: ``Cov(θ, b_a)`` and ``Cov(b_a, b_g)`` stay zero, the bias blocks are ``Q_b·Δt`` in closed
form, the ``p`` row of ``F`` is ``dt/2`` times its ``v`` row plus ``dt·v``, and ``J_r(θ)⁻¹`` is the
closed form ``I + W/2 + (1/|θ|² − (1 + cos|θ|)/(2|θ| sin|θ|)) W²`` (``W = [θ]×``); about 100 ns a
sample (2-core x86-64 VM, AVX2 clone). ``body_P_sensor`` is not supported here.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import gtsam
import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..lie import so3
from . import kernel as _kernel
from .inputs import freeze_arrays, read_bias, read_params, read_samples

__all__ = ["PreintegratedCombined", "preintegrate_combined"]

_N_OUT = 289


@dataclasses.dataclass(frozen=True, eq=False)
class PreintegratedCombined:
    """GTSAM's ``PreintegratedCombinedMeasurements`` as arrays (see the module docstring).

    Attributes
    ----------
    delta_R : ndarray (3, 3)
        ``Exp(θ)`` (``deltaRij``).
    delta_p, delta_v : ndarray (3,)
        Frame ``i``, gravity excluded (``deltaPij``, ``deltaVij``).
    delta_t : float
    preintegrated : ndarray (9,)
        The tangent vector ``(θ, p, v)``.
    covariance : ndarray (15, 15)
        ``preintMeasCov()``, order ``(θ, p, v, b_a, b_g)``.
    bias_jacobian : ndarray (9, 6)
        ``d(θ, p, v)/d(b_a, b_g)``.
    bias_hat : ndarray (6,)
        Bias estimate, order (acc, gyro).
    gravity : ndarray (3,)
    n_samples : int
    """

    delta_R: FloatArray
    delta_p: FloatArray
    delta_v: FloatArray
    delta_t: float
    preintegrated: FloatArray
    covariance: FloatArray
    bias_jacobian: FloatArray
    bias_hat: FloatArray
    gravity: FloatArray
    n_samples: int = 0

    def __post_init__(self) -> None:
        freeze_arrays(self, scalars=("delta_t", "n_samples"))

    @property
    def residual_covariance(self) -> FloatArray:
        """The noise model of GTSAM 4.3's ``CombinedImuFactor``: ``residualCovariance()`` (15×15).

        ``T S Σ S Tᵀ`` with ``Σ`` = :attr:`covariance`, ``S = diag(I₉, −I₆)`` (the residual's bias
        part is ``b_i − b_j`` while ``Σ``'s bias columns follow GTSAM's ``F``) and
        ``T = blockdiag(J_r(θ), ΔRᵀ, ΔRᵀ, I₆)`` (from the tangent chart of ``(θ, p, v)`` to the
        residual's: right perturbation of ``ΔR``, body-frame ``p``, ``v``). Measured equal to
        GTSAM's ``residualCovariance()`` to 2e-16 relative, in both error modes; it is *not*
        ``preintMeasCov()`` (those differ in the sign of the bias cross-covariance and in ``T``).
        """
        T = np.eye(15)
        T[0:3, 0:3] = so3.jr(self.preintegrated[0:3])
        T[3:6, 3:6] = T[6:9, 6:9] = self.delta_R.T
        T[9:15, 9:15] = -np.eye(6)  # T·S
        C = T @ self.covariance @ T.T
        return np.asarray(0.5 * (C + C.T))


def _aligned(x: FloatArray) -> FloatArray:
    """``x`` as an aligned, C-contiguous float64 array (the compiled kernel reads raw doubles)."""
    return np.require(x, dtype=np.float64, requirements=["C_CONTIGUOUS", "ALIGNED"])


def _python_loop(
    acc: FloatArray, gyro: FloatArray, dt: FloatArray, bias: FloatArray, cv: FloatArray
) -> FloatArray:
    """Run the reference loop: GTSAM's dense ``F Σ Fᵀ`` per sample, one sample at a time.

    ``combined_loop`` in ``_imu_ext.c`` computes the same recursion in 3×3 blocks (equal to
    rounding; tested to 1e-12 relative).
    """
    aCov, wCov, iCov, baCov, bgCov = (cv[9 * i : 9 * i + 9].reshape(3, 3) for i in range(5))
    x = np.zeros(9)
    S = np.zeros((15, 15))
    Hb = np.zeros((9, 6))
    T = 0.0
    Q = np.zeros((6, 6))
    Q[0:3, 0:3], Q[3:6, 3:6] = aCov, wCov
    for k in range(dt.shape[0]):
        d = float(dt[k])
        d22 = 0.5 * d * d
        a = acc[k] - bias[:3]
        w = gyro[k] - bias[3:]
        th = x[0:3].copy()
        R = so3.exp(th)
        Jr = so3.jr(th)
        iJ = np.linalg.inv(Jr)
        c = iJ @ w
        # d(J_r(θ) c)/dθ by central differences would be slow; use the closed form
        t2 = float(th @ th)
        t = np.sqrt(t2)
        if t < 1e-2:
            B = 0.5 - t2 / 24 + t2 * t2 / 720 - t2**3 / 40320
            C = 1 / 6 - t2 / 120 + t2 * t2 / 5040 - t2**3 / 362880
            dB = -1 / 12 + t2 / 180 - t2 * t2 / 6720
            dC = -1 / 60 + t2 / 1260 - t2 * t2 / 60480
        else:
            st, ct = np.sin(t), np.cos(t)
            B, C = (1 - ct) / t2, (t - st) / (t2 * t)
            dB = (t * st - 2 * (1 - ct)) / t2**2
            dC = (1 - ct) / t2**2 - 3 * (t - st) / (t2**2 * t)
        cxt = np.cross(c, th)
        ttc = np.cross(th, -cxt)
        H = (
            B * so3.hat(c)
            + dB * np.outer(cxt, th)
            + C * (float(th @ c) * np.eye(3) + np.outer(th, c) - 2 * np.outer(c, th))
            + dC * np.outer(ttc, th)
        )
        aH = R @ so3.hat(-a) @ Jr
        F = np.eye(15)
        F[0:3, 0:3] -= iJ @ H * d
        F[3:6, 0:3] = aH * d22
        F[6:9, 0:3] = aH * d
        F[3:6, 6:9] = d * np.eye(3)
        F[0:3, 12:15] = iJ * d
        F[3:6, 9:12] = R * d22
        F[6:9, 9:12] = R * d
        Hb = F[0:9, 0:9] @ Hb - F[0:9, 9:15]
        S = F @ S @ F.T
        G = F[0:9, 9:15]
        S[0:9, 0:9] += G @ (Q / d) @ G.T
        S[3:6, 3:6] += d * iCov
        S[9:12, 9:12] += d * baCov
        S[12:15, 12:15] += d * bgCov
        an = R @ a
        x = np.concatenate([th + c * d, x[3:6] + x[6:9] * d + an * d22, x[6:9] + an * d])
        T += d
    out = np.empty(_N_OUT)
    out[0:9], out[9] = x, T
    out[10:235] = S.ravel()
    out[235:262] = Hb[:, 0:3].ravel()
    out[262:289] = Hb[:, 3:6].ravel()
    return out


def preintegrate_combined(
    acc: Any, gyro: Any, dt: Any, *, bias: Any, params: Any, compiled: bool | None = None
) -> PreintegratedCombined:
    """Preintegrate IMU samples as GTSAM's ``PreintegratedCombinedMeasurements``.

    Parameters
    ----------
    acc, gyro : array_like, shape (N, 3)
        Accelerometer (m/s²) and gyroscope (rad/s) samples, body frame.
    dt : float or array_like (N,)
        > 0 (s).
    bias : gtsam.imuBias.ConstantBias, (acc, gyro) pair, or array (6,)
    params : gtsam.PreintegrationCombinedParams
        Without ``body_P_sensor`` and with ``omegaCoriolis`` unset or zero.
    compiled : bool, optional
        ``False`` forces the Python loop, ``True`` requires the compiled kernel.

    Returns
    -------
    PreintegratedCombined
        Equal to GTSAM's on the same samples (``deltaRij/Pij/Vij``, ``preintMeasCov()``).

    Raises
    ------
    TypeError
        ``params`` is not a ``gtsam.PreintegrationCombinedParams``.
    ValueError
        Bad samples (naming the index), ``body_P_sensor`` set, overflow.
    """
    if not isinstance(params, gtsam.PreintegrationCombinedParams):
        raise TypeError(
            "params: expected a gtsam.PreintegrationCombinedParams (the bias random walk "
            f"densities live there), got {type(params).__name__}"
        )
    acc_, gyro_, dt_ = read_samples(acc, gyro, dt)
    P = read_params(params)
    if P.body_R_sensor is not None or P.lever_arm is not None:
        raise ValueError(
            "params: body_P_sensor is not supported by preintegrate_combined; rotate the samples "
            "into the body frame first"
        )
    b = read_bias(bias)
    if b.shape != (6,):
        raise ValueError(f"bias: expected one bias (6,), got shape {b.shape}")
    bacc = validate.covariance(
        np.array(params.getBiasAccCovariance(), dtype=np.float64), "params.biasAccCovariance", 3
    )
    bgyro = validate.covariance(
        np.array(params.getBiasOmegaCovariance(), dtype=np.float64), "params.biasOmegaCovariance", 3
    )
    # GTSAM ≤ 4.2's biasAccOmegaInt term does not exist in 4.3 (no slot for it)
    cv = np.concatenate([P.acc_cov, P.gyro_cov, P.int_cov, bacc, bgyro], axis=None)
    if compiled and not _kernel.COMPILED:
        raise ValueError("compiled=True: the compiled kernel is not built")
    ext = _kernel._imu_ext
    with np.errstate(all="ignore"):
        if ext is not None and compiled is not False:
            out = np.empty(_N_OUT)
            ext.combined_integrate(*(_aligned(x) for x in (acc_, gyro_, dt_, b, cv)), out)
        else:
            out = _python_loop(acc_, gyro_, dt_, b, cv)
    if not np.all(np.isfinite(out)):
        raise ValueError(
            f"acc, gyro, dt, bias: finite inputs whose combined preintegration overflows float64 "
            f"(max |acc| {float(np.abs(acc_).max()):.3g}, max |gyro| "
            f"{float(np.abs(gyro_).max()):.3g}, max dt {float(dt_.max()):.3g})"
        )
    S = out[10:235].reshape(15, 15)
    J = np.hstack([out[235:262].reshape(9, 3), out[262:289].reshape(9, 3)])
    return PreintegratedCombined(
        delta_R=so3.exp(out[0:3]),
        delta_p=out[3:6],
        delta_v=out[6:9],
        delta_t=float(out[9]),
        preintegrated=out[0:9],
        covariance=0.5 * (S + S.T),
        bias_jacobian=J,
        bias_hat=b,
        gravity=P.gravity,
        n_samples=int(dt_.shape[0]),
    )
