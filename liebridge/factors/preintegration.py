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
  ``dR_dbg = −Σ_k ΔR_{k+1,N}ᵀ J_r(ω_k dt_k) dt_k``, design note §9.3), while ``Δp`` and ``Δv``
  are corrected additively in frame ``i``: ``Δp + dp_dba δb_a + dp_dbg δb_g``.

Vectorization
-------------
No Python loop runs per sample. The rotation increments ``Exp(ω_k dt_k)`` are built in one batched
call as unit quaternions (held as complex pairs, so that a Hamilton product is four complex
multiplications) and their prefix products ``ΔR_k`` come from a blocked scan (≈ 2N products,
depth log₈ N). ``Δv``, ``Δp`` are cumulative sums. The covariance recursion
``Σ_{k+1} = A_k Σ_k A_kᵀ + B_k Q_a B_kᵀ/dt + C_k Q_g C_kᵀ/dt + G Q_i Gᵀ dt`` is linear; expressed
in frame-``i`` coordinates (rotation perturbed on the left, position and velocity additively) the
transition from sample ``k+1`` to the end has the closed form
``Φ = [[I, 0, 0], [−[p̃_k]×, I, τ_k I], [−[ṽ_k]×, 0, I]]`` with ``τ_k = T − t_{k+1}``,
``ṽ_k = Δv_N − Δv_{k+1}``, ``p̃_k = Δp_N − Δp_{k+1} − τ_k Δv_{k+1}``, so that
``Σ = Σ_k (Φ_k G_k) Q_k (Φ_k G_k)ᵀ`` is a matrix product over samples instead of a sequential
recursion (with isotropic gyroscope noise, ``J_r J_rᵀ = a I + b θθᵀ`` reduces it further to
outer-product sums). The bias Jacobians are ``−Σ_k Φ_k G_k``: the same per-sample blocks, summed.
Long inputs are cut into blocks of 4,096 samples (cache-sized), each integrated from the identity
and concatenated *exactly* (``ΔR = ΔR₁ΔR₂``; covariance and bias Jacobians by the chain rule), the
same operation :class:`ImuPreintegrator` uses. ``benchmarks/bench_imu.py`` measures the result
against GTSAM's per-sample loop; short windows (≲ 300 samples) are dominated by the fixed cost of
a few hundred numpy calls and are faster in GTSAM's loop.

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

import dataclasses
import math
from typing import Any, NamedTuple

import gtsam
import numpy as np
import numpy.typing as npt

from .. import _validate as v
from .._validate import FloatArray
from ..lie import so3

__all__ = ["ImuDelta", "ImuPreintegrator", "PreintegratedImu", "preintegrate"]


# --------------------------------------------------------------------------------------------
# inputs


def _is_isotropic(C: FloatArray) -> bool:
    return bool(np.all(C == C[0, 0] * np.eye(3)))


@dataclasses.dataclass(frozen=True)
class _Params:
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


def _read_params(params: Any) -> _Params:
    if not isinstance(params, gtsam.PreintegrationParams):
        raise TypeError(
            f"params: expected a gtsam.PreintegrationParams, got {type(params).__name__}"
        )
    coriolis = params.getOmegaCoriolis()
    if coriolis is not None and np.any(np.asarray(coriolis) != 0.0):
        raise ValueError(
            f"params: omegaCoriolis = {np.asarray(coriolis).tolist()} is not supported "
            "(GTSAM then predicts in a rotating frame); set it to None or zero"
        )
    gravity = v.vector(np.array(params.n_gravity, dtype=np.float64), "params.n_gravity", 3)
    if gravity.shape != (3,):
        raise ValueError(f"params.n_gravity: expected shape (3,), got {gravity.shape}")

    def cov(x: Any, name: str) -> FloatArray:
        c = v.covariance(np.array(x, dtype=np.float64), name, 3)
        if c.shape != (3, 3):
            raise ValueError(f"{name}: expected shape (3, 3), got {c.shape}")
        return np.asarray(0.5 * (c + c.T))

    acc_cov = cov(params.getAccelerometerCovariance(), "params.accelerometerCovariance")
    gyro_cov = cov(params.getGyroscopeCovariance(), "params.gyroscopeCovariance")
    int_cov = cov(params.getIntegrationCovariance(), "params.integrationCovariance")
    bRs = lever = None
    body_P_sensor = params.getBodyPSensor()
    if body_P_sensor is not None:
        bRs = v.rotation(np.array(body_P_sensor.rotation().matrix()), "params.body_P_sensor")
        t = np.array(body_P_sensor.translation(), dtype=np.float64)
        lever = t if np.any(t != 0.0) else None
        if not _is_isotropic(acc_cov):
            acc_cov = bRs @ acc_cov @ bRs.T
        if lever is None and not _is_isotropic(gyro_cov):
            gyro_cov = bRs @ gyro_cov @ bRs.T
    return _Params(
        gravity=gravity.copy(),
        acc_cov=acc_cov,
        gyro_cov=gyro_cov,
        int_cov=int_cov,
        body_R_sensor=bRs,
        lever_arm=lever,
        fast=lever is None and _is_isotropic(gyro_cov),
    )


def _read_bias(bias: Any, name: str = "bias") -> FloatArray:
    """Return a bias as a ``(..., 6)`` array in (acc, gyro) order."""
    if isinstance(bias, gtsam.imuBias.ConstantBias):
        return np.array(bias.vector(), dtype=np.float64)
    if isinstance(bias, (tuple, list)) and len(bias) == 2:
        acc = v.vector(bias[0], f"{name}[0] (accelerometer)", 3)
        gyro = v.vector(bias[1], f"{name}[1] (gyroscope)", 3)
        acc, gyro = np.broadcast_arrays(acc, gyro)
        return np.concatenate([acc, gyro], axis=-1)
    return v.vector(bias, f"{name} (acc, gyro)", 6)


def _read_samples(acc: Any, gyro: Any, dt: Any) -> tuple[FloatArray, FloatArray, FloatArray]:
    acc_ = v.as_float_array(acc, "acc")
    gyro_ = v.as_float_array(gyro, "gyro")
    for arr, name in ((acc_, "acc"), (gyro_, "gyro")):
        if arr.ndim != 2 or arr.shape[1] != 3:
            raise ValueError(f"{name}: expected shape (N, 3), got {arr.shape}")
    n = acc_.shape[0]
    if gyro_.shape[0] != n:
        raise ValueError(f"gyro: {gyro_.shape[0]} samples but acc has {n}")
    if n == 0:
        raise ValueError("acc: no samples (N = 0)")
    v.check_finite(acc_, "acc", core_ndim=1)
    v.check_finite(gyro_, "gyro", core_ndim=1)
    dt_ = v.as_float_array(dt, "dt")
    if dt_.ndim == 0:
        dt_ = np.full(n, float(dt_))
    elif dt_.shape != (n,):
        raise ValueError(f"dt: expected a scalar or shape ({n},) to match acc, got {dt_.shape}")
    v.check_finite(dt_, "dt")
    bad = dt_ <= 0.0
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(
            f"dt: must be > 0, got dt[{i}] = {dt_[i]:.6g} ({int(bad.sum())} of {n} values ≤ 0)"
        )
    return acc_, gyro_, dt_


# --------------------------------------------------------------------------------------------
# structure-of-arrays helpers: vectors (3, n), matrices (3, 3, n); `out` may not alias inputs


def _mv(A: FloatArray, x: FloatArray) -> FloatArray:
    """``A_k x_k`` for ``A`` (3, 3, n), ``x`` (3, n)."""
    return np.asarray(np.einsum("ijn,jn->in", A, x))


def _cols_cross(M: FloatArray, x: FloatArray, out: FloatArray) -> FloatArray:
    """``−[x]× M`` (each column of ``M`` crossed with ``x``) for ``x`` (3, n), ``M`` (3, 3, n)."""
    np.multiply(M[1], x[2], out=out[0])
    out[0] -= M[2] * x[1]
    np.multiply(M[2], x[0], out=out[1])
    out[1] -= M[0] * x[2]
    np.multiply(M[0], x[1], out=out[2])
    out[2] -= M[1] * x[0]
    return out


# Unit quaternions w + x i + y j + z k are held as complex pairs (α, β) = (w + x i, y + z i),
# q = α + β j (Cayley–Dickson). The Hamilton product is then four complex products:
# (α₁, β₁)(α₂, β₂) = (α₁α₂ − β₁β̄₂, α₁β₂ + β₁ᾱ₂): a quarter of the array operations of the
# real 16-product form, which is what a vectorized scan is bound by.
ComplexArray = npt.NDArray[np.complex128]


def _cmul(
    a1: ComplexArray, b1: ComplexArray, a2: ComplexArray, b2: ComplexArray
) -> tuple[ComplexArray, ComplexArray]:
    return a1 * a2 - b1 * b2.conj(), a1 * b2 + b1 * a2.conj()


def _qscan_small(a: ComplexArray, b: ComplexArray) -> tuple[ComplexArray, ComplexArray]:
    """Sequential prefix products for a few quaternions (Python complex numbers)."""
    xa, xb = a.tolist(), b.tolist()
    oa, ob = [xa[0]], [xb[0]]
    p, q = xa[0], xb[0]
    for u, w in zip(xa[1:], xb[1:], strict=True):
        p, q = p * u - q * w.conjugate(), p * w + q * u.conjugate()
        oa.append(p)
        ob.append(q)
    return np.array(oa, dtype=np.complex128), np.array(ob, dtype=np.complex128)


_SCAN_BLOCK = 8


def _qscan(a: ComplexArray, b: ComplexArray) -> tuple[ComplexArray, ComplexArray]:
    """Inclusive prefix products ``q_0 q_1 … q_k`` of quaternions given as (α, β), shape (n,).

    Blocked scan: prefix products inside blocks of 8 consecutive samples (7 batched products
    over all blocks at once), a recursive scan of the block totals, then one batched product
    applying each block's predecessor total. About 2n products, recursion depth log₈ n.
    """
    n = a.shape[0]
    bs = _SCAN_BLOCK
    if n <= 2 * bs:
        return _qscan_small(a, b)
    m = n // bs
    head = m * bs
    A = a[:head].reshape(m, bs).T.copy()  # (bs, m): row j holds sample j of every block
    B = b[:head].reshape(m, bs).T.copy()
    for j in range(1, bs):
        A[j], B[j] = _cmul(A[j - 1], B[j - 1], A[j], B[j])
    ta, tb = _qscan(A[bs - 1].copy(), B[bs - 1].copy())
    A[:, 1:], B[:, 1:] = _cmul(ta[None, :-1], tb[None, :-1], A[:, 1:], B[:, 1:])
    out_a = np.empty_like(a)
    out_b = np.empty_like(b)
    out_a[:head] = A.T.reshape(head)
    out_b[:head] = B.T.reshape(head)
    if head < n:
        xa, xb = _qscan_small(
            np.concatenate([out_a[head - 1 : head], a[head:]]),
            np.concatenate([out_b[head - 1 : head], b[head:]]),
        )
        out_a[head:], out_b[head:] = xa[1:], xb[1:]
    return out_a, out_b


def _quat_to_R(a: ComplexArray, b: ComplexArray, out: FloatArray) -> FloatArray:
    """Rotation matrices (3, 3, n) of quaternions (α, β), normalised on the fly."""
    w, x, y, z = a.real, a.imag, b.real, b.imag
    s = 2.0 / (a.real**2 + a.imag**2 + b.real**2 + b.imag**2)
    sx, sy, sz = s * x, s * y, s * z
    xx, yy, zz = sx * x, sy * y, sz * z
    xy, xz, yz = sx * y, sx * z, sy * z
    wx, wy, wz = sx * w, sy * w, sz * w
    np.subtract(1.0 - yy, zz, out=out[0, 0])
    np.subtract(xy, wz, out=out[0, 1])
    np.add(xz, wy, out=out[0, 2])
    np.add(xy, wz, out=out[1, 0])
    np.subtract(1.0 - xx, zz, out=out[1, 1])
    np.subtract(yz, wx, out=out[1, 2])
    np.subtract(xz, wy, out=out[2, 0])
    np.add(yz, wx, out=out[2, 1])
    np.subtract(1.0 - xx, yy, out=out[2, 2])
    return out


def _hat(x: FloatArray) -> FloatArray:
    """Single-vector skew matrix (no validation)."""
    return np.array([[0.0, -x[2], x[1]], [x[2], 0.0, -x[0]], [-x[1], x[0], 0.0]])


_E = np.array([_hat(e) for e in np.eye(3)])  # [e_b]×, b = 0, 1, 2


def _blockdiag3(R: FloatArray) -> FloatArray:
    T = np.zeros((9, 9))
    T[0:3, 0:3] = T[3:6, 3:6] = T[6:9, 6:9] = R
    return T


def _weighted_congruence(R9: FloatArray, weights: FloatArray, W: FloatArray) -> FloatArray:
    """``Σ_k w_k R_k W R_kᵀ`` for each row of ``weights`` (m, n); ``R9`` (9, n) → (m, 3, 3).

    One matrix product builds ``Σ_k w_k R_k[i, a] R_k[j, b]`` for every (i, a, j, b); the
    contraction with ``W`` is then a 3×3×3×3 sum independent of n.
    """
    n = R9.shape[1]
    T = (weights[:, None, :] * R9[None]).reshape(-1, n) @ R9.T  # (m·9, 9)
    T = T.reshape(-1, 3, 3, 3, 3)  # (m, i, a, j, b)
    return np.asarray(np.einsum("miajb,ab->mij", T, W))


# --------------------------------------------------------------------------------------------
# the kernel


class _Workspace:
    """Scratch buffers reused by the blocks of one call.

    Arrays above glibc's mmap threshold (128 KiB: the 9-row per-sample arrays of a 4,096-sample
    block) are otherwise mapped afresh and page-faulted for every block; measured, that was a
    quarter of the CPU time.
    """

    def __init__(self) -> None:
        self._bufs: dict[str, FloatArray] = {}

    def get(self, name: str, shape: tuple[int, ...]) -> FloatArray:
        size = math.prod(shape)
        buf = self._bufs.get(name)
        if buf is None or buf.size < size:
            buf = np.empty(size)
            self._bufs[name] = buf
        return buf[:size].reshape(shape)


@dataclasses.dataclass(frozen=True)
class _Delta:
    """Preintegrated numbers of one block of samples, integrated from identity."""

    delta_t: float
    n: int
    R: FloatArray  # (3, 3)
    p: FloatArray  # (3,)
    v: FloatArray  # (3,)
    cov: FloatArray  # (9, 9) body chart (rot, pos, vel)
    J: FloatArray  # (9, 6): rows (rot right-perturbation, pos, vel additive), cols (acc, gyro)


def _integrate(
    acc: FloatArray,
    gyro: FloatArray,
    dt: FloatArray,
    bias: FloatArray,
    P: _Params,
    *,
    general: bool = False,
    ws: _Workspace | None = None,
) -> _Delta:
    """Preintegrate validated samples (N, 3), (N, 3), (N,) with bias estimate ``bias`` (6,).

    Two algebraically identical paths for the gyroscope noise: the general one builds the 9×3
    input block of every sample; the fast one (isotropic gyroscope covariance, no lever arm) uses
    ``J_r J_rᵀ = a I + b θθᵀ`` and ``ΔR θ = u`` to reduce it to outer-product sums (matrix
    products over samples). ``general=True`` forces the general path (tests).
    """
    n = dt.shape[0]
    ws = ws if ws is not None else _Workspace()
    a = np.subtract(acc.T, bias[:3, None], out=np.empty((3, n)))  # (3, n), sensor frame
    w = np.subtract(gyro.T, bias[3:, None], out=np.empty((3, n)))
    bRs = P.body_R_sensor
    D = None  # d(corrected acc)/d(unbiased sensor ω), only with a lever arm
    if bRs is not None:
        a = bRs @ a
        w = bRs @ w
        if P.lever_arm is not None:
            r = P.lever_arm
            wr = r @ w  # ω·r
            a = a - (w * wr - r[:, None] * np.einsum("in,in->n", w, w))  # ω × (ω × r)
            # −[(ω·r) I + ω rᵀ − 2 r ωᵀ] bRs (PreintegrationBase.cpp)
            M = w[:, None, :] * r[None, :, None] - 2.0 * r[:, None, None] * w[None, :, :]
            M[0, 0] += wr
            M[1, 1] += wr
            M[2, 2] += wr
            D = -np.einsum("ijn,jk->ikn", M, bRs)
    general = general or not P.fast

    # rotation increments Exp(θ_k) as quaternions; J_r(θ) = c0 I − B [θ]× + C θθᵀ with
    # c0 = sin θ/θ, B = (1 − cos θ)/θ² = ½ sinc(θ/2)², C = (1 − c0)/θ² (C cancels for small θ,
    # but it only multiplies θθᵀ, so the absolute error of J_r stays ~ eps)
    theta = w * dt
    th2 = np.einsum("in,in->n", theta, theta)
    half = np.sqrt(th2)
    half *= 0.5
    sh = np.sin(half)
    ch = np.cos(half) if half.max() > 0.5 else np.sqrt(1.0 - sh * sh)
    sinc_h = np.divide(sh, half, out=np.ones(n), where=half > 0.0)  # sin(θ/2)/(θ/2)
    s = 0.5 * sinc_h
    qa = np.empty(n, dtype=np.complex128)
    qb = np.empty(n, dtype=np.complex128)
    qa.real = ch
    np.multiply(s, theta[0], out=qa.imag)
    np.multiply(s, theta[1], out=qb.real)
    np.multiply(s, theta[2], out=qb.imag)
    c0 = sinc_h * ch
    B = s * sinc_h
    C = np.divide(1.0 - c0, th2, out=np.full(n, 1.0 / 6.0), where=th2 > 0.0)

    R_all = ws.get("R", (3, 3, n + 1))  # ΔR_0 … ΔR_N
    R_all[:, :, 0] = np.eye(3)
    _quat_to_R(*_qscan(qa, qb), out=R_all[:, :, 1:])
    R_prev, R_next = R_all[:, :, :-1], R_all[:, :, 1:]
    R9_prev = R_all.reshape(9, n + 1)[:, :-1]
    R9_next = R_all.reshape(9, n + 1)[:, 1:]

    # Δv, Δp (frame i), and the carry-to-the-end quantities τ_k, ṽ_k, p̃_k, α_k
    dv = _mv(R_prev, a)  # acceleration in frame i …
    dv *= dt  # … times dt
    v_next = np.cumsum(dv, axis=1)
    dp = dv * (0.5 * dt)
    dp[:, 1:] += v_next[:, :-1] * dt[1:]
    p_next = np.cumsum(dp, axis=1)
    t_next = np.cumsum(dt)
    T = float(t_next[-1])
    tau = T - t_next
    pv_tilde = np.empty((6, n))  # rows: p̃_k, ṽ_k
    p_tilde, v_tilde = pv_tilde[0:3], pv_tilde[3:6]
    np.subtract(v_next[:, -1:], v_next, out=v_tilde)
    np.subtract(p_next[:, -1:], p_next, out=p_tilde)
    p_tilde -= tau * v_next
    alpha = tau + 0.5 * dt
    alpha *= dt

    # gyro input carried to the end, frame i: [Y; −[p̃]× Y; −[ṽ]× Y], Y = ΔR_{k+1} J_r dt
    c0dt, Bdt, Cdt = c0 * dt, B * dt, C * dt
    Jr = np.multiply((Cdt * theta)[:, None, :], theta[None, :, :], out=ws.get("Jr", (3, 3, n)))
    Jr.reshape(9, n)[0::4] += c0dt  # the diagonal
    Bt = Bdt * theta
    Jr[0, 1] += Bt[2]
    Jr[0, 2] -= Bt[1]
    Jr[1, 0] -= Bt[2]
    Jr[1, 2] += Bt[0]
    Jr[2, 0] += Bt[1]
    Jr[2, 1] -= Bt[0]
    if general:
        G = ws.get("G", (9, 3, n))
        Y = np.einsum("ijn,jkn->ikn", R_next, Jr, out=G[0:3])
        _cols_cross(Y, p_tilde, out=G[3:6])
        _cols_cross(Y, v_tilde, out=G[6:9])
        if D is not None:  # lever arm: the gyro also moves the corrected acceleration
            assert bRs is not None
            G = np.einsum("ijn,jk->ikn", G, bRs)
            RD = np.einsum("ijn,jkn->ikn", R_prev, D)
            G[3:6] += RD * alpha
            G[6:9] += RD * dt
            Jg = -(G.reshape(27, n) @ np.ones(n)).reshape(9, 3)
        else:
            Jg = _sum_carried(Y, pv_tilde)
        if _is_isotropic(P.gyro_cov):
            GQ = G * (P.gyro_cov[0, 0] / dt)
        else:
            GQ = np.matmul(P.gyro_cov.T, G) / dt
        cov_i = G.reshape(9, 3 * n) @ GQ.reshape(9, 3 * n).T
    else:
        Y = np.einsum("ijn,jkn->ikn", R_next, Jr, out=ws.get("Y", (3, 3, n)))
        Jg = _sum_carried(Y, pv_tilde)
        cov_i = _gyro_covariance(R_prev, theta, pv_tilde, c0, B, C, th2, dt, P.gyro_cov[0, 0], ws)
    if bRs is not None and D is None:
        Jg = Jg @ bRs

    # accelerometer input [0; α ΔR_k; dt ΔR_k] (times bRs): bias Jacobian and covariance
    Ja = -(R9_prev @ np.stack([alpha, dt], axis=1)).reshape(3, 3, 2)
    Ja = np.concatenate([Ja[:, :, 0], Ja[:, :, 1]])
    if bRs is not None:
        Ja = Ja @ bRs
    if _is_isotropic(P.acc_cov):
        var = P.acc_cov[0, 0]
        cov_i[3:6, 3:6] += (var * float(alpha @ (alpha / dt))) * np.eye(3)
        pv = (var * float(alpha.sum())) * np.eye(3)
        cov_i[6:9, 6:9] += (var * T) * np.eye(3)
    else:
        pp, pv, vv = _weighted_congruence(
            R9_prev, np.stack([alpha * alpha / dt, alpha, dt]), P.acc_cov
        )
        cov_i[3:6, 3:6] += pp
        cov_i[6:9, 6:9] += vv
    cov_i[3:6, 6:9] += pv
    cov_i[6:9, 3:6] += pv.T
    # integration noise, added to the body-frame position at every step
    if _is_isotropic(P.int_cov):
        cov_i[3:6, 3:6] += (P.int_cov[0, 0] * T) * np.eye(3)
    else:
        cov_i[3:6, 3:6] += _weighted_congruence(R9_next, dt[None], P.int_cov)[0]

    RN = R_all[:, :, -1].copy()
    Tb = _blockdiag3(RN)  # frame-i → body-chart coordinates: δ_body = Tbᵀ δ_i
    cov = Tb.T @ cov_i @ Tb
    cov = 0.5 * (cov + cov.T)
    J = np.zeros((9, 6))
    J[0:3, 3:6] = RN.T @ Jg[0:3]
    J[3:9, 0:3] = Ja
    J[3:9, 3:6] = Jg[3:9]
    return _Delta(
        delta_t=T, n=n, R=RN, p=p_next[:, -1].copy(), v=v_next[:, -1].copy(), cov=cov, J=J
    )


def _sum_carried(Y: FloatArray, pv: FloatArray) -> FloatArray:
    """``−Σ_k [Y_k; −[p̃_k]× Y_k; −[ṽ_k]× Y_k]`` (9, 3) from ``Σ_k w_k Y_k``, ``w ∈ {1, p̃, ṽ}``."""
    n = Y.shape[2]
    W = np.empty((7, n))
    W[0] = 1.0
    W[1:] = pv
    S = (W @ Y.reshape(9, n).T).reshape(7, 3, 3)
    J = np.empty((9, 3))
    J[0:3] = -S[0]
    J[3:6] = np.einsum("aij,ajk->ik", _E, S[1:4])  # Σ_k [p̃_k]× Y_k = Σ_a [e_a]× Σ_k p̃_ka Y_k
    J[6:9] = np.einsum("aij,ajk->ik", _E, S[4:7])
    return J


def _gyro_covariance(
    R: FloatArray,
    theta: FloatArray,
    pv: FloatArray,
    c0: FloatArray,
    B: FloatArray,
    C: FloatArray,
    th2: FloatArray,
    dt: FloatArray,
    var: float,
    ws: _Workspace,
) -> FloatArray:
    """Frame-i covariance of isotropic gyro noise (variance density ``var``) carried to the end.

    Per sample ``Y Q Yᵀ/dt = var·dt·ΔR J_r J_rᵀ ΔRᵀ = var·dt (a I + b u uᵀ)`` with
    ``u = ΔR_k θ_k``, ``a = c0² + B²θ²``, ``b = 2 c0 C + C²θ² − B²``; the blocks ``S Z Sᵀ`` with
    ``S = [I; −[p̃]×; −[ṽ]×]`` then only need outer-product sums, using
    ``[x]× u uᵀ [y]×ᵀ = (x×u)(y×u)ᵀ`` and ``[x]× [y]×ᵀ = (x·y) I − y xᵀ``.
    """
    n = theta.shape[1]
    B2 = B * B
    wa = dt * (c0 * c0 + B2 * th2)
    wb = dt * (C * (2.0 * c0 + C * th2) - B2)
    V = ws.get("V", (9, n))  # rows: u, p̃ × u, ṽ × u
    u = np.einsum("ijn,jn->in", R, theta, out=V[0:3])
    for r in (0, 3):
        x, o = pv[r : r + 3], V[r + 3 : r + 6]
        for i, j, k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
            np.multiply(x[j], u[k], out=o[i])
            o[i] -= x[k] * u[j]
    VW = np.multiply(V, wb, out=ws.get("VW", (9, n)))
    cov = VW @ V.T  # Σ wb (·)(·)ᵀ over u, p̃ × u, ṽ × u
    cov[3:9, 0:3] *= -1.0
    cov[0:3, 3:9] *= -1.0
    PW = np.multiply(pv, wa, out=ws.get("PW", (6, n)))
    M4 = (PW @ pv.T).reshape(2, 3, 2, 3)  # [r, i, c, j] = Σ wa x_r[i] x_c[j], x ∈ {p̃, ṽ}
    I3 = np.eye(3)
    cov[0:3, 0:3] += float(wa.sum()) * I3
    hats = -np.einsum("rb,bij->rij", PW.sum(axis=1).reshape(2, 3), _E).reshape(6, 3)
    cov[3:9, 0:3] += hats  # Σ −wa [x]×
    cov[0:3, 3:9] += hats.T
    tr = np.einsum("rici->rc", M4)
    cov[3:9, 3:9] += (
        tr[:, None, :, None] * I3[None, :, None, :] - M4.transpose(0, 3, 2, 1)
    ).reshape(6, 6)
    return np.asarray(var * cov)


def _compose(d1: _Delta, d2: _Delta) -> _Delta:
    """Concatenate two blocks integrated with the same bias estimate (exact, not approximate)."""
    R1, p1, v1, T2 = d1.R, d1.p, d1.v, d2.delta_t
    # transition of block 2 in body charts: blockdiag(R2ᵀ) [[I,0,0],[−[p2]×,I,T2 I],[−[v2]×,0,I]]
    F = np.eye(9)
    F[3:6, 0:3] = -_hat(d2.p)
    F[3:6, 6:9] = T2 * np.eye(3)
    F[6:9, 0:3] = -_hat(d2.v)
    F = _blockdiag3(d2.R.T) @ F
    cov = F @ d1.cov @ F.T + d2.cov
    J1, J2 = d1.J, d2.J
    D1 = J1[0:3, 3:6]
    J = np.zeros((9, 6))
    J[0:3, 3:6] = d2.R.T @ D1 + J2[0:3, 3:6]
    J[3:6] = J1[3:6] + T2 * J1[6:9] + R1 @ J2[3:6]
    J[3:6, 3:6] -= R1 @ _hat(d2.p) @ D1
    J[6:9] = J1[6:9] + R1 @ J2[6:9]
    J[6:9, 3:6] -= R1 @ _hat(d2.v) @ D1
    return _Delta(
        delta_t=d1.delta_t + T2,
        n=d1.n + d2.n,
        R=R1 @ d2.R,
        p=p1 + v1 * T2 + R1 @ d2.p,
        v=v1 + R1 @ d2.v,
        cov=0.5 * (cov + cov.T),
        J=J,
    )


#: Samples per vectorized block. Blocks are concatenated exactly with :func:`_compose`; the size
#: keeps the ~30 per-sample work arrays inside the CPU cache (measured: 2-4k samples per block run
#: about twice as fast per sample as one 40k block).
_BLOCK = 4096


def _integrate_blocks(
    acc: FloatArray, gyro: FloatArray, dt: FloatArray, bias: FloatArray, P: _Params
) -> _Delta:
    n = dt.shape[0]
    out: _Delta | None = None
    ws = _Workspace()
    for s in range(0, n, _BLOCK):
        e = min(n, s + _BLOCK)
        if n - e < _BLOCK // 4:  # fold a short tail into the last block
            e = n
        d = _integrate(acc[s:e], gyro[s:e], dt[s:e], bias, P, ws=ws)
        out = d if out is None else _compose(out, d)
        if e == n:
            break
    assert out is not None
    return out


# --------------------------------------------------------------------------------------------
# results


class ImuDelta(NamedTuple):
    """A bias-corrected preintegrated increment ``(ΔR, Δp, Δv)``, frame ``i``, gravity excluded."""

    delta_R: FloatArray
    delta_p: FloatArray
    delta_v: FloatArray


def _readonly(x: Any) -> FloatArray:
    arr = np.array(x, dtype=np.float64, copy=True)
    arr.flags.writeable = False
    return arr


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
        for f in dataclasses.fields(self):
            if f.name not in ("delta_t", "n_samples"):
                object.__setattr__(self, f.name, _readonly(getattr(self, f.name)))
        object.__setattr__(self, "delta_t", float(self.delta_t))

    @property
    def bias_jacobian(self) -> FloatArray:
        """``(9, 6)``: rows (rot, pos, vel) as in :meth:`bias_corrected`, columns (acc, gyro)."""
        J = np.zeros((9, 6))
        J[0:3, 3:6] = self.dR_dbg
        J[3:6] = np.hstack([self.dp_dba, self.dp_dbg])
        J[6:9] = np.hstack([self.dv_dba, self.dv_dbg])
        return J

    @classmethod
    def _from_delta(cls, d: _Delta, bias_hat: FloatArray, gravity: FloatArray) -> PreintegratedImu:
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
        P = _read_params(params)
        bias_hat = _read_bias(pim.biasHat(), "pim.biasHat()")
        H1 = np.zeros((9, 9), order="F")
        H2 = np.zeros((9, 6), order="F")
        pim.predict(gtsam.NavState(), pim.biasHat(), H1, H2)
        R = np.array(pim.deltaRij().matrix())
        J = np.zeros((9, 6))
        J[0:3] = H2[0:3]
        J[3:6] = R @ H2[3:6]
        J[6:9] = R @ H2[6:9]
        d = _Delta(
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
        db = _read_bias(bias) - self.bias_hat
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
        T_i = v.pose(pose_i, "pose_i")
        v_i = v.vector(vel_i, "vel_i", 3)
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
    acc_, gyro_, dt_ = _read_samples(acc, gyro, dt)
    P = _read_params(params)
    b = _read_bias(bias)
    if b.shape != (6,):
        raise ValueError(f"bias: expected one bias (6,), got shape {b.shape}")
    return PreintegratedImu._from_delta(_integrate_blocks(acc_, gyro_, dt_, b, P), b, P.gravity)


class ImuPreintegrator:
    """Incremental preintegration for online use.

    Samples given to :meth:`integrate` are validated immediately and buffered; they are
    integrated in one vectorized pass when a result is requested, and passes are concatenated
    exactly (``ΔR = ΔR₁ΔR₂``, covariance and bias Jacobians by the chain rule). Feeding one sample
    at a time (a few µs each: a tuple is appended) and asking for :meth:`result` at keyframes
    therefore costs about as much as one :func:`preintegrate` call on the whole window.

    Parameters
    ----------
    params : gtsam.PreintegrationParams
    bias : bias estimate, as for :func:`preintegrate` (default zero)
    """

    def __init__(self, params: Any, bias: Any = None) -> None:
        self._P = _read_params(params)
        self.reset(bias)

    def reset(self, bias: Any = None) -> None:
        """Forget all samples; optionally set a new bias estimate (default: keep it)."""
        if bias is not None or not hasattr(self, "_bias"):
            b = np.zeros(6) if bias is None else _read_bias(bias)
            if b.shape != (6,):
                raise ValueError(f"bias: expected one bias (6,), got shape {b.shape}")
            self._bias = b
        self._done: _Delta | None = None
        self._blocks: list[tuple[FloatArray, FloatArray, FloatArray]] = []
        self._rows: list[list[float]] = []  # single samples: [ax, ay, az, wx, wy, wz, dt]
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
        if np.ndim(dt) == 0 and np.ndim(acc) == 1 and np.ndim(gyro) == 1:
            row = [*_sample3(acc, "acc"), *_sample3(gyro, "gyro"), float(dt)]
            if not all(map(math.isfinite, row)) or not row[6] > 0.0:
                _reject_sample(row, self.n_samples)
            self._rows.append(row)
            self._buffered += 1
            return
        try:
            a, g, d_ = _read_samples(acc, gyro, dt)
        except ValueError as exc:
            raise ValueError(f"{exc} (block starting at sample {self.n_samples})") from None
        self._stash_rows()
        self._blocks.append((a.copy(), g.copy(), d_.copy()))
        self._buffered += d_.shape[0]

    def _stash_rows(self) -> None:
        if self._rows:
            rows = np.array(self._rows)
            self._blocks.append((rows[:, 0:3], rows[:, 3:6], rows[:, 6].copy()))
            self._rows = []

    def _flush(self) -> None:
        self._stash_rows()
        if not self._blocks:
            return
        a = np.concatenate([b[0] for b in self._blocks])
        g = np.concatenate([b[1] for b in self._blocks])
        d = np.concatenate([b[2] for b in self._blocks])
        block = _integrate_blocks(a, g, d, self._bias, self._P)
        self._done = block if self._done is None else _compose(self._done, block)
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
