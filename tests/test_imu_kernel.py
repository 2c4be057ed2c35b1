"""The pieces of the vectorized IMU kernel (liebridge.imu.kernel), each against a plain
reference: the banded-solve rotation scan against a sequential product, the truncated coefficient
series against 50-digit arithmetic, the suffix sums against a running sum, and the gyro
input block against ΔR_{k+1} J_r(θ_k) dt_k."""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from liebridge.imu import inputs as _imu_inputs
from liebridge.imu import kernel as K
from liebridge.lie import so3

# ------------------------------------------------------------------------------------------------
# rotation scan


def _increments(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    th2 = np.einsum("in,in->n", theta, theta)
    coef = K._coefficients(th2, K.Workspace())
    return coef[3], theta * (0.5 * coef[4])


@pytest.mark.parametrize("n", [1, 2, 17, 1000])
@pytest.mark.parametrize("scale", [0.0, 1e-12, 0.02, 1.0, 3.1])
def test_rotation_scan_equals_sequential_product(n: int, scale: float) -> None:
    rng = np.random.default_rng(n)
    theta = rng.normal(size=(3, n)) * scale
    R9, RN = K._rotation_scan(*_increments(theta), K.Workspace())
    R = np.eye(3)
    ref = [R]
    for k in range(n):
        R = R @ so3.exp(theta[:, k])
        ref.append(R)
    ref_arr = np.array(ref)  # (n + 1, 3, 3)
    got = R9.reshape(3, 3, n + 1).transpose(2, 0, 1)
    assert np.abs(got - ref_arr).max() < 1e-13 * max(1.0, n**0.5)
    assert np.array_equal(RN, got[-1])
    # normalised on the fly: orthonormal to rounding whatever the length
    assert np.abs(got[-1] @ got[-1].T - np.eye(3)).max() < 1e-15 * 8


def test_rotation_scan_is_forward_substitution_to_rounding() -> None:
    """ztbtrs performs the complex products of a sequential loop, to the rounding of each product.

    Not bit for bit: OpenBLAS picks its kernel by CPU (``OPENBLAS_CORETYPE``), and the kernels
    round each complex multiply-add differently (FMA contraction or not, the order of the four
    real products). Each of the n = 200 steps may then differ by about 2 ulps with a random sign,
    so the difference grows like √n: the bound is 4·√n ulps of 1 (|entries| ≤ 1). Measured
    (OpenBLAS 0.3.30): 0 ulp on Haswell, Zen and Sandybridge, 3.5 on SkylakeX, 9.5 on Prescott;
    a different algorithm (a parallel prefix product, a dropped normalisation) misses by far more.
    """
    n = 200
    rng = np.random.default_rng(3)
    theta = rng.normal(size=(3, n)) * 0.05
    ch, qv = _increments(theta)
    R9, _ = K._rotation_scan(ch, qv, K.Workspace())
    alpha, beta = 1.0 + 0j, 0j
    quats = [(alpha, beta)]
    for k in range(n):
        a2, b2 = complex(ch[k], qv[0, k]), complex(qv[1, k], qv[2, k])
        alpha, beta = alpha * a2 - beta * b2.conjugate(), alpha * b2 + beta * a2.conjugate()
        quats.append((alpha, beta))
    q4 = np.array([[a.real, a.imag, b.real, b.imag] for a, b in quats]).T
    ref, _ = K._quat_to_R9(q4, K.Workspace())
    ulps = np.abs(R9 - ref).max() / np.finfo(np.float64).eps
    assert ulps <= 4.0 * np.sqrt(n), f"{ulps:.1f} ulps from the sequential product"


# ------------------------------------------------------------------------------------------------
# coefficients


def _mp_coefficients(theta: float) -> list[float]:
    with mpmath.workdps(50):
        t = mpmath.mpf(theta)
        if t == 0:
            return [1.0, 0.5, 1.0 / 6.0, 1.0, 1.0]
        h = t / 2
        return [
            float(mpmath.sin(t) / t),
            float((1 - mpmath.cos(t)) / t**2),
            float((t - mpmath.sin(t)) / t**3),
            float(mpmath.cos(h)),
            float(mpmath.sin(h) / h),
        ]


ANGLES = [0.0, 1e-12, 1e-6, 1e-3, 0.01, 0.1, 0.3, 0.4999999, 0.5, 0.5000001, 1.0, 2.0, 3.0, np.pi]


@pytest.mark.parametrize("spread", ["alone", "mixed"])
def test_coefficients_match_50_digit_values(spread: str) -> None:
    """The number of series terms depends on the block's largest angle: test each angle alone
    (fewest terms) and all of them in one block (most terms, closed forms on the large ones)."""
    ref = np.array([_mp_coefficients(t) for t in ANGLES]).T
    if spread == "alone":
        got = np.stack(
            [K._coefficients(np.array([t * t]), K.Workspace())[:, 0] for t in ANGLES], axis=1
        )
    else:
        got = K._coefficients(np.array(ANGLES) ** 2, K.Workspace())
    rel = np.abs(got - ref) / np.abs(ref)
    assert rel.max() < 3e-15, (rel.max(), np.unravel_index(rel.argmax(), rel.shape))


def test_series_truncation_keeps_terms_for_the_largest_small_angle() -> None:
    assert K._n_terms(0.0) == 1
    assert K._n_terms(1e-6) <= 3
    # the rule: the first omitted term is below 2⁻⁵⁶ relative, up to θ = SMALL_ANGLE
    for t2 in (1e-8, 1e-4, 1e-2, 0.1, 0.2, 0.25):
        k = K._n_terms(t2)
        assert k == 9 or K._TERM[k] * t2**k < 2.0**-56


# ------------------------------------------------------------------------------------------------
# suffix sums


@given(n=st.integers(1, 300), rows=st.integers(1, 4), seed=st.integers(0, 2**32 - 1))
def test_suffix_sum_equals_running_sum_from_the_end(n: int, rows: int, seed: int) -> None:
    x = np.random.default_rng(seed).normal(size=(rows, n)) * 10.0
    got, total = K._suffix_sum(x)
    inclusive = np.cumsum(x[:, ::-1], axis=1)[:, ::-1]
    ref = np.concatenate([inclusive[:, 1:], np.zeros((rows, 1))], axis=1)
    scale = max(1.0, float(np.abs(x).sum(axis=1).max()))
    assert np.abs(got - ref).max() <= 1e-13 * scale
    assert np.abs(total - inclusive[:, 0]).max() <= 1e-13 * scale


@pytest.mark.parametrize("n", [1, 15, 16, 17, 32, 4096, 5003])
def test_suffix_sum_block_edges(n: int) -> None:
    x = np.arange(1.0, n + 1.0)[None]  # exact integers: every order of summation is exact
    out = np.full((1, n), np.nan)
    got, total = K._suffix_sum(x, out=out)
    assert got is out
    assert np.array_equal(got[0], n * (n + 1) / 2 - np.cumsum(x[0]))
    assert total[0] == n * (n + 1) / 2


# ------------------------------------------------------------------------------------------------
# the gyro input block


def test_gyro_input_block_is_right_jacobian_carried_by_the_next_rotation() -> None:
    """Y_k = ΔR_k J_l(θ_k) dt equals ΔR_{k+1} J_r(θ_k) dt (what GTSAM's recursion uses), and the
    weighted sums S = Σ_k w_k Y_k equal the same sums of the reference blocks."""
    rng = np.random.default_rng(11)
    n = 50
    theta = rng.normal(size=(3, n)) * 0.7  # some above SMALL_ANGLE
    dt = rng.uniform(0.001, 0.02, n)
    R9, _ = K._rotation_scan(*_increments(theta), K.Workspace())
    R = R9.reshape(3, 3, n + 1).transpose(2, 0, 1)
    ref = np.array([R[k + 1] @ so3.jr(theta[:, k]) * dt[k] for k in range(n)])
    alt = np.array([R[k] @ so3.jl(theta[:, k]) * dt[k] for k in range(n)])
    assert np.abs(ref - alt).max() < 1e-15
    # the kernel's elementwise construction, as integrate() builds it
    coef = K._coefficients(np.einsum("in,in->n", theta, theta), K.Workspace())
    R3 = R9[:, :n].reshape(3, 3, n)
    u = np.einsum("ijn,jn->in", R3, theta)
    g, Cu = u * (coef[1] * dt), u * (coef[2] * dt)
    Y = R3 * (coef[0] * dt) + Cu[:, None, :] * theta[None, :, :]
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        Y[i] += R3[k] * g[j] - R3[j] * g[k]
    assert np.abs(Y.transpose(2, 0, 1) - ref).max() < 1e-15


def test_sum_hat_times_is_sum_of_skew_products() -> None:
    rng = np.random.default_rng(5)
    M = rng.normal(size=(3, 3, 3))
    ref = sum(so3.hat(np.eye(3)[b]) @ M[b] for b in range(3))
    assert np.allclose(K._sum_hat_times(M), ref, atol=1e-15)


# ------------------------------------------------------------------------------------------------
# the compiled kernel (liebridge/imu/_imu_ext.c) against the numpy kernel

requires_compiled = pytest.mark.skipif(not K.COMPILED, reason="compiled kernel not built")


def test_compiled_kernel_is_built_where_ci_requires_it() -> None:
    """.ci/run sets LIEBRIDGE_REQUIRE_COMPILED=1: there a silently skipped build is a failure."""
    import os

    if os.environ.get("LIEBRIDGE_REQUIRE_COMPILED") == "1":
        assert K.COMPILED


def _params(body_rot: bool = False, aniso: bool = False) -> object:
    import gtsam

    p = gtsam.PreintegrationParams.MakeSharedU(9.81)
    p.setAccelerometerCovariance(np.diag([1e-4, 2e-4, 3e-4]) if aniso else 1e-4 * np.eye(3))
    p.setGyroscopeCovariance(3e-8 * np.eye(3))
    p.setIntegrationCovariance(1e-8 * np.eye(3))
    if body_rot:
        p.setBodyPSensor(gtsam.Pose3(gtsam.Rot3.Expmap([0.4, -0.3, 1.0]), np.zeros(3)))
    return p


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


@requires_compiled
@given(
    n=st.integers(1, 60),
    seed=st.integers(0, 2**32 - 1),
    spin=st.sampled_from([0.0, 0.5, 5.0, 60.0]),
    body_rot=st.booleans(),
)
def test_compiled_equals_numpy_kernel(n: int, seed: int, spin: float, body_rot: bool) -> None:
    rng = np.random.default_rng(seed)
    acc = rng.normal(size=(n, 3)) * 3 + [0, 0, 9.8]
    gyro = rng.normal(size=(n, 3)) * spin  # up to 3 rad per step: closed forms as well as series
    dt = rng.uniform(1e-3, 0.05, size=n)
    bias = rng.normal(size=6) * 0.1
    P = _imu_inputs.read_params(_params(body_rot))
    assert K.compiled_applies(P)
    c = K.integrate(acc, gyro, dt, bias, P, compiled=True)
    nu = K.integrate(acc, gyro, dt, bias, P, compiled=False)
    assert c.n == nu.n == n
    assert abs(c.delta_t - nu.delta_t) <= 1e-15 * nu.delta_t
    for f in ("R", "p", "v", "cov", "J"):
        assert _rel(getattr(c, f), getattr(nu, f)) < 1e-12, f


@requires_compiled
@pytest.mark.parametrize("n", [K.BLOCK - 1, K.BLOCK + K.BLOCK // 4 + 3, 3 * K.BLOCK + 5])
def test_compiled_equals_numpy_across_block_boundaries(n: int) -> None:
    rng = np.random.default_rng(n)
    acc = rng.normal(size=(n, 3)) + np.array([0.0, 0.0, 9.8])
    gyro = rng.normal(size=(n, 3)) * 0.3
    dt = np.full(n, 0.005)
    P = _imu_inputs.read_params(_params())
    bias = np.array([0.05, -0.03, 0.1, 2e-3, -1e-3, 3e-3])
    c = K.integrate_blocks(acc, gyro, dt, bias, P, compiled=True)
    nu = K.integrate_blocks(acc, gyro, dt, bias, P, compiled=False)
    for f in ("R", "p", "v", "cov", "J"):
        assert _rel(getattr(c, f), getattr(nu, f)) < 1e-12, f


def test_compiled_switch_and_coverage() -> None:
    from liebridge.factors import imu_kernel

    assert imu_kernel(_params()) == ("compiled" if K.COMPILED else "numpy")
    assert imu_kernel(_params(body_rot=True)) == ("compiled" if K.COMPILED else "numpy")
    assert imu_kernel(_params(aniso=True)) == "numpy"
    aniso = _imu_inputs.read_params(_params(aniso=True))
    assert not K.compiled_applies(aniso)  # anisotropic accelerometer noise: numpy only
    x = np.zeros((5, 3))
    with pytest.raises(ValueError, match="compiled=True"):
        K.integrate(x, x, np.full(5, 0.01), np.zeros(6), aniso, compiled=True)
    d = K.integrate(x, x, np.full(5, 0.01), np.zeros(6), aniso)  # falls back to numpy
    assert d.n == 5


def test_without_the_compiled_kernel_preintegrate_uses_numpy(monkeypatch) -> None:
    """The extension is optional: with it missing, every result comes from numpy unchanged."""
    from liebridge.factors import preintegrate

    rng = np.random.default_rng(2)
    acc, gyro, dt = rng.normal(size=(300, 3)), rng.normal(size=(300, 3)), np.full(300, 0.01)
    params = _params()
    with_c = preintegrate(acc, gyro, dt, bias=np.zeros(6), params=params)
    monkeypatch.setattr(K, "_imu_ext", None)
    assert not K.compiled_applies(_imu_inputs.read_params(params))
    without = preintegrate(acc, gyro, dt, bias=np.zeros(6), params=params)
    assert _rel(with_c.covariance, without.covariance) < 1e-12
    assert _rel(with_c.bias_jacobian, without.bias_jacobian) < 1e-12
    assert np.abs(with_c.delta_R - without.delta_R).max() < 1e-15


def _imu_inputs_read(params: object) -> object:
    return _imu_inputs.read_params(params)


@requires_compiled
def test_compiled_kernel_rejects_wrong_buffer_sizes() -> None:
    from liebridge.imu import _imu_ext

    n = 4
    args = dict(
        acc=np.zeros((n, 3)),
        gyro=np.zeros((n, 3)),
        dt=np.full(n, 0.01),
        bias=np.zeros(6),
        rotate=False,
        bRs=np.eye(3),
        coef=K._COEF,
        K=9,
        small2=0.25,
        scratch=np.empty((n, K._C_N_SCRATCH)),
        out=np.empty(K._C_N_OUT),
    )
    _imu_ext.block_sums(*args.values())
    for name, bad in [
        ("acc", np.zeros((n, 2))),
        ("bias", np.zeros(5)),
        ("bRs", np.eye(2)),
        ("coef", K._COEF[:4]),
        ("K", 10),
        ("scratch", np.empty((n, 3))),
        ("out", np.empty(5)),
        ("dt", np.zeros(0)),
    ]:
        with pytest.raises(ValueError):
            _imu_ext.block_sums(*{**args, name: bad}.values())
    with pytest.raises(TypeError):  # a read-only output buffer
        out = np.empty(K._C_N_OUT)
        out.flags.writeable = False
        _imu_ext.block_sums(*{**args, "out": out}.values())


def test_compiled_path_reads_byte_swapped_and_fortran_ordered_input_correctly() -> None:
    """The C kernel reads raw float64 buffers: inputs in another byte order or memory layout must
    reach it converted (regression guard for the buffer interface)."""
    from liebridge.factors import preintegrate

    rng = np.random.default_rng(0)
    acc, gyro, dt = rng.normal(size=(50, 3)), rng.normal(size=(50, 3)), np.full(50, 0.01)
    params = _params()
    ref = preintegrate(acc, gyro, dt, bias=np.zeros(6), params=params)
    for a, g, d, b in [
        (acc.astype(">f8"), gyro.astype(">f8"), dt.astype(">f8"), np.zeros(6, dtype=">f8")),
        (np.asfortranarray(acc), np.asfortranarray(gyro), dt, np.zeros(6)),
        (np.hstack([acc, gyro])[:, :3], np.hstack([acc, gyro])[:, 3:], dt, np.zeros(6)),
    ]:
        r = preintegrate(a, g, d, bias=b, params=params)
        assert np.array_equal(r.covariance, ref.covariance)
        assert np.array_equal(r.delta_p, ref.delta_p)


def test_output_layout_matches_the_c_defines() -> None:
    """The slices that read the compiled kernel's output are the O_* offsets of the C file."""
    import re
    from pathlib import Path

    src = (Path(K.__file__).with_name("_imu_ext.c")).read_text()
    d = {k: int(v) for k, v in re.findall(r"#define (O_\w+|N_OUT|N_SCRATCH) (\d+)", src)}
    starts = [
        (K._C_R, "O_R"), (K._C_P, "O_P"), (K._C_V, "O_V"), (K._C_S, "O_S"), (K._C_JA, "O_JA"),
        (K._C_COVV, "O_COVV"), (K._C_M, "O_M"), (K._C_SPV, "O_SPV"),
    ]  # fmt: skip
    for sl, name in starts:
        assert sl.start == d[name], name
    ends = [K._C_R.stop, K._C_P.stop, K._C_V.stop, K._C_T + 1, K._C_S.stop, K._C_JA.stop]
    assert ends == [d["O_P"], d["O_V"], d["O_T"], d["O_S"], d["O_JA"], d["O_COVV"]]
    assert (K._C_COVV.stop, K._C_M.stop, K._C_SPV.stop) == (d["O_M"], d["O_SPV"], d["O_SWA"])
    assert (K._C_T, K._C_SWA, K._C_SA2, K._C_SA) == (d["O_T"], d["O_SWA"], d["O_SA2"], d["O_SA"])
    assert (K._C_N_OUT, K._C_N_SCRATCH) == (d["N_OUT"], d["N_SCRATCH"])
