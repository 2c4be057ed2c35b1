"""On-manifold IMU preintegration (Forster et al.), vectorized over samples.

Reference: C. Forster, L. Carlone, F. Dellaert, D. Scaramuzza, "On-Manifold Preintegration for
Real-Time Visual-Inertial Odometry", IEEE TRO 33(1), 2017, and its supplementary material. The
numbers reproduce GTSAM 4.3's ``ManifoldPreintegration`` (``PreintegratedImuMeasurementsManifold``
in Python, *not* the default ``PreintegratedImuMeasurements``, which is the tangent
preintegration): ``gtsam/navigation/ManifoldPreintegration.cpp`` (``update``,
``biasCorrectedDelta``), ``NavState.cpp`` (``NavState::update``: the transition ``A`` and noise
Jacobians ``B``, ``C``; ``predictPIM``), ``ImuFactor.cpp``
(``PreintegratedImuMeasurementsT::integrateMeasurement``: the covariance recursion) and
``PreintegrationBase.cpp`` (``correctMeasurementsBySensorPose``, ``predict``).

Conventions
-----------
* Frames: ``i`` is the body frame at the first sample, ``k`` the body frame at sample ``k``.
  ``delta_R`` = R_ik (maps frame-k coordinates to frame i), ``delta_p`` and ``delta_v`` are
  expressed in frame ``i`` and exclude gravity; ``gravity`` is ``params.n_gravity`` in the
  navigation (world) frame.
* Samples are in the sensor frame; with ``params.body_P_sensor = (bRs, r)`` they are moved to the
  body frame as GTSAM does: ``ω = bRs (ω_m − b_g)``, ``a = bRs (a_m − b_a) − ω × (ω × r)``.
* Sample ``k`` is held over ``[t_k, t_k + dt_k)``: ``ΔR_{k+1} = ΔR_k Exp(ω_k dt_k)``,
  ``Δv_{k+1} = Δv_k + ΔR_k a_k dt_k``, ``Δp_{k+1} = Δp_k + Δv_k dt_k + ½ ΔR_k a_k dt_k²``.
* Covariance: 9×9 in GTSAM's order (rot, pos, vel), in the chart of ``NavState::retract`` at
  ``(ΔR, Δp, Δv)``: ``(ΔR·Exp(δφ), Δp + ΔR·δp, Δv + ΔR·δv)``. It equals GTSAM's
  ``preintMeasCov()`` and ``residualCovariance()`` (the ``ImuFactor`` noise model).
* Bias vectors are ``(acc, gyro)`` (``ConstantBias.vector()`` order). Bias Jacobians:
  ``ΔR(b̂ + δb) ≈ ΔR·Exp(dR_dbg δb_g)`` (right perturbation, with the right Jacobian ``J_r``:
  ``dR_dbg = −Σ_k ΔR_{k+1,N}ᵀ J_r(ω_k dt_k) dt_k``, Forster et al. 2017; pitfall P3 of
  docs/common-formula-errors.md), while ``Δp`` and ``Δv`` are corrected additively in frame
  ``i``: ``Δp + dp_dba δb_a + dp_dbg δb_g``.

Vectorization
-------------
No Python loop runs per sample; the kernel is :mod:`liebridge.imu.kernel` (its docstring
derives each step). The covariance and bias Jacobians are closed-form sums over samples instead of
a sequential recursion, so only the rotation prefix products are sequential. In numpy, those are
a banded triangular solve in LAPACK, and the velocity and position terms are blocked suffix sums.
Where a C compiler was found at install time, the per-sample sums of the common case (isotropic
noise densities, no lever arm) come from a small compiled loop (``_imu_ext.c``, two passes over
the samples), about twice as fast as numpy. Either way the Python assembly of the covariance and
Jacobians is the same code, and both kernels are tested against each other and against GTSAM.
``_imu_kernel.COMPILED`` says whether the compiled kernel was built.

Long inputs are cut into blocks of 8,192 samples, integrated from the identity and concatenated
*exactly*: ``ΔR = ΔR₁ΔR₂``, and the covariance and bias Jacobians by the chain rule.
:class:`ImuPreintegrator` uses the same concatenation. Scratch arrays are kept per thread between
calls (about 9 MB with the numpy kernel, 1.4 MB with the compiled one).
``benchmarks/bench_imu.py`` measures both kernels against GTSAM's per-sample loop in one run.

Sensor pose
-----------
``body_P_sensor`` is supported. ``delta_*`` and ``covariance`` equal GTSAM's. The bias Jacobians
are the derivatives of the re-integration with respect to the bias, which is defined in the sensor
frame: they include ``bRs`` and the lever-arm term. GTSAM's ``ManifoldPreintegration`` omits both
(its recursion uses the body-frame ``ω``, ``a`` without the chain rule through ``bRs``), so with a
rotated sensor its bias Jacobians do not match finite differences of its own re-integration and
differ from these (tests/test_imu_preintegration.py shows both facts).

A non-zero ``params.omegaCoriolis`` is rejected (GTSAM then predicts in a rotating frame, which is
not implemented here).
"""

from __future__ import annotations

import array
import dataclasses
import math
from typing import Any, Literal, NamedTuple

import gtsam
import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..lie import so3
from .inputs import freeze_arrays, read_bias, read_params, read_samples
from .kernel import Delta, check_delta_finite, compiled_applies, compose, integrate_blocks

__all__ = ["ImuDelta", "ImuPreintegrator", "PreintegratedImu", "imu_kernel", "preintegrate"]


# --------------------------------------------------------------------------------------------
# results


class ImuDelta(NamedTuple):
    """A bias-corrected preintegrated increment ``(ΔR, Δp, Δv)``, frame ``i``, gravity excluded."""

    delta_R: FloatArray
    delta_p: FloatArray
    delta_v: FloatArray


@dataclasses.dataclass(frozen=True, eq=False)
class PreintegratedImu:
    """Preintegrated IMU measurements between two keyframes ``i`` and ``j``.

    Attributes
    ----------
    delta_R : ndarray, shape (3, 3)
        R_ij, rotation of frame ``j`` in frame ``i``.
    delta_p, delta_v : ndarray, shape (3,)
        Position and velocity increments in frame ``i``, gravity excluded.
    delta_t : float
        Integrated time (s).
    covariance : ndarray, shape (9, 9)
        Order (rot, pos, vel), chart ``(ΔR·Exp(δφ), Δp + ΔR δp, Δv + ΔR δv)`` (GTSAM's
        ``preintMeasCov``); it is the noise model of :func:`liebridge.factors.imu`.
    dR_dbg, dp_dba, dp_dbg, dv_dba, dv_dbg : ndarray, shape (3, 3)
        First-order bias Jacobians (see :meth:`bias_corrected`). GTSAM's names:
        ``delRdelBiasOmega``, ``delPdelBiasAcc``, ``delPdelBiasOmega``, ``delVdelBiasAcc``,
        ``delVdelBiasOmega``.
    bias_hat : ndarray, shape (6,)
        Bias estimate used while integrating, order (acc, gyro).
    gravity : ndarray, shape (3,)
        Gravity in the navigation frame (``params.n_gravity``).
    n_samples : int
        Number of integrated samples (0 when built from a GTSAM object).
    """

    delta_R: FloatArray
    delta_p: FloatArray
    delta_v: FloatArray
    delta_t: float
    covariance: FloatArray
    dR_dbg: FloatArray
    dp_dba: FloatArray
    dp_dbg: FloatArray
    dv_dba: FloatArray
    dv_dbg: FloatArray
    bias_hat: FloatArray
    gravity: FloatArray
    n_samples: int = 0

    def __post_init__(self) -> None:
        freeze_arrays(self, scalars=("delta_t", "n_samples"))

    @property
    def bias_jacobian(self) -> FloatArray:
        """``(9, 6)``: rows (rot, pos, vel) as in :meth:`bias_corrected`, columns (acc, gyro)."""
        J = np.zeros((9, 6))
        J[0:3, 3:6] = self.dR_dbg
        J[3:6] = np.hstack([self.dp_dba, self.dp_dbg])
        J[6:9] = np.hstack([self.dv_dba, self.dv_dbg])
        return J

    @classmethod
    def _from_delta(cls, d: Delta, bias_hat: FloatArray, gravity: FloatArray) -> PreintegratedImu:
        return cls(
            delta_R=d.R,
            delta_p=d.p,
            delta_v=d.v,
            delta_t=d.delta_t,
            covariance=d.cov,
            dR_dbg=d.J[0:3, 3:6],
            dp_dba=d.J[3:6, 0:3],
            dp_dbg=d.J[3:6, 3:6],
            dv_dba=d.J[6:9, 0:3],
            dv_dbg=d.J[6:9, 3:6],
            bias_hat=bias_hat,
            gravity=gravity,
            n_samples=d.n,
        )

    @classmethod
    def from_gtsam(cls, pim: Any, params: Any) -> PreintegratedImu:
        """Read a GTSAM preintegrated-measurements object (manifold or tangent).

        The deltas come from ``deltaRij/deltaPij/deltaVij``, the covariance from
        ``residualCovariance()`` (what ``gtsam.ImuFactor`` whitens with) and the bias Jacobians
        from ``pim.predict(NavState(), biasHat, H1, H2)``: ``dR_dbg = H2[0:3, 3:6]``, ``dp_db =
        ΔR·H2[3:6]``, ``dv_db = ΔR·H2[6:9]`` (GTSAM's NavState chart rotates position and
        velocity rows into the predicted frame). For a tangent preintegration the bias correction
        of the result is Forster's (manifold) rule, which agrees with GTSAM's tangent rule to first
        order in the bias change only. With a rotated ``body_P_sensor`` GTSAM's bias Jacobians
        lack the sensor rotation (see the module docstring); they are read as GTSAM reports them.

        Parameters
        ----------
        pim : gtsam.PreintegratedImuMeasurements or gtsam.PreintegratedImuMeasurementsManifold
        params : gtsam.PreintegrationParams
            The parameters ``pim`` was built with (Python cannot read them back from ``pim``).
        """
        P = read_params(params)
        bias_hat = read_bias(pim.biasHat(), "pim.biasHat()")
        H1 = np.zeros((9, 9), order="F")
        H2 = np.zeros((9, 6), order="F")
        pim.predict(gtsam.NavState(), pim.biasHat(), H1, H2)
        R = np.array(pim.deltaRij().matrix())
        J = np.zeros((9, 6))
        J[0:3] = H2[0:3]
        J[3:6] = R @ H2[3:6]
        J[6:9] = R @ H2[6:9]
        d = Delta(
            delta_t=float(pim.deltaTij()),
            n=0,
            R=R,
            p=np.array(pim.deltaPij(), dtype=np.float64),
            v=np.array(pim.deltaVij(), dtype=np.float64),
            cov=np.array(pim.residualCovariance(), dtype=np.float64),
            J=J,
        )
        return cls._from_delta(d, bias_hat, P.gravity)

    def bias_corrected(self, bias: Any) -> ImuDelta:
        """First-order bias correction (Forster et al.; GTSAM ``biasCorrectedDelta``).

        ``ΔR(b) = ΔR·Exp(dR_dbg δb_g)``, ``Δp(b) = Δp + dp_dba δb_a + dp_dbg δb_g``,
        ``Δv(b) = Δv + dv_dba δb_a + dv_dbg δb_g`` with ``δb = b − bias_hat``.

        Parameters
        ----------
        bias : gtsam.imuBias.ConstantBias, (acc, gyro) pair of arrays, or array (..., 6)
            Order (acc, gyro); batched over leading dimensions.

        Returns
        -------
        ImuDelta
            ``delta_R`` (..., 3, 3), ``delta_p`` (..., 3), ``delta_v`` (..., 3).
        """
        db = read_bias(bias) - self.bias_hat
        dba, dbg = db[..., :3], db[..., 3:]
        R = self.delta_R @ so3.exp(dbg @ self.dR_dbg.T)
        p = self.delta_p + dba @ self.dp_dba.T + dbg @ self.dp_dbg.T
        vel = self.delta_v + dba @ self.dv_dba.T + dbg @ self.dv_dbg.T
        return ImuDelta(R, p, vel)

    def predict(self, pose_i: Any, vel_i: Any, bias: Any) -> tuple[FloatArray, FloatArray]:
        """Predict the state at ``j`` (GTSAM ``PreintegrationBase::predict``, no Coriolis).

        ``R_j = R_i ΔR(b)``, ``p_j = p_i + v_i Δt + ½ g Δt² + R_i Δp(b)``,
        ``v_j = v_i + g Δt + R_i Δv(b)``.

        Parameters
        ----------
        pose_i : array_like, shape (..., 4, 4)
            ``T_world_body`` at ``i``.
        vel_i : array_like, shape (..., 3)
            Velocity at ``i`` in the world (navigation) frame.
        bias : see :meth:`bias_corrected`

        Returns
        -------
        pose_j : ndarray, shape (..., 4, 4)
        vel_j : ndarray, shape (..., 3)
        """
        T_i = validate.pose(pose_i, "pose_i")
        v_i = validate.vector(vel_i, "vel_i", 3)
        dR, dp, dv = self.bias_corrected(bias)
        R_i, p_i = T_i[..., :3, :3], T_i[..., :3, 3]
        t, g = self.delta_t, self.gravity
        R_j = R_i @ dR
        p_j = p_i + v_i * t + 0.5 * g * t * t + np.einsum("...ij,...j->...i", R_i, dp)
        v_j = v_i + g * t + np.einsum("...ij,...j->...i", R_i, dv)
        R_j, p_j = np.broadcast_arrays(R_j, p_j[..., None])
        T_j = np.zeros((*R_j.shape[:-2], 4, 4))
        T_j[..., :3, :3] = R_j
        T_j[..., :3, 3] = p_j[..., 0]
        T_j[..., 3, 3] = 1.0
        return T_j, v_j


# --------------------------------------------------------------------------------------------
# public entry points


def preintegrate(acc: Any, gyro: Any, dt: Any, *, bias: Any, params: Any) -> PreintegratedImu:
    """Preintegrate IMU samples on the manifold, vectorized over samples.

    Reproduces ``gtsam.PreintegratedImuMeasurementsManifold`` fed with the same samples (see the
    module docstring for the conventions and the one deliberate difference with a rotated
    ``body_P_sensor``).

    Parameters
    ----------
    acc : array_like, shape (N, 3)
        Accelerometer samples (specific force, m/s²), sensor frame.
    gyro : array_like, shape (N, 3)
        Gyroscope samples (rad/s), sensor frame.
    dt : float or array_like, shape (N,)
        Duration each sample is held (s), > 0.
    bias : gtsam.imuBias.ConstantBias, (acc, gyro) pair of 3-vectors, or array (6,)
        Bias estimate ``b̂`` subtracted from the samples, order (acc, gyro).
    params : gtsam.PreintegrationParams
        Gravity, continuous-time noise covariances, integration covariance, optional
        ``body_P_sensor``. ``omegaCoriolis`` must be unset or zero.

    Returns
    -------
    PreintegratedImu

    Raises
    ------
    ValueError
        Wrong shapes, mismatched lengths, NaN/Inf, ``dt ≤ 0`` (naming the index), an unusable
        ``params``.
    """
    acc_, gyro_, dt_ = read_samples(acc, gyro, dt)
    P = read_params(params)
    b = read_bias(bias)
    if b.shape != (6,):
        raise ValueError(f"bias: expected one bias (6,), got shape {b.shape}")
    return PreintegratedImu._from_delta(integrate_blocks(acc_, gyro_, dt_, b, P), b, P.gravity)


def imu_kernel(params: Any) -> Literal["compiled", "numpy"]:
    """Return which kernel :func:`preintegrate` uses with ``params``: ``"compiled"`` or ``"numpy"``.

    The compiled kernel (``liebridge/imu/_imu_ext.c``, built at install time where a C compiler
    is found) covers isotropic noise densities without a lever arm in ``body_P_sensor``; anything
    else, or an install without the compiled kernel, uses numpy. Both give the same numbers (to
    rounding; tested against each other and against GTSAM).
    """
    return "compiled" if compiled_applies(read_params(params)) else "numpy"


class ImuPreintegrator:
    """Incremental preintegration for online use.

    Samples given to :meth:`integrate` are validated immediately and buffered; they are
    integrated in one vectorized pass when a result is requested, and passes are concatenated
    exactly (``ΔR = ΔR₁ΔR₂``, covariance and bias Jacobians by the chain rule). One sample per
    call costs about 1.7 µs: the sample is checked and appended to a flat buffer (measured against
    2.2 µs for GTSAM's ``integrateMeasurement`` on the same machine). :meth:`result` then costs one
    :func:`preintegrate` call on the samples buffered since the last result. Blocks of samples per
    call avoid the per-call cost.

    Parameters
    ----------
    params : gtsam.PreintegrationParams
    bias : bias estimate, as for :func:`preintegrate` (default zero)
    """

    def __init__(self, params: Any, bias: Any = None) -> None:
        self._P = read_params(params)
        self.reset(bias)

    def reset(self, bias: Any = None) -> None:
        """Forget all samples; optionally set a new bias estimate (default: keep it)."""
        if bias is not None or not hasattr(self, "_bias"):
            b = np.zeros(6) if bias is None else read_bias(bias)
            if b.shape != (6,):
                raise ValueError(f"bias: expected one bias (6,), got shape {b.shape}")
            self._bias = b
        self._done: Delta | None = None
        self._blocks: list[tuple[FloatArray, FloatArray, FloatArray]] = []
        self._rows = array.array("d")  # single samples, 7 numbers each: ax ay az wx wy wz dt
        self._buffered = 0

    @property
    def bias_hat(self) -> FloatArray:
        """Bias estimate in use, (acc, gyro)."""
        return self._bias.copy()

    @property
    def n_samples(self) -> int:
        """Number of samples integrated so far."""
        return (self._done.n if self._done is not None else 0) + self._buffered

    def integrate(self, acc: Any, gyro: Any, dt: Any) -> None:
        """Add one sample ``(3,), (3,), scalar`` or a block ``(N, 3), (N, 3), (N,) or scalar``.

        Raises ``ValueError`` naming the argument, the sample index (counted from the last
        :meth:`reset`) and the offending value; a rejected call adds nothing.
        """
        if (  # the common case first, checked without numpy calls (about 1 µs a sample)
            type(acc) is np.ndarray
            and type(gyro) is np.ndarray
            and acc.shape == (3,)
            and gyro.shape == (3,)
            and acc.dtype.kind == "f"
            and gyro.dtype.kind == "f"
            and isinstance(dt, float)  # np.float64 is a float
        ):
            row = [*acc.tolist(), *gyro.tolist(), float(dt)]
        elif np.ndim(dt) == 0 and np.ndim(acc) == 1 and np.ndim(gyro) == 1:
            row = [*_sample3(acc, "acc"), *_sample3(gyro, "gyro"), float(dt)]
        else:
            row = None
        if row is not None:
            if not all(map(math.isfinite, row)) or not row[6] > 0.0:
                _reject_sample(row, self.n_samples)
            self._rows.extend(row)
            self._buffered += 1
            return
        try:
            a, g, d_ = read_samples(acc, gyro, dt)
        except ValueError as exc:
            raise ValueError(f"{exc} (block starting at sample {self.n_samples})") from None
        self._stash_rows()
        self._blocks.append((a.copy(), g.copy(), d_.copy()))
        self._buffered += d_.shape[0]

    def _stash_rows(self) -> None:
        if self._rows:
            rows = np.frombuffer(self._rows, dtype=np.float64).reshape(-1, 7).copy()
            self._blocks.append((rows[:, 0:3], rows[:, 3:6], rows[:, 6].copy()))
            self._rows = array.array("d")

    def _flush(self) -> None:
        self._stash_rows()
        if not self._blocks:
            return
        a = np.concatenate([b[0] for b in self._blocks])
        g = np.concatenate([b[1] for b in self._blocks])
        d = np.concatenate([b[2] for b in self._blocks])
        block = integrate_blocks(a, g, d, self._bias, self._P)
        if self._done is not None:
            with np.errstate(all="ignore"):
                block = compose(self._done, block)
            check_delta_finite(block)
        self._done = block
        self._blocks, self._buffered = [], 0

    @property
    def delta_t(self) -> float:
        """Integrated time so far (s)."""
        self._flush()
        return self._done.delta_t if self._done is not None else 0.0

    def result(self) -> PreintegratedImu:
        """Return the preintegrated measurements of every sample so far (raises if none)."""
        self._flush()
        if self._done is None:
            raise ValueError("ImuPreintegrator.result: no samples integrated yet")
        return PreintegratedImu._from_delta(self._done, self._bias, self._P.gravity)


def _sample3(x: Any, name: str) -> list[float]:
    """One 3-vector sample as a list of floats (cheap: no numpy array is built)."""
    try:
        vals = x.tolist() if isinstance(x, np.ndarray) else [float(c) for c in x]
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name}: expected a numeric 3-vector ({exc})") from None
    if len(vals) != 3:
        raise ValueError(f"{name}: expected shape (3,) or (N, 3), got ({len(vals)},)")
    return [float(c) for c in vals] if not isinstance(vals[0], float) else vals


def _reject_sample(row: list[float], index: int) -> None:
    for name, off in (("acc", 0), ("gyro", 3)):
        for i in range(3):
            if not math.isfinite(row[off + i]):
                raise ValueError(f"{name}: contains NaN or Inf at sample {index}, entry {i}")
    raise ValueError(f"dt: must be finite and > 0, got {row[6]:.6g} at sample {index}")
