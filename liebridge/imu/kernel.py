"""The vectorized kernel of IMU preintegration: one block of samples, integrated from identity.

Conventions are those of :mod:`liebridge.imu.preintegration` (its module docstring states
them): frame ``i`` is the body frame at the first sample, ``ΔR_k`` maps frame ``k`` to frame
``i``, ``Δp``/``Δv`` are in frame ``i`` without gravity, the covariance is in GTSAM's order
(rot, pos, vel) in the chart of ``NavState::retract``, and bias vectors are (acc, gyro).

No Python loop runs per sample. Each step, and where its formula comes from:

* **Rotation increments.** ``Exp(θ_k)``, ``θ_k = ω_k dt_k``, as unit quaternions. The scalar
  coefficients (``sin θ/θ``, ``(1 − cos θ)/θ²``, ``(θ − sin θ)/θ³``, ``cos(θ/2)``,
  ``sin(θ/2)/(θ/2)``) come from their exact Maclaurin series (:mod:`liebridge.lie.series`)
  below ``SMALL_ANGLE``. All five are evaluated in one matrix product with the powers of ``θ²``,
  truncated where the first omitted term is below 2⁻⁵⁶ of the leading one at the block's largest
  angle. The closed forms are used on the few samples above the threshold.
* **Prefix products** ``ΔR_{k+1} = ΔR_k Exp(θ_k)``. This is the only sequential step. Written as
  quaternions held as complex pairs ``(α, β) = (w + x i, y + z i)``, the Hamilton product is
  complex-*linear* in the left factor: ``(α', β') = (α α_k − β β̄_k, α β_k + β ᾱ_k)``. So the
  sequence of all ``q_k`` solves a unit lower-triangular block-bidiagonal linear system (2×2
  complex blocks, bandwidth 3). LAPACK's banded triangular solve (``ztbtrs``, forward
  substitution: the same products in the same order as a sequential loop, bit for bit) runs it in
  compiled code. This is why scipy is used here rather than a numpy prefix scan.
* **Velocity and position.** ``Δv_{k+1} = Δv_k + ΔR_k a_k dt_k`` and
  ``Δp_{k+1} = Δp_k + Δv_k dt_k + ½ ΔR_k a_k dt_k²``. Summed by parts, what the covariance and
  Jacobians need are *suffix* sums: ``ṽ_k = Σ_{i>k} ΔR_i a_i dt_i`` and
  ``p̃_k = Σ_{i>k} ΔR_i a_i α_i`` with ``α_i = (τ_i + ½dt_i) dt_i``, and ``τ_k = Σ_{i>k} dt_i``.
  Their totals are ``Δv_N``, ``Δp_N`` and ``T`` (reversed ``numpy.cumsum``).
* **Covariance and bias Jacobians.** The recursion
  ``Σ_{k+1} = A_k Σ_k A_kᵀ + B_k Q_a B_kᵀ/dt + C_k Q_g C_kᵀ/dt + G Q_i Gᵀ dt``
  (``NavState::update`` and ``PreintegratedImuMeasurementsT::integrateMeasurement``) is linear.
  Express it in frame-``i`` coordinates: rotation perturbed on the left, position and velocity
  additively. The transition from sample ``k+1`` to the end then has the closed form
  ``Φ_k = [[I, 0, 0], [−[p̃_k]×, I, τ_k I], [−[ṽ_k]×, 0, I]]``, with ``τ_k = T − t_{k+1}``,
  ``ṽ_k = Δv_N − Δv_{k+1}`` and ``p̃_k = Δp_N − Δp_{k+1} − τ_k Δv_{k+1}``. So
  ``Σ = Σ_k (Φ_k G_k) Q_k (Φ_k G_k)ᵀ`` is a sum over samples instead of a sequential recursion,
  and the bias Jacobians are ``−Σ_k Φ_k G_k``.
  - The gyroscope input block is ``Y_k = ΔR_{k+1} J_r(θ_k) dt_k``. It equals
    ``ΔR_k J_l(θ_k) dt_k = c₀ dt ΔR_k + B dt [u_k]× ΔR_k + C dt u_k θ_kᵀ`` with ``u_k = ΔR_k θ_k``.
    It uses ``J_l = Exp·J_r`` and ``R[θ]× = [Rθ]× R``. ``tests/test_imu_kernel.py`` checks the
    construction against ``ΔR_{k+1} so3.jr(θ_k) dt_k``, and ``so3.jr``/``so3.jl`` are
    finite-difference tested in ``tests/test_lie_so3.py``.
  - The sums ``Σ_k w_k Y_k`` for the seven weights ``w ∈ {1, p̃, ṽ}`` are then one matrix
    product.
  - With isotropic gyroscope noise, ``J_r J_rᵀ = a I + b θθᵀ`` reduces the gyroscope covariance
    to outer-product sums too.

Blocks of :data:`BLOCK` samples are integrated separately and concatenated exactly by
:func:`compose` (``ΔR = ΔR₁ΔR₂``; covariance and bias Jacobians by the chain rule). The large
scratch arrays live in a per-thread :class:`Workspace` kept between calls. Measured on a 2-core
VM, fresh arrays page-faulted on every call at about 3 µs per 4 KiB page. With the workspace
kept, 8k-sample blocks ran 1.6× faster than 4k blocks with a fresh workspace per call (median of
25 calls on 40k samples: 11.1 ms against 18.3 ms).

**Compiled kernel.** In numpy the fast path costs 0.31 µs per sample (40k KITTI samples,
``benchmarks/bench_imu.py``). It is bound by memory bandwidth: each of its array passes costs
about 1.2 ns per element on that VM, against 0.3–0.7 ns for the same operation on arrays that stay
in cache. That is 9.7× GTSAM's loop, so the fast path's per-sample sums (everything up to ``S``,
the ``Σ α ΔR`` sums and the gyroscope covariance sums) also exist as one C loop in two passes,
``_imu_ext.c``. It is optional: it is built with the package where a C compiler is found, and
:data:`COMPILED` says whether it was.
The assembly after the sums (:func:`_gyro_cov_from_sums`, :func:`_finish`) is shared, and the
tests compare the two kernels output by output.
"""

from __future__ import annotations

import dataclasses
import math
import threading
import types
from typing import Any

import numpy as np

from .._validate import FloatArray
from ..lie import series, so3
from .inputs import Params

__all__ = [
    "BLOCK",
    "COMPILED",
    "Delta",
    "Deltas",
    "Workspace",
    "compiled_applies",
    "compose",
    "integrate",
    "integrate_blocks",
    "integrate_windows",
    "thread_workspace",
]

#: Samples per vectorized block (see the module docstring for the measurement behind it).
BLOCK = 8192


class Workspace:
    """Scratch buffers reused by every block of every call in one thread.

    Fresh arrays above glibc's mmap threshold are mapped anew and page-faulted on first touch,
    which on the 2-core VM this was measured on cost about 3 µs per 4 KiB page. That is more than
    the arithmetic on them. See :func:`thread_workspace`.
    """

    def __init__(self) -> None:
        self._bufs: dict[str, FloatArray] = {}

    def get(self, name: str, shape: tuple[int, ...], *, zero: bool = False) -> FloatArray:
        """Return a float64 array of ``shape``, reused under ``name``.

        Its contents are undefined, except with ``zero=True``: zero when first allocated, and
        from then on whatever the previous user of ``name`` left (a user that relies on zeros
        restores the ones it overwrites).
        """
        size = math.prod(shape)
        buf = self._bufs.get(name)
        if buf is None or buf.size < size:
            buf = np.zeros(size) if zero else np.empty(size)
            self._bufs[name] = buf
        return buf[:size].reshape(shape)

    @property
    def nbytes(self) -> int:
        """Bytes held by the buffers."""
        return sum(b.nbytes for b in self._bufs.values())


@dataclasses.dataclass(frozen=True)
class Delta:
    """Preintegrated numbers of one block of samples, integrated from identity."""

    delta_t: float
    n: int
    R: FloatArray  # (3, 3)
    p: FloatArray  # (3,)
    v: FloatArray  # (3,)
    cov: FloatArray  # (9, 9) body chart (rot, pos, vel)
    J: FloatArray  # (9, 6): rows (rot right-perturbation, pos, vel additive), cols (acc, gyro)


_LOCAL = threading.local()


def thread_workspace() -> Workspace:
    """Return the calling thread's :class:`Workspace`, created on first use.

    It holds about 9 MB once a full block of :data:`BLOCK` samples has been integrated
    (``Workspace.nbytes``), for as long as the thread lives. Threads never share one, so
    preintegration is thread-safe.
    """
    ws: Workspace | None = getattr(_LOCAL, "ws", None)
    if ws is None:
        ws = _LOCAL.ws = Workspace()
    return ws


# --------------------------------------------------------------------------------------------
# small 3×3 helpers


_NEXT, _PREV = np.array([1, 2, 0]), np.array([2, 0, 1])


def _sum_hat_times(M: FloatArray) -> FloatArray:
    """``Σ_b [e_b]× M_b`` for ``M`` (..., 3, 3, 3): ``Σ_k [x_k]× Y_k`` given ``M_b = Σ_k x_kb Y_k``.

    Row i of the result is ``M[i+1, i+2] − M[i+2, i+1]`` (indices mod 3); leading axes batch.
    """
    return np.asarray(M[..., _NEXT, _PREV, :] - M[..., _PREV, _NEXT, :])


_I3 = np.eye(3)
#: [e_b]× as a (9, 3) map: ``so3.hat(x).ravel() = _HAT9 @ x``
_HAT9 = np.stack([so3.hat(e).ravel() for e in np.eye(3)], axis=1)
#: sign pattern of the gyroscope covariance's V-sums (−1 between the rotation and the rest)
_SIGN9 = np.ones((9, 9))
_SIGN9[3:9, 0:3] = _SIGN9[0:3, 3:9] = -1.0


def _blockdiag3(R: FloatArray) -> FloatArray:
    T = np.zeros((9, 9))
    T[0:3, 0:3] = T[3:6, 3:6] = T[6:9, 6:9] = R
    return T


# --------------------------------------------------------------------------------------------
# scalar coefficients of Exp, J_l and the half-angle quaternion


def _half_angle_series(cos: bool) -> tuple[float, ...]:
    """Maclaurin coefficients in powers of θ² of ``cos(θ/2)`` or ``sin(θ/2)/(θ/2)``."""
    off = 0 if cos else 1
    return tuple((-1) ** k / (math.factorial(2 * k + off) * 4.0**k) for k in range(9))


#: rows: sin θ/θ, (1 − cos θ)/θ², (θ − sin θ)/θ³, cos(θ/2), sin(θ/2)/(θ/2); columns: powers of θ²
_COEF = np.array(
    [
        series.SINC_SERIES,
        series.ONE_MINUS_COS_OVER_T2_SERIES,
        series.T_MINUS_SIN_OVER_T3_SERIES,
        _half_angle_series(cos=True),
        _half_angle_series(cos=False),
    ]
)
#: largest relative size of the k-th term over the five series: truncating after K terms leaves
#: an alternating tail below ``_TERM[K] · θ²ᴷ`` (relative to the leading term)
_TERM = np.abs(_COEF / _COEF[:, :1]).max(axis=0)


def _n_terms(t2max: float) -> int:
    """Fewest series terms whose first omitted term is below 2⁻⁵⁶ (relative) at ``θ² = t2max``."""
    for k in range(1, _COEF.shape[1]):
        if _TERM[k] * t2max**k < 2.0**-56:
            return k
    return _COEF.shape[1]


def _coefficients(th2: FloatArray, ws: Workspace) -> FloatArray:
    """``(5, n)``: ``sin θ/θ, (1 − cos θ)/θ², (θ − sin θ)/θ³, cos(θ/2), sin(θ/2)/(θ/2)``."""
    n = th2.shape[0]
    small2 = series.SMALL_ANGLE**2
    big = th2 >= small2
    any_big = bool(big.any())
    t2 = np.where(big, 0.0, th2) if any_big else th2
    K = _n_terms(float(t2.max()))
    powers = ws.get("powers", (K, n))
    powers[0] = 1.0
    if K > 1:
        powers[1] = t2
    for k in range(2, K):
        np.multiply(powers[k - 1], t2, out=powers[k])
    out = _COEF[:, :K] @ powers
    if any_big:
        theta = np.sqrt(th2[big])
        half = 0.5 * theta
        out[0, big] = series.sinc(theta)
        out[1, big] = series.one_minus_cos_over_t2(theta)
        out[2, big] = series.t_minus_sin_over_t3(theta)
        out[3, big] = np.cos(half)
        out[4, big] = series.sinc(half)
    return out


# --------------------------------------------------------------------------------------------
# the rotation scan


def _rotation_scan(
    cos_half: FloatArray, qvec: FloatArray, ws: Workspace
) -> tuple[FloatArray, FloatArray]:
    """Rotation matrices ``ΔR_0 = I, ΔR_1, …, ΔR_n`` of the increments ``(cos_half, qvec)``.

    ``qvec`` (3, n) is the vector part ``sin(θ/2) θ/θ`` of each increment. Returns ``R9`` (9, n+1),
    the row-major entries of every ``ΔR_k`` (normalised: ``2/‖q‖²`` scaling), and the last one
    as (3, 3). See the module docstring for the banded-solve formulation.
    """
    from scipy.linalg import lapack  # lazily: 0.5 s off `import liebridge`

    n = cos_half.shape[0]
    m = n + 1
    # LAPACK lower band storage of the unit lower-triangular matrix L (order 2m, bandwidth 3) with
    # L q = e₀: column 2k+c (c = 0: α_k, c = 1: β_k) holds L[2k+c+d, 2k+c] at row d. In memory
    # (Fortran order) that is buf[k, c, d]; `fv` is the same buffer as (re, im) float pairs. Only
    # d = 2 (both columns), d = 3 (c = 0) and d = 1 (c = 1) are non-zero, at the same offsets for
    # any block length; the diagonal d = 0 is not referenced (diag='U'). So the buffer is zeroed
    # once, and only the last row (which another block length may have filled) is cleared here.
    fv = ws.get("band", (m, 2, 8), zero=True)
    fv[n] = 0.0
    ch, x, y, z = cos_half, qvec[0], qvec[1], qvec[2]
    # α_{k+1} − α_k·α_δ + β_k·conj(β_δ) = 0;  β_{k+1} − α_k·β_δ − β_k·conj(α_δ) = 0
    np.negative(ch, out=fv[:n, 0, 4])  # −α_δ at (2k+2, 2k)
    np.negative(x, out=fv[:n, 0, 5])
    np.negative(y, out=fv[:n, 0, 6])  # −β_δ at (2k+3, 2k)
    np.negative(z, out=fv[:n, 0, 7])
    fv[:n, 1, 2] = y  # conj(β_δ) at (2k+2, 2k+1)
    np.negative(z, out=fv[:n, 1, 3])
    np.negative(ch, out=fv[:n, 1, 4])  # −conj(α_δ) at (2k+3, 2k+1)
    fv[:n, 1, 5] = x
    band = fv.view(np.complex128).reshape(2 * m, 4).T  # (4, 2m), Fortran-contiguous
    rhs = ws.get("quats", (m, 4))
    rhs.fill(0.0)
    rhs[0, 0] = 1.0
    q, info = lapack.ztbtrs(
        band, rhs.view(np.complex128).reshape(2 * m, 1), uplo="L", diag="U", overwrite_b=1
    )
    if info != 0:  # pragma: no cover - a unit-diagonal triangular system is never singular
        raise RuntimeError(f"ztbtrs failed (info = {info})")
    q4 = q.view(np.float64).reshape(m, 4).T  # rows w, x, y, z (α = w + x i, β = y + z i)
    return _quat_to_R9(q4, ws)


def _quat_to_R9(q4: FloatArray, ws: Workspace) -> tuple[FloatArray, FloatArray]:
    """Row-major rotation entries (9, m) of quaternions ``q4`` (4, m), normalised on the fly."""
    m = q4.shape[1]
    q = ws.get("q4", (4, m))
    q[...] = q4
    s = np.einsum("im,im->m", q, q)
    np.divide(2.0, s, out=s)
    qs = q[1:] * s  # (sx, sy, sz)·s
    qq = ws.get("qq", (3, 4, m))  # qq[i, j] = s q_{i+1} q_j
    np.multiply(qs[:, None, :], q[None, :, :], out=qq)
    wx, xx, xy, xz = qq[0]
    wy, _, yy, yz = qq[1]
    wz, _, _, zz = qq[2]
    R9 = ws.get("R9", (9, m))
    np.add(yy, zz, out=R9[0])
    np.subtract(1.0, R9[0], out=R9[0])
    np.subtract(xy, wz, out=R9[1])
    np.add(xz, wy, out=R9[2])
    np.add(xy, wz, out=R9[3])
    np.add(xx, zz, out=R9[4])
    np.subtract(1.0, R9[4], out=R9[4])
    np.subtract(yz, wx, out=R9[5])
    np.subtract(xz, wy, out=R9[6])
    np.add(yz, wx, out=R9[7])
    np.add(xx, yy, out=R9[8])
    np.subtract(1.0, R9[8], out=R9[8])
    return R9, R9[:, -1].reshape(3, 3).copy()


# --------------------------------------------------------------------------------------------
# suffix sums


def _suffix_sum(x: FloatArray, out: FloatArray | None = None) -> tuple[FloatArray, FloatArray]:
    """Exclusive suffix sums ``s_k = Σ_{j>k} x_j`` along the last axis of ``x`` (r, n), and totals.

    Returns ``(s, Σ_j x_j)``, shapes (r, n) and (r,); ``s`` is written into ``out`` if given.
    (A blocked version through a triangular matrix product made the whole numpy kernel 4% faster,
    median 12.28 against 12.79 ms on 40k samples, within its run-to-run spread: not worth its code.)
    """
    r, n = x.shape
    out = np.empty((r, n)) if out is None else out
    inc = np.cumsum(x[:, ::-1], axis=1)  # inc[:, m] = Σ_{j ≥ n−1−m} x_j
    if n > 1:
        out[:, : n - 1] = inc[:, n - 2 :: -1]
    out[:, n - 1] = 0.0
    return out, inc[:, -1].copy()


# --------------------------------------------------------------------------------------------
# one block


def _cols_cross(M: FloatArray, x: FloatArray, out: FloatArray) -> FloatArray:
    """``−[x]× M`` (each column of ``M`` crossed with ``x``) for ``x`` (3, n), ``M`` (3, 3, n)."""
    np.multiply(M[1], x[2], out=out[0])
    out[0] -= M[2] * x[1]
    np.multiply(M[2], x[0], out=out[1])
    out[1] -= M[0] * x[2]
    np.multiply(M[0], x[1], out=out[2])
    out[2] -= M[1] * x[0]
    return out


def _weighted_congruence(R9: FloatArray, weights: FloatArray, W: FloatArray) -> FloatArray:
    """``Σ_k w_k R_k W R_kᵀ`` for each row of ``weights`` (m, n); ``R9`` (9, n) → (m, 3, 3).

    One matrix product builds ``Σ_k w_k R_k[i, a] R_k[j, b]`` for every (i, a, j, b); the
    contraction with ``W`` is then a 3×3×3×3 sum independent of n.
    """
    n = R9.shape[1]
    T = (weights[:, None, :] * R9[None]).reshape(-1, n) @ R9.T  # (m·9, 9)
    T = T.reshape(-1, 3, 3, 3, 3)  # (m, i, a, j, b)
    return np.asarray(np.einsum("miajb,ab->mij", T, W))


def _lever_arm_terms(w: FloatArray, P: Params) -> tuple[FloatArray, FloatArray]:
    """Centripetal correction ``ω × (ω × r)`` (3, n) and its ω-Jacobian times ``bRs`` (3, 3, n).

    ``D = −[(ω·r) I + ω rᵀ − 2 r ωᵀ] bRs``
    (``PreintegrationBase::correctMeasurementsBySensorPose``).
    """
    assert P.lever_arm is not None and P.body_R_sensor is not None
    r = P.lever_arm
    wr = r @ w  # ω·r
    centripetal = w * wr - r[:, None] * np.einsum("in,in->n", w, w)
    M = w[:, None, :] * r[None, :, None] - 2.0 * r[:, None, None] * w[None, :, :]
    M[0, 0] += wr
    M[1, 1] += wr
    M[2, 2] += wr
    return centripetal, -np.einsum("ijn,jk->ikn", M, P.body_R_sensor)


def integrate(
    acc: FloatArray,
    gyro: FloatArray,
    dt: FloatArray,
    bias: FloatArray,
    P: Params,
    *,
    general: bool = False,
    compiled: bool | None = None,
    ws: Workspace | None = None,
) -> Delta:
    """Preintegrate validated samples (N, 3), (N, 3), (N,) with bias estimate ``bias`` (6,).

    Two algebraically identical paths for the gyroscope noise. The general one builds the 9×3
    input block of every sample. The fast one (isotropic gyroscope covariance, no lever arm) uses
    ``J_r J_rᵀ = a I + b θθᵀ`` and ``ΔR θ = u`` to reduce it to outer-product sums.
    ``general=True`` forces the general path (tests). The fast path with isotropic accelerometer
    and integration noise runs in the compiled kernel when it is built (:data:`COMPILED`);
    ``compiled=False`` forces numpy, ``compiled=True`` requires the compiled kernel.
    """
    n = dt.shape[0]
    ws = ws if ws is not None else Workspace()
    if compiled is not False and compiled_applies(P) and not general:
        return _integrate_compiled(acc, gyro, dt, bias, P, ws)
    if compiled:
        raise ValueError(
            "compiled=True: the compiled kernel is not built or does not cover these params "
            "(it needs isotropic noise and no lever arm)"
        )
    a = np.subtract(acc.T, bias[:3, None], out=ws.get("a", (3, n)))  # sensor frame
    w = np.subtract(gyro.T, bias[3:, None], out=ws.get("w", (3, n)))
    bRs = P.body_R_sensor
    D = None  # d(corrected acc)/d(unbiased sensor ω), only with a lever arm
    if bRs is not None:
        a = bRs @ a
        w = bRs @ w
        if P.lever_arm is not None:
            centripetal, D = _lever_arm_terms(w, P)
            a = a - centripetal
    general = general or not P.fast

    # increments: θ_k, Exp(θ_k) as (cos(θ/2), sin(θ/2) θ/θ), and J_l's coefficients
    theta = np.multiply(w, dt, out=ws.get("theta", (3, n)))
    th2 = np.einsum("in,in->n", theta, theta)
    coef = _coefficients(th2, ws)  # c0, B, C, cos(θ/2), sinc(θ/2)
    qvec = np.multiply(theta, 0.5 * coef[4], out=ws.get("qvec", (3, n)))
    R9, RN = _rotation_scan(coef[3], qvec, ws)
    R3 = R9[:, :n].reshape(3, 3, n)  # ΔR_k, k = 0 … n−1

    # acceleration in frame i and u_k = ΔR_k θ_k in one product
    X = ws.get("X", (2, 3, n))
    X[0] = a
    X[1] = theta
    RX = np.einsum("ijn,cjn->cin", R3, X)
    ra, u = RX[0], RX[1]

    # time to the end τ_k = T − t_{k+1}, α_k = (τ_k + ½dt_k) dt_k, and the carried increments as
    # suffix sums: ṽ_k = Δv_N − Δv_{k+1} = Σ_{i>k} ΔR_i a_i dt_i and (summing the position
    # recursion by parts) p̃_k = Δp_N − Δp_{k+1} − τ_k Δv_{k+1} = Σ_{i>k} ΔR_i a_i α_i
    tau2, T_arr = _suffix_sum(dt[None])
    tau = tau2[0]
    T = float(T_arr[0])
    alpha = tau + 0.5 * dt
    alpha *= dt
    E = ws.get("E", (2, 3, n))  # ΔR_k a_k α_k, ΔR_k a_k dt_k
    np.multiply(ra, alpha, out=E[0])
    np.multiply(ra, dt, out=E[1])
    W = ws.get("W", (7, n))  # weights 1, p̃_k, ṽ_k
    W[0] = 1.0
    _, pv_end = _suffix_sum(E.reshape(6, n), out=W[1:7])
    p_tilde, v_tilde = W[1:4], W[4:7]
    delta_p, delta_v = pv_end[0:3], pv_end[3:6]

    # gyro input Y_k = ΔR_k J_l(θ_k) dt = c0 dt ΔR_k + [B dt u]× ΔR_k + C dt u θᵀ
    cdt = np.multiply(coef[0:3], dt, out=ws.get("cdt", (3, n)))
    gh = np.multiply(u[None], cdt[1:3, None, :], out=ws.get("gh", (2, 3, n)))
    g, Cu = gh[0], gh[1]
    Y = np.multiply(R3, cdt[0], out=ws.get("Y", (3, 3, n)))
    tmp = np.multiply(Cu[:, None, :], theta[None, :, :], out=ws.get("tmp", (3, 3, n)))
    Y += tmp
    t3 = tmp[0]
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        np.multiply(R3[k], g[j], out=t3)
        Y[i] += t3
        np.multiply(R3[j], g[k], out=t3)
        Y[i] -= t3
    Y9 = Y.reshape(9, n)
    if D is None:  # (with a lever arm the general path below sums its own input blocks)
        Jg = _gyro_bias_jacobian((W @ Y9.T).reshape(7, 3, 3))  # from Σ_k w_k Y_k, w ∈ {1, p̃, ṽ}

    if general:
        G = ws.get("G", (9, 3, n))  # [Y; −[p̃]× Y; −[ṽ]× Y]
        G[0:3] = Y
        _cols_cross(Y, p_tilde, out=G[3:6])
        _cols_cross(Y, v_tilde, out=G[6:9])
        if D is not None:  # lever arm: the gyro also moves the corrected acceleration
            assert bRs is not None
            G = np.einsum("ijn,jk->ikn", G, bRs)
            RD = np.einsum("ijn,jkn->ikn", R3, D)
            G[3:6] += RD * alpha
            G[6:9] += RD * dt
            Jg = -G.sum(axis=2)
        if P.gyro_var is not None:
            GQ = G * (P.gyro_var / dt)
        else:
            GQ = np.matmul(P.gyro_cov.T, G) / dt
        cov_i = G.reshape(9, 3 * n) @ GQ.reshape(9, 3 * n).T
    else:
        assert P.gyro_var is not None
        cov_i = _gyro_covariance(u, W[1:7], coef, th2, dt, P.gyro_var, ws)
    if bRs is not None and D is None:
        Jg = Jg @ bRs

    # accelerometer input [0; α ΔR_k; dt ΔR_k] (times bRs): bias Jacobian and covariance
    Ja9 = np.stack([alpha, dt]) @ R9[:, :n].T  # (2, 9)
    if P.acc_var is not None:
        acc_blocks = _isotropic_acc_blocks(
            P.acc_var, float(alpha @ (alpha / dt)), float(alpha.sum()), T
        )
    else:
        acc_blocks = tuple(
            _weighted_congruence(R9[:, :n], np.stack([alpha * alpha / dt, alpha, dt]), P.acc_cov)
        )
    # integration noise, added to the body-frame position at every step
    if P.int_var is not None:
        int_block = (P.int_var * T) * _I3
    else:
        int_block = _weighted_congruence(R9[:, 1:], dt[None], P.int_cov)[0]
    return _finish(n, T, RN, delta_p, delta_v, Jg, Ja9, cov_i, acc_blocks, int_block, bRs)


def _gyro_bias_jacobian(S: FloatArray) -> FloatArray:
    """``−Σ_k [Y_k; −[p̃_k]× Y_k; −[ṽ_k]× Y_k]`` (9, 3) from ``S`` = the sums for w ∈ {1, p̃, ṽ}."""
    J = np.empty((9, 3))
    np.negative(S[0], out=J[0:3])
    J[3:9] = _sum_hat_times(S[1:7].reshape(2, 3, 3, 3)).reshape(6, 3)
    return J


def _isotropic_acc_blocks(
    var: float, sum_a2_dt: float, sum_alpha: float, T: float
) -> tuple[FloatArray, ...]:
    """(pos, pos), (pos, vel), (vel, vel) blocks of isotropic accelerometer noise, frame i."""
    return (var * sum_a2_dt) * _I3, (var * sum_alpha) * _I3, (var * T) * _I3


def _finish(
    n: int,
    T: float,
    RN: FloatArray,
    delta_p: FloatArray,
    delta_v: FloatArray,
    Jg: FloatArray,
    Ja9: FloatArray,
    cov_i: FloatArray,
    acc_blocks: tuple[FloatArray, ...],
    int_block: FloatArray,
    bRs: FloatArray | None,
) -> Delta:
    """Add accelerometer and integration noise, move to the body chart, lay out the Jacobians.

    ``cov_i`` is the gyroscope part of the covariance in frame-i coordinates (modified in place),
    ``Jg`` (9, 3) the gyroscope bias Jacobian (sensor frame already applied) and ``Ja9`` the sums
    ``Σ α ΔR``, ``Σ dt ΔR`` (2, 9) of the accelerometer input ``[0; α ΔR_k; dt ΔR_k]``.
    """
    Ja = -Ja9.reshape(6, 3)  # rows: −Σ α ΔR, −Σ dt ΔR
    if bRs is not None:
        Ja = Ja @ bRs
    pp, pv, vv = acc_blocks
    cov_i[3:6, 3:6] += pp + int_block
    cov_i[3:6, 6:9] += pv
    cov_i[6:9, 3:6] += pv.T
    cov_i[6:9, 6:9] += vv
    Tb = _blockdiag3(RN)  # frame-i → body-chart coordinates: δ_body = Tbᵀ δ_i
    cov = Tb.T @ cov_i @ Tb
    cov = 0.5 * (cov + cov.T)
    J = np.zeros((9, 6))
    J[0:3, 3:6] = RN.T @ Jg[0:3]
    J[3:9, 0:3] = Ja
    J[3:9, 3:6] = Jg[3:9]
    return Delta(delta_t=T, n=n, R=RN, p=delta_p, v=delta_v, cov=cov, J=J)


# --------------------------------------------------------------------------------------------
# the compiled kernel (optional; built from _imu_ext.c with the package)

_imu_ext: types.ModuleType | None
try:
    from . import _imu_ext
except ImportError:  # pragma: no cover - the build skips it where no C compiler is found
    _imu_ext = None

#: Whether the compiled kernel was built (``liebridge/imu/_imu_ext.c``). Without it the same
#: numbers come from numpy, about 2× slower (``benchmarks/bench_imu.py`` measures both).
COMPILED = _imu_ext is not None

# layout of the compiled kernel's output: the O_* offsets of _imu_ext.c, as slices
_C_R, _C_P, _C_V, _C_T = slice(0, 9), slice(9, 12), slice(12, 15), 15
_C_S, _C_JA, _C_COVV = slice(16, 79), slice(79, 97), slice(97, 178)
_C_M, _C_SPV, _C_SWA, _C_SA2, _C_SA = slice(178, 214), slice(214, 220), 220, 221, 222
_C_N_OUT = 223
_C_N_SCRATCH = 21  # doubles per sample in the scratch buffer (N_SCRATCH)


def compiled_applies(P: Params) -> bool:
    """Whether the compiled kernel is built and covers ``P``.

    It covers isotropic noise densities and no lever arm; a rotated sensor is allowed.
    """
    return _imu_ext is not None and P.fast and P.acc_var is not None and P.int_var is not None


def _c_buffer(x: FloatArray) -> FloatArray:
    """``x`` as a C-contiguous, **aligned** float64 array (a copy only when it is not one).

    ``np.ascontiguousarray`` keeps a misaligned view (e.g. ``np.frombuffer(b, offset=1)``) as it
    is; the C kernel reads doubles through the pointer, undefined behaviour when misaligned
    (the kernel itself refuses such a buffer).
    """
    return np.require(x, dtype=np.float64, requirements=["C_CONTIGUOUS", "ALIGNED"])


def _integrate_compiled(
    acc: FloatArray, gyro: FloatArray, dt: FloatArray, bias: FloatArray, P: Params, ws: Workspace
) -> Delta:
    """:func:`integrate`'s fast path with the per-sample sums from the compiled kernel."""
    assert _imu_ext is not None and P.gyro_var is not None
    assert P.acc_var is not None and P.int_var is not None
    n = dt.shape[0]
    out = np.empty(_C_N_OUT)
    bRs = P.body_R_sensor
    _imu_ext.block_sums(
        _c_buffer(acc),
        _c_buffer(gyro),
        _c_buffer(dt),
        _c_buffer(bias),
        bRs is not None,
        _I3 if bRs is None else _c_buffer(bRs),
        _COEF,
        _COEF.shape[1],
        series.SMALL_ANGLE**2,
        ws.get("c_scratch", (n, _C_N_SCRATCH)),
        out,
    )
    RN, T = out[_C_R].reshape(3, 3), float(out[_C_T])
    Jg = _gyro_bias_jacobian(out[_C_S].reshape(7, 3, 3))
    if bRs is not None:
        Jg = Jg @ bRs
    cov_i = _gyro_cov_from_sums(
        out[_C_COVV].reshape(9, 9),
        out[_C_M].reshape(6, 6),
        out[_C_SPV],
        float(out[_C_SWA]),
        P.gyro_var,
    )
    acc_blocks = _isotropic_acc_blocks(P.acc_var, float(out[_C_SA2]), float(out[_C_SA]), T)
    int_block = (P.int_var * T) * _I3
    Ja9 = out[_C_JA].reshape(2, 9)
    delta_p, delta_v = out[_C_P], out[_C_V]
    return _finish(n, T, RN, delta_p, delta_v, Jg, Ja9, cov_i, acc_blocks, int_block, bRs)


def _gyro_covariance(
    u: FloatArray,
    pv: FloatArray,
    coef: FloatArray,
    th2: FloatArray,
    dt: FloatArray,
    var: float,
    ws: Workspace,
) -> FloatArray:
    """Frame-i covariance of isotropic gyro noise (variance density ``var``) carried to the end.

    Per sample ``Y Q Yᵀ/dt = var·dt·ΔR J_r J_rᵀ ΔRᵀ = var·dt (a I + b u uᵀ)`` with
    ``u = ΔR_k θ_k``, ``a = c0² + B²θ²``, ``b = 2 c0 C + C²θ² − B²``. The blocks ``S Z Sᵀ`` with
    ``S = [I; −[p̃]×; −[ṽ]×]`` then only need outer-product sums, using
    ``[x]× u uᵀ [y]×ᵀ = (x×u)(y×u)ᵀ`` and ``[x]× [y]×ᵀ = (x·y) I − y xᵀ``.
    ``pv`` (6, n) holds the rows p̃, ṽ.
    """
    n = u.shape[1]
    c0, B, C = coef[0], coef[1], coef[2]
    B2 = B * B
    wa = c0 * c0
    wa += B2 * th2
    wa *= dt
    wb = 2.0 * c0
    wb += C * th2
    wb *= C
    wb -= B2
    wb *= dt
    V = ws.get("V", (9, n))  # rows: u, p̃ × u, ṽ × u
    V[0:3] = u
    X, XU = pv.reshape(2, 3, n), V[3:9].reshape(2, 3, n)  # XU = X × u
    tmp = ws.get("cross", (2, n))
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        np.multiply(X[:, j], u[k], out=XU[:, i])
        np.multiply(X[:, k], u[j], out=tmp)
        XU[:, i] -= tmp
    VW = np.multiply(V, wb, out=ws.get("VW", (9, n)))
    PW = np.multiply(pv, wa, out=ws.get("PW", (6, n)))
    return _gyro_cov_from_sums(VW @ V.T, PW @ pv.T, PW.sum(axis=1), float(wa.sum()), var)


def _gyro_cov_from_sums(
    covV: FloatArray, M6: FloatArray, s: FloatArray, sum_wa: float, var: float
) -> FloatArray:
    """Return the gyroscope covariance (frame i) from its sums over samples.

    ``covV = Σ wb V Vᵀ`` (9, 9) with ``V = [u; p̃ × u; ṽ × u]``, ``M6 = Σ wa x xᵀ`` (6, 6) and
    ``s = Σ wa x`` (6) with ``x = [p̃; ṽ]``, ``sum_wa = Σ wa`` (see :func:`_gyro_covariance`). The
    result is a new array.
    """
    cov = covV * _SIGN9
    M = M6.reshape(2, 3, 2, 3)  # [r, i, c, j] = Σ wa x_r[i] x_c[j], x ∈ {p̃, ṽ}
    cov[0:3, 0:3] += sum_wa * _I3
    hats = (_HAT9 @ s.reshape(2, 3).T).T.reshape(6, 3)  # Σ wa [x]×, x ∈ {p̃, ṽ}
    cov[3:9, 0:3] -= hats
    cov[0:3, 3:9] -= hats.T
    # block (r, c): Σ wa [x_r]× [x_c]×ᵀ = tr(M_rc) I − M_rcᵀ
    tr = M.trace(axis1=1, axis2=3)
    cov[3:9, 3:9] += (tr[:, None, :, None] * _I3[None, :, None, :]).reshape(6, 6)
    cov[3:9, 3:9] -= M.transpose(0, 3, 2, 1).reshape(6, 6)
    cov *= var
    return cov


# --------------------------------------------------------------------------------------------
# concatenation


def compose(d1: Delta, d2: Delta) -> Delta:
    """Concatenate two blocks integrated with the same bias estimate (exact, not approximate)."""
    R1, p1, v1, T2 = d1.R, d1.p, d1.v, d2.delta_t
    # transition of block 2 in body charts: blockdiag(R2ᵀ) [[I,0,0],[−[p2]×,I,T2 I],[−[v2]×,0,I]]
    F = np.eye(9)
    F[3:6, 0:3] = -so3.hat(d2.p)
    F[3:6, 6:9] = T2 * np.eye(3)
    F[6:9, 0:3] = -so3.hat(d2.v)
    F = _blockdiag3(d2.R.T) @ F
    cov = F @ d1.cov @ F.T + d2.cov
    J1, J2 = d1.J, d2.J
    D1 = J1[0:3, 3:6]
    J = np.zeros((9, 6))
    J[0:3, 3:6] = d2.R.T @ D1 + J2[0:3, 3:6]
    J[3:6] = J1[3:6] + T2 * J1[6:9] + R1 @ J2[3:6]
    J[3:6, 3:6] -= R1 @ so3.hat(d2.p) @ D1
    J[6:9] = J1[6:9] + R1 @ J2[6:9]
    J[6:9, 3:6] -= R1 @ so3.hat(d2.v) @ D1
    return Delta(
        delta_t=d1.delta_t + T2,
        n=d1.n + d2.n,
        R=R1 @ d2.R,
        p=p1 + v1 * T2 + R1 @ d2.p,
        v=v1 + R1 @ d2.v,
        cov=0.5 * (cov + cov.T),
        J=J,
    )


def integrate_blocks(
    acc: FloatArray, gyro: FloatArray, dt: FloatArray, bias: FloatArray, P: Params, **kw: Any
) -> Delta:
    """:func:`integrate` on blocks of :data:`BLOCK` samples, concatenated with :func:`compose`.

    Raises
    ------
    ValueError
        The inputs are finite but so large that the result is not: the
        message gives the largest ``|acc|``, ``|gyro|``, ``dt`` and ``|bias|``.
    """
    n = dt.shape[0]
    out: Delta | None = None
    ws = thread_workspace()
    with np.errstate(all="ignore"):  # an overflow is reported below, as one ValueError
        for s in range(0, n, BLOCK):
            e = min(n, s + BLOCK)
            if n - e < BLOCK // 4:  # fold a short tail into the last block
                e = n
            d = integrate(acc[s:e], gyro[s:e], dt[s:e], bias, P, ws=ws, **kw)
            out = d if out is None else compose(out, d)
            if e == n:
                break
    assert out is not None
    check_delta_finite(out, acc, gyro, dt, bias)
    return out


def check_delta_finite(
    d: Delta,
    acc: FloatArray | None = None,
    gyro: FloatArray | None = None,
    dt: FloatArray | None = None,
    bias: FloatArray | None = None,
) -> None:
    """Raise ``ValueError`` if any preintegrated number is NaN or Inf (inputs overflowed)."""
    parts = {"delta_R": d.R, "delta_p": d.p, "delta_v": d.v, "covariance": d.cov, "J": d.J}
    bad = [k for k, x in parts.items() if not np.isfinite(x).all()]
    if not bad and math.isfinite(d.delta_t):
        return
    sizes = ""
    if acc is not None and gyro is not None and dt is not None and bias is not None:
        sizes = (
            f": max |acc| {float(np.abs(acc).max()):.3g}, max |gyro| "
            f"{float(np.abs(gyro).max()):.3g}, max dt {float(dt.max()):.3g}, "
            f"max |bias| {float(np.abs(bias).max()):.3g}"
        )
    raise ValueError(
        f"acc, gyro, dt, bias: finite inputs whose preintegration overflows float64 "
        f"({', '.join(bad) or 'delta_t'} not finite after {d.n} samples){sizes}"
    )


# --------------------------------------------------------------------------------------------
# many windows of one sequence (keyframe intervals)


@dataclasses.dataclass(frozen=True)
class Deltas:
    """:class:`Delta` of ``m`` windows, stacked along a leading axis."""

    delta_t: FloatArray  # (m,)
    n: FloatArray  # (m,) samples per window (int64)
    R: FloatArray  # (m, 3, 3)
    p: FloatArray  # (m, 3)
    v: FloatArray  # (m, 3)
    cov: FloatArray  # (m, 9, 9)
    J: FloatArray  # (m, 9, 6)


def integrate_windows(
    acc: FloatArray,
    gyro: FloatArray,
    dt: FloatArray,
    starts: FloatArray,
    bias: FloatArray,
    P: Params,
    *,
    compiled: bool | None = None,
) -> Deltas:
    """Preintegrate every window ``[starts[w], starts[w+1])`` of one sequence, each from identity.

    ``starts`` (m,) int64, strictly increasing in ``[0, N)`` (the last window runs to ``N``);
    ``bias`` (m, 6), one estimate per window. Window ``w``'s numbers are those of
    :func:`integrate_blocks` on its samples.

    With the compiled kernel (:func:`compiled_applies`) all windows' per-sample sums come from one
    C call (``window_sums``: the rotation prefix product restarts at every window start, the suffix
    sums run within each window), and the assembly of the covariances and Jacobians from those sums
    is batched over windows in numpy: no Python code runs per window. Otherwise (numpy kernel,
    anisotropic noise, lever arm) each window goes through :func:`integrate_blocks`, a Python loop
    over windows.
    """
    m, N = starts.shape[0], dt.shape[0]
    ends = np.append(starts[1:], N)
    use_c = compiled is not False and compiled_applies(P)
    if compiled and not use_c:
        raise ValueError(
            "compiled=True: the compiled kernel is not built or does not cover these params "
            "(it needs isotropic noise and no lever arm)"
        )
    if not use_c:
        ds = []
        for w, (s, e) in enumerate(zip(starts.tolist(), ends.tolist(), strict=True)):
            try:
                ds.append(
                    integrate_blocks(acc[s:e], gyro[s:e], dt[s:e], bias[w], P, compiled=compiled)
                )
            except ValueError as exc:
                raise ValueError(f"{exc} (window {w}: samples {s} to {e - 1})") from None
        return Deltas(
            delta_t=np.array([d.delta_t for d in ds]),
            n=ends - starts,
            R=np.stack([d.R for d in ds]),
            p=np.stack([d.p for d in ds]),
            v=np.stack([d.v for d in ds]),
            cov=np.stack([d.cov for d in ds]),
            J=np.stack([d.J for d in ds]),
        )
    assert _imu_ext is not None and P.gyro_var is not None
    assert P.acc_var is not None and P.int_var is not None
    ws = thread_workspace()
    out = np.empty((m, _C_N_OUT))
    bRs = P.body_R_sensor
    longest = int((ends - starts).max())
    with np.errstate(all="ignore"):  # an overflow is reported below, as one ValueError
        _imu_ext.window_sums(
            _c_buffer(acc),
            _c_buffer(gyro),
            _c_buffer(dt),
            np.require(starts, dtype=np.int64, requirements=["C_CONTIGUOUS", "ALIGNED"]),
            _c_buffer(bias),
            bRs is not None,
            _I3 if bRs is None else _c_buffer(bRs),
            _COEF,
            _COEF.shape[1],
            series.SMALL_ANGLE**2,
            ws.get("c_scratch", (longest, _C_N_SCRATCH)),
            out,
        )
        d = _finish_windows(out, ends - starts, P)
    bad = ~(
        np.isfinite(d.cov).all(axis=(1, 2))
        & np.isfinite(d.J).all(axis=(1, 2))
        & np.isfinite(d.R).all(axis=(1, 2))
        & np.isfinite(d.p).all(axis=1)
        & np.isfinite(d.v).all(axis=1)
        & np.isfinite(d.delta_t)
    )
    if bad.any():
        w = int(np.argmax(bad))
        s, e = int(starts[w]), int(ends[w])
        try:
            check_delta_finite(
                Delta(float(d.delta_t[w]), e - s, d.R[w], d.p[w], d.v[w], d.cov[w], d.J[w]),
                acc[s:e],
                gyro[s:e],
                dt[s:e],
                bias[w],
            )
        except ValueError as exc:
            raise ValueError(f"{exc} (window {w}: samples {s} to {e - 1})") from None
    return d


def _finish_windows(out: FloatArray, n: FloatArray, P: Params) -> Deltas:
    """Batched :func:`_integrate_compiled` assembly: ``out`` (m, N_OUT) sums → :class:`Deltas`.

    The same formulas as :func:`_gyro_bias_jacobian`, :func:`_gyro_cov_from_sums` and
    :func:`_finish`, with a leading window axis.
    """
    assert P.gyro_var is not None and P.acc_var is not None and P.int_var is not None
    m = out.shape[0]
    RN = out[:, _C_R].reshape(m, 3, 3)
    T = out[:, _C_T]
    # gyroscope bias Jacobian (frame i), from S = Σ_k w_k Y_k, w ∈ {1, p̃, ṽ}
    S = out[:, _C_S].reshape(m, 7, 3, 3)
    Jg = np.empty((m, 9, 3))
    np.negative(S[:, 0], out=Jg[:, 0:3])
    Jg[:, 3:9] = _sum_hat_times(S[:, 1:7].reshape(m, 2, 3, 3, 3)).reshape(m, 6, 3)
    bRs = P.body_R_sensor
    if bRs is not None:
        Jg = Jg @ bRs
    # gyroscope covariance (frame i) from its sums
    cov = out[:, _C_COVV].reshape(m, 9, 9) * _SIGN9
    M = out[:, _C_M].reshape(m, 2, 3, 2, 3)
    s = out[:, _C_SPV].reshape(m, 2, 3)
    cov[:, 0:3, 0:3] += out[:, _C_SWA, None, None] * _I3
    hats = np.einsum("ab,krb->kra", _HAT9, s).reshape(m, 6, 3)
    cov[:, 3:9, 0:3] -= hats
    cov[:, 0:3, 3:9] -= hats.transpose(0, 2, 1)
    tr = np.trace(M, axis1=2, axis2=4)  # (m, 2, 2)
    cov[:, 3:9, 3:9] += (tr[:, :, None, :, None] * _I3[None, None, :, None, :]).reshape(m, 6, 6)
    cov[:, 3:9, 3:9] -= M.transpose(0, 1, 4, 3, 2).reshape(m, 6, 6)
    cov *= P.gyro_var
    # accelerometer and integration noise (isotropic), then the body chart
    pp = P.acc_var * out[:, _C_SA2] + P.int_var * T
    pv = P.acc_var * out[:, _C_SA]
    vv = P.acc_var * T
    cov[:, 3:6, 3:6] += pp[:, None, None] * _I3
    cov[:, 3:6, 6:9] += pv[:, None, None] * _I3
    cov[:, 6:9, 3:6] += pv[:, None, None] * _I3
    cov[:, 6:9, 6:9] += vv[:, None, None] * _I3
    C = np.einsum("kia,kxiyj,kjb->kxayb", RN, cov.reshape(m, 3, 3, 3, 3), RN, optimize=True)
    C = C.reshape(m, 9, 9)
    C = 0.5 * (C + C.transpose(0, 2, 1))
    Ja = -out[:, _C_JA].reshape(m, 6, 3)
    if bRs is not None:
        Ja = Ja @ bRs
    J = np.zeros((m, 9, 6))
    J[:, 0:3, 3:6] = RN.transpose(0, 2, 1) @ Jg[:, 0:3]
    J[:, 3:9, 0:3] = Ja
    J[:, 3:9, 3:6] = Jg[:, 3:9]
    return Deltas(
        delta_t=T.copy(), n=n, R=RN.copy(), p=out[:, _C_P].copy(), v=out[:, _C_V].copy(), cov=C, J=J
    )
