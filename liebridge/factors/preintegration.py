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
The rotation increments ``Exp(ω_k dt_k)`` are built in one batched call (as unit quaternions) and
their prefix products ``ΔR_k`` by a work-efficient recursive scan (≈ 2N quaternion products,
depth 2·log₂N). ``Δv``, ``Δp`` are cumulative sums. The covariance recursion
``Σ_{k+1} = A_k Σ_k A_kᵀ + B_k Q_a B_kᵀ/dt + C_k Q_g C_kᵀ/dt + G Q_i Gᵀ dt`` is linear; expressed
in frame-``i`` coordinates (rotation perturbed on the left, position and velocity additively) the
transition from sample ``k+1`` to the end has the closed form
``Φ = [[I, 0, 0], [−[p̃_k]×, I, τ_k I], [−[ṽ_k]×, 0, I]]`` with ``τ_k = T − t_{k+1}``,
``ṽ_k = Δv_N − Δv_{k+1}``, ``p̃_k = Δp_N − Δp_{k+1} − τ_k Δv_{k+1}``, so that
``Σ = Σ_k (Φ_k G_k) Q_k (Φ_k G_k)ᵀ`` is one matrix product over all samples, with no sequential
loop. The bias Jacobians are ``−Σ_k Φ_k G_k`` (the same per-sample blocks, summed).

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
from typing import Any, NamedTuple

import gtsam
import numpy as np

from .. import _validate as v
from .._validate import FloatArray
from ..lie import so3

__all__ = ["ImuDelta", "ImuPreintegrator", "PreintegratedImu", "preintegrate"]


# --------------------------------------------------------------------------------------------
# inputs


@dataclasses.dataclass(frozen=True)
class _Params:
    """Numbers read once from a ``gtsam.PreintegrationParams``."""

    gravity: FloatArray  # (3,) navigation frame
    acc_cov: FloatArray  # (3, 3) continuous-time, sensor frame
    gyro_cov: FloatArray
    int_cov: FloatArray
    body_R_sensor: FloatArray | None  # (3, 3) or None
    lever_arm: FloatArray | None  # (3,) body frame, None when zero


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

    body_R_sensor = lever = None
    body_P_sensor = params.getBodyPSensor()
    if body_P_sensor is not None:
        body_R_sensor = v.rotation(
            np.array(body_P_sensor.rotation().matrix()), "params.body_P_sensor"
        )
        t = np.array(body_P_sensor.translation(), dtype=np.float64)
        lever = t if np.any(t != 0.0) else None
    return _Params(
        gravity=gravity.copy(),
        acc_cov=cov(params.getAccelerometerCovariance(), "params.accelerometerCovariance"),
        gyro_cov=cov(params.getGyroscopeCovariance(), "params.gyroscopeCovariance"),
        int_cov=cov(params.getIntegrationCovariance(), "params.integrationCovariance"),
        body_R_sensor=body_R_sensor,
        lever_arm=lever,
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


def _mv(A: FloatArray, x: FloatArray, out: FloatArray) -> FloatArray:
    for i in range(3):
        np.multiply(A[i, 0], x[0], out=out[i])
        out[i] += A[i, 1] * x[1]
        out[i] += A[i, 2] * x[2]
    return out


def _cols_cross(M: FloatArray, x: FloatArray, out: FloatArray) -> FloatArray:
    """``−[x]× M`` (each column of ``M`` crossed with ``x``) for ``x`` (3, n), ``M`` (3, 3, n)."""
    np.multiply(M[1], x[2], out=out[0])
    out[0] -= M[2] * x[1]
    np.multiply(M[2], x[0], out=out[1])
    out[1] -= M[0] * x[2]
    np.multiply(M[0], x[1], out=out[2])
    out[2] -= M[1] * x[0]
    return out


def _qmul(a: FloatArray, b: FloatArray, out: FloatArray | None = None) -> FloatArray:
    """Hamilton product of quaternions stored (w, x, y, z) along axis 0; ``out`` may alias."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    w = aw * bw - ax * bx - ay * by - az * bz
    x = aw * bx + ax * bw + ay * bz - az * by
    y = aw * by - ax * bz + ay * bw + az * bx
    z = aw * bz + ax * by - ay * bx + az * bw
    if out is None:
        return np.stack([w, x, y, z])
    out[0], out[1], out[2], out[3] = w, x, y, z
    return out


def _qscan_small(q: FloatArray) -> FloatArray:
    """Sequential prefix products for a few quaternions (plain floats are faster there)."""
    cols = q.T.tolist()
    w, x, y, z = cols[0]
    out = [cols[0]]
    for bw, bx, by, bz in cols[1:]:
        w, x, y, z = (
            w * bw - x * bx - y * by - z * bz,
            w * bx + x * bw + y * bz - z * by,
            w * by - x * bz + y * bw + z * bx,
            w * bz + x * by - y * bx + z * bw,
        )
        out.append([w, x, y, z])
    return np.array(out).T


_SCAN_BLOCK = 8


def _qscan(q: FloatArray) -> FloatArray:
    """Inclusive prefix products ``q_0 ⊗ q_1 ⊗ … ⊗ q_k`` of ``q`` (4, n), ``(w, x, y, z)``.

    Blocked scan: prefix products inside blocks of 8 consecutive samples (7 batched products
    over all blocks at once), a recursive scan of the block totals, then one batched product
    applying each block's predecessor total. About 2n products, depth O(log n).
    """
    n = q.shape[1]
    b = _SCAN_BLOCK
    if n <= 2 * b:
        return _qscan_small(q)
    m = n // b
    head = m * b
    blk = np.ascontiguousarray(q[:, :head].reshape(4, m, b).transpose(0, 2, 1))  # (4, b, m)
    for j in range(1, b):
        _qmul(blk[:, j - 1], blk[:, j], out=blk[:, j])
    totals = _qscan(np.ascontiguousarray(blk[:, b - 1]))  # (4, m)
    _qmul(totals[:, None, :-1], blk[:, :, 1:], out=blk[:, :, 1:])
    out = np.empty_like(q)
    out[:, :head] = blk.transpose(0, 2, 1).reshape(4, head)
    if head < n:
        tail = np.concatenate([out[:, head - 1 : head], q[:, head:]], axis=1)
        out[:, head:] = _qscan_small(tail)[:, 1:]
    return out


def _quat_to_R(q: FloatArray, out: FloatArray) -> FloatArray:
    w, x, y, z = q
    s = 2.0 / (w * w + x * x + y * y + z * z)
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


def _is_isotropic(C: FloatArray) -> bool:
    return bool(np.all(C == C[0, 0] * np.eye(3)))


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
) -> _Delta:
    """Preintegrate validated samples (N, 3), (N, 3), (N,) with bias estimate ``bias`` (6,).

    Two algebraically identical paths: the general one builds the 9×3 gyro input block of every
    sample; the fast one (isotropic gyroscope covariance, no lever arm) uses
    ``J_r J_rᵀ = a I + b θθᵀ`` and ``R [x]× = [R x]× R`` to reduce everything to outer-product
    sums (matrix products over samples). ``general=True`` forces the general path (tests).
    """
    n = dt.shape[0]
    a = np.ascontiguousarray((acc - bias[:3]).T)  # (3, n), sensor frame
    w = np.ascontiguousarray((gyro - bias[3:]).T)
    bRs = P.body_R_sensor
    acc_cov, gyro_cov = P.acc_cov, P.gyro_cov
    D = None  # d(corrected acc)/d(unbiased sensor ω), only with a lever arm
    if bRs is not None:
        a = bRs @ a
        w = bRs @ w
        # body-frame noise (an isotropic covariance is left as it is: rotation keeps it)
        if not _is_isotropic(acc_cov):
            acc_cov = bRs @ acc_cov @ bRs.T
        if P.lever_arm is None:
            if not _is_isotropic(gyro_cov):
                gyro_cov = bRs @ gyro_cov @ bRs.T
        else:
            r = P.lever_arm
            wr = r @ w  # ω·r
            a = a - (w * wr - r[:, None] * np.einsum("in,in->n", w, w))  # ω × (ω × r)
            # −[(ω·r) I + ω rᵀ − 2 r ωᵀ] bRs (PreintegrationBase.cpp)
            M = w[:, None, :] * r[None, :, None] - 2.0 * r[:, None, None] * w[None, :, :]
            M[0, 0] += wr
            M[1, 1] += wr
            M[2, 2] += wr
            D = -np.einsum("ijn,jk->ikn", M, bRs)
    general = general or D is not None or not _is_isotropic(gyro_cov)

    # rotation increments Exp(θ_k) as quaternions; J_r(θ) = c0 I − B [θ]× + C θθᵀ with
    # c0 = sin θ/θ, B = (1 − cos θ)/θ² = ½ sinc(θ/2)², C = (1 − c0)/θ² (C cancels for small θ,
    # but it only multiplies θθᵀ, so the absolute error of J_r stays ~ eps)
    theta = w * dt
    th2 = np.einsum("in,in->n", theta, theta)
    half = 0.5 * np.sqrt(th2)
    sh = np.sin(half)
    ch = np.cos(half) if half.max() > 0.5 else np.sqrt(1.0 - sh * sh)
    sinc_h = np.divide(sh, half, out=np.ones(n), where=half > 0.0)  # sin(θ/2)/(θ/2)
    q = np.empty((4, n))
    q[0] = ch
    np.multiply(0.5 * sinc_h, theta, out=q[1:])
    c0 = sinc_h * ch
    B = 0.5 * sinc_h * sinc_h
    C = np.divide(1.0 - c0, th2, out=np.full(n, 1.0 / 6.0), where=th2 > 0.0)

    R_all = np.empty((3, 3, n + 1))  # ΔR_0 … ΔR_N
    R_all[:, :, 0] = np.eye(3)
    _quat_to_R(_qscan(q), out=R_all[:, :, 1:])
    R_prev, R_next = R_all[:, :, :-1], R_all[:, :, 1:]
    R9_prev = R_all.reshape(9, n + 1)[:, :-1]
    R9_next = R_all.reshape(9, n + 1)[:, 1:]

    # Δv, Δp (frame i), and the carry-to-the-end quantities τ_k, ṽ_k, p̃_k, α_k
    a_i = _mv(R_prev, a, np.empty((3, n)))
    dv = a_i * dt
    v_next = np.cumsum(dv, axis=1)
    dp = 0.5 * dt * dv
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
    alpha = dt * (tau + 0.5 * dt)

    # gyro input carried to the end, frame i: [Y; −[p̃]× Y; −[ṽ]× Y], Y = ΔR_{k+1} J_r dt
    Jr = np.empty((3, 3, n))
    Ct = (C * dt) * theta
    for i in range(3):
        for j in range(3):
            np.multiply(Ct[i], theta[j], out=Jr[i, j])
        Jr[i, i] += c0 * dt
    Bt = (B * dt) * theta
    Jr[0, 1] += Bt[2]
    Jr[0, 2] -= Bt[1]
    Jr[1, 0] -= Bt[2]
    Jr[1, 2] += Bt[0]
    Jr[2, 0] += Bt[1]
    Jr[2, 1] -= Bt[0]
    if general:
        G = np.empty((9, 3, n))
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
        if _is_isotropic(gyro_cov):
            GQ = G * (gyro_cov[0, 0] / dt)
        else:
            GQ = np.matmul(gyro_cov.T, G) / dt
        cov_i = G.reshape(9, 3 * n) @ GQ.reshape(9, 3 * n).T
    else:
        Y = np.einsum("ijn,jkn->ikn", R_next, Jr)
        Jg = _sum_carried(Y, pv_tilde)
        u = _mv(R_prev, theta, np.empty((3, n)))  # ΔR_k θ_k = ΔR_{k+1} θ_k
        cov_i = _gyro_covariance(u, pv_tilde, c0, B, C, th2, dt, gyro_cov[0, 0])
    if bRs is not None and D is None:
        Jg = Jg @ bRs

    # accelerometer input [0; α ΔR_k; dt ΔR_k] (times bRs): bias Jacobian and covariance
    Ja = -(R9_prev @ np.stack([alpha, dt], axis=1)).reshape(3, 3, 2)
    Ja = np.einsum("ijw,jk->wik", Ja, bRs if bRs is not None else np.eye(3)).reshape(6, 3)
    if _is_isotropic(acc_cov):
        s = acc_cov[0, 0] * np.array([alpha * alpha @ (1.0 / dt), alpha.sum(), T])
        pp, pv, vv = (x * np.eye(3) for x in s)
    else:
        pp, pv, vv = _weighted_congruence(
            R9_prev, np.stack([alpha * alpha / dt, alpha, dt]), acc_cov
        )
    cov_i[3:6, 3:6] += pp
    cov_i[3:6, 6:9] += pv
    cov_i[6:9, 3:6] += pv.T
    cov_i[6:9, 6:9] += vv
    # integration noise, added to the body-frame position at every step
    if _is_isotropic(P.int_cov):
        cov_i[3:6, 3:6] += (P.int_cov[0, 0] * T) * np.eye(3)
    else:
        cov_i[3:6, 3:6] += _weighted_congruence(R9_next, dt[None], P.int_cov)[0]

    RN = R_all[:, :, -1].copy()
    Tb = np.kron(np.eye(3), RN)  # frame-i → body-chart coordinates: δ_body = Tbᵀ δ_i
    cov = Tb.T @ cov_i @ Tb
    cov = 0.5 * (cov + cov.T)
    J = np.zeros((9, 6))
    J[0:3, 3:6] = RN.T @ Jg[0:3]
    J[3:9, 0:3] = Ja
    J[3:9, 3:6] = Jg[3:9]
    return _Delta(
        delta_t=T, n=n, R=RN, p=p_next[:, -1].copy(), v=v_next[:, -1].copy(), cov=cov, J=J
    )


_E = np.array([_hat(e) for e in np.eye(3)])  # [e_b]×, b = 0, 1, 2


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
    u: FloatArray,
    pv: FloatArray,
    c0: FloatArray,
    B: FloatArray,
    C: FloatArray,
    th2: FloatArray,
    dt: FloatArray,
    var: float,
) -> FloatArray:
    """Frame-i covariance of isotropic gyro noise (variance density ``var``) carried to the end.

    Per sample ``Y Q Yᵀ/dt = var·dt·ΔR J_r J_rᵀ ΔRᵀ = var·dt (a I + b u uᵀ)`` with
    ``a = c0² + B²θ²``, ``b = 2 c0 C + C²θ² − B²``; the blocks ``S Z Sᵀ`` with
    ``S = [I; −[p̃]×; −[ṽ]×]`` then only need outer-product sums, using
    ``[x]× u uᵀ [y]×ᵀ = (x×u)(y×u)ᵀ`` and ``[x]× [y]×ᵀ = (x·y) I − y xᵀ``.
    """
    n = u.shape[1]
    wa = dt * (c0 * c0 + B * B * th2)
    wb = dt * (2.0 * c0 * C + C * C * th2 - B * B)
    V = np.empty((9, n))  # u, p̃ × u, ṽ × u
    V[0:3] = u
    for r, (x, y) in enumerate(((pv[0:3], u), (pv[3:6], u))):
        o = V[3 * r + 3 : 3 * r + 6]
        np.multiply(x[1], y[2], out=o[0])
        o[0] -= x[2] * y[1]
        np.multiply(x[2], y[0], out=o[1])
        o[1] -= x[0] * y[2]
        np.multiply(x[0], y[1], out=o[2])
        o[2] -= x[1] * y[0]
    cov = (V * wb) @ V.T  # Σ wb (·)(·)ᵀ over u, p̃×u, ṽ×u
    cov[3:9, 0:3] *= -1.0
    cov[0:3, 3:9] *= -1.0
    Ma = (pv * wa) @ pv.T  # Σ wa x yᵀ for x, y ∈ {p̃, ṽ}
    sa = pv @ wa  # Σ wa p̃, Σ wa ṽ
    I3 = np.eye(3)
    cov[0:3, 0:3] += wa.sum() * I3
    for r in range(2):
        blk = -_hat(sa[3 * r : 3 * r + 3])  # Σ −wa [x]×
        cov[3 * r + 3 : 3 * r + 6, 0:3] += blk
        cov[0:3, 3 * r + 3 : 3 * r + 6] += blk.T
        for c in range(2):
            Mxy = Ma[3 * r : 3 * r + 3, 3 * c : 3 * c + 3]
            cov[3 * r + 3 : 3 * r + 6, 3 * c + 3 : 3 * c + 6] += np.trace(Mxy) * I3 - Mxy.T
    return np.asarray(var * cov)


def _compose(d1: _Delta, d2: _Delta) -> _Delta:
    """Concatenate two blocks integrated with the same bias estimate (exact, not approximate)."""
    R1, p1, v1, T2 = d1.R, d1.p, d1.v, d2.delta_t
    # transition of block 2 in body charts: blockdiag(R2ᵀ) [[I,0,0],[−[p2]×,I,T2 I],[−[v2]×,0,I]]
    F = np.eye(9)
    F[3:6, 0:3] = -_hat(d2.p)
    F[3:6, 6:9] = T2 * np.eye(3)
    F[6:9, 0:3] = -_hat(d2.v)
    F = np.kron(np.eye(3), d2.R.T) @ F
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
        order in the bias change only.

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
        """First-order bias correction (Forster et al. eq. 44; GTSAM ``biasCorrectedDelta``).

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
    return PreintegratedImu._from_delta(_integrate(acc_, gyro_, dt_, b, P), b, P.gravity)


class ImuPreintegrator:
    """Incremental preintegration for online use.

    Samples given to :meth:`integrate` are validated immediately and buffered; they are
    integrated in one vectorized block when a result is requested, and blocks are concatenated
    exactly (``ΔR = ΔR₁ΔR₂``, covariance and bias Jacobians by the chain rule). Feeding one sample
    at a time and asking for :meth:`result` at keyframes therefore costs about as much as one
    :func:`preintegrate` call on the whole window.

    Parameters
    ----------
    params : gtsam.PreintegrationParams
    bias : bias estimate, as for :func:`preintegrate` (default zero)
    """

    def __init__(self, params: Any, bias: Any = None) -> None:
        self._params_obj = params
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
        self._buf: list[tuple[FloatArray, FloatArray, FloatArray]] = []
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
        """Add one sample ``(3,), (3,), scalar`` or a block ``(N, 3), (N, 3), (N,) or scalar``."""
        acc_a = v.as_float_array(acc, "acc")
        gyro_a = v.as_float_array(gyro, "gyro")
        if acc_a.ndim == 1 and gyro_a.ndim == 1:
            acc_a, gyro_a = acc_a[None], gyro_a[None]
            dt = np.reshape(v.as_float_array(dt, "dt"), (-1,))
        a, g, d = _read_samples(acc_a, gyro_a, dt)
        self._buf.append((a.copy(), g.copy(), d.copy()))
        self._buffered += d.shape[0]

    def _flush(self) -> None:
        if not self._buf:
            return
        a = np.concatenate([b[0] for b in self._buf])
        g = np.concatenate([b[1] for b in self._buf])
        d = np.concatenate([b[2] for b in self._buf])
        block = _integrate(a, g, d, self._bias, self._P)
        self._done = block if self._done is None else _compose(self._done, block)
        self._buf, self._buffered = [], 0

    @property
    def delta_t(self) -> float:
        """Integrated time so far (s)."""
        done = self._done.delta_t if self._done is not None else 0.0
        return done + float(sum(float(b[2].sum()) for b in self._buf))

    def result(self) -> PreintegratedImu:
        """Return the preintegrated measurements of every sample so far (raises if none)."""
        self._flush()
        if self._done is None:
            raise ValueError("ImuPreintegrator.result: no samples integrated yet")
        return PreintegratedImu._from_delta(self._done, self._bias, self._P.gravity)
