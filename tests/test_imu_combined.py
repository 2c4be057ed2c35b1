"""``preintegrate_combined`` equals GTSAM's ``PreintegratedCombinedMeasurements`` (both kernels)."""

from __future__ import annotations

import gtsam
import numpy as np
import pytest
from test_imu_preintegration import ACC, BIAS, DT, GYRO, META, SENSOR_ROT, rel

import liebridge.factors as F
from liebridge.check import numerical_jacobian
from liebridge.imu import PreintegratedCombined, preintegrate_combined
from liebridge.imu import kernel as _imu_kernel


def combined_params(*, anisotropic: bool = False) -> gtsam.PreintegrationCombinedParams:
    p = gtsam.PreintegrationCombinedParams.MakeSharedU(9.8)
    p.setAccelerometerCovariance(META["AccelerometerSigma"] ** 2 * np.eye(3))
    p.setGyroscopeCovariance(META["GyroscopeSigma"] ** 2 * np.eye(3))
    p.setIntegrationCovariance(1e-8 * np.eye(3))
    p.setBiasAccCovariance(META["AccelerometerBiasSigma"] ** 2 * np.eye(3))
    p.setBiasOmegaCovariance(META["GyroscopeBiasSigma"] ** 2 * np.eye(3))
    if anisotropic:
        p.setAccelerometerCovariance(np.diag([1e-4, 2e-4, 3e-4]) + 1e-5)
        p.setBiasOmegaCovariance(np.diag([1e-10, 3e-10, 2e-10]))
    return p


def gtsam_combined(params, bias, acc, gyro, dt) -> gtsam.PreintegratedCombinedMeasurements:
    pim = gtsam.PreintegratedCombinedMeasurements(params, bias)
    for a, w, d in zip(acc, gyro, dt, strict=True):
        pim.integrateMeasurement(a, w, d)
    return pim


@pytest.fixture(params=["compiled", "python"])
def compiled(request) -> bool:
    if request.param == "compiled" and not _imu_kernel.COMPILED:
        pytest.skip("compiled kernel not built")
    return request.param == "compiled"


@pytest.mark.parametrize("anisotropic", [False, True])
def test_equals_gtsam_combined_on_kitti(compiled, anisotropic) -> None:
    n = 2000 if compiled else 400
    params = combined_params(anisotropic=anisotropic)
    pim = gtsam_combined(params, BIAS, ACC[:n], GYRO[:n], DT[:n])
    ours = F.preintegrate_combined(
        ACC[:n], GYRO[:n], DT[:n], bias=BIAS, params=params, compiled=compiled
    )
    assert isinstance(ours, PreintegratedCombined) and ours.n_samples == n
    assert abs(ours.delta_t - pim.deltaTij()) < 1e-12
    assert np.abs(ours.delta_R - pim.deltaRij().matrix()).max() < 1e-9
    assert np.abs(ours.delta_p - pim.deltaPij()).max() < 1e-9
    assert np.abs(ours.delta_v - pim.deltaVij()).max() < 1e-9
    G = pim.preintMeasCov()
    assert G.shape == (15, 15) and ours.covariance.shape == (15, 15)
    assert rel(ours.covariance, G) < 1e-9
    # each block, relative to itself (the bias blocks are tiny next to the position block)
    for i in range(0, 15, 3):
        for j in range(0, 15, 3):
            g = G[i : i + 3, j : j + 3]
            if np.abs(g).max() > 0:
                assert rel(ours.covariance[i : i + 3, j : j + 3], g) < 1e-8, (i, j)
    # the bias random walk block is exactly Q·Δt
    np.testing.assert_allclose(
        ours.covariance[9:12, 9:12], params.getBiasAccCovariance() * pim.deltaTij(), rtol=1e-12
    )


def test_the_two_kernels_agree() -> None:
    if not _imu_kernel.COMPILED:
        pytest.skip("compiled kernel not built")
    p = combined_params()
    a = preintegrate_combined(ACC[:300], GYRO[:300], DT[:300], bias=BIAS, params=p, compiled=True)
    b = preintegrate_combined(ACC[:300], GYRO[:300], DT[:300], bias=BIAS, params=p, compiled=False)
    for f in ("preintegrated", "covariance", "bias_jacobian"):
        assert rel(getattr(a, f), getattr(b, f)) < 1e-12, f


def _spd(rng: np.random.Generator, scale: float) -> np.ndarray:
    """A full (non-diagonal) symmetric positive definite 3×3 of magnitude ``scale``."""
    L = rng.normal(size=(3, 3))
    return scale * (L @ L.T + 0.5 * np.eye(3))


def _hard_case(seed: int, n: int):
    """Fast, varying rotation (|θ| sweeps past π), uneven dt, full anisotropic covariances."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.002, 0.02, size=n))
    gyro = np.column_stack([1.5 * np.sin(0.7 * t), 0.8 * np.cos(1.3 * t), 2.0 + 0.0 * t])
    gyro += 0.05 * rng.normal(size=(n, 3))
    acc = np.column_stack([np.sin(t), 0.5 * np.cos(2 * t), 9.8 + 0.2 * np.sin(3 * t)])
    acc += 0.1 * rng.normal(size=(n, 3))
    dt = np.diff(np.concatenate([[0.0], t]))
    p = gtsam.PreintegrationCombinedParams.MakeSharedU(9.81)
    p.setAccelerometerCovariance(_spd(rng, 1e-4))
    p.setGyroscopeCovariance(_spd(rng, 1e-6))
    p.setIntegrationCovariance(_spd(rng, 1e-8))
    p.setBiasAccCovariance(_spd(rng, 1e-6))
    p.setBiasOmegaCovariance(_spd(rng, 1e-8))
    bias = gtsam.imuBias.ConstantBias(rng.normal(0, 0.05, 3), rng.normal(0, 0.01, 3))
    return acc, gyro, dt, bias, p


def _assert_equals_gtsam(ours: PreintegratedCombined, pim, *, tol: float = 1e-9) -> None:
    assert abs(ours.delta_t - pim.deltaTij()) < 1e-9
    assert np.abs(ours.delta_R - pim.deltaRij().matrix()).max() < tol
    assert rel(ours.delta_p, pim.deltaPij()) < tol
    assert rel(ours.delta_v, pim.deltaVij()) < tol
    G = pim.preintMeasCov()
    assert rel(ours.covariance, G) < tol
    for i in range(0, 15, 3):  # each 3×3 block relative to itself (bias blocks are tiny)
        for j in range(0, 15, 3):
            if np.abs(G[i : i + 3, j : j + 3]).max() > 0:
                assert rel(ours.covariance[i : i + 3, j : j + 3], G[i : i + 3, j : j + 3]) < 1e-7
            else:
                assert np.all(ours.covariance[i : i + 3, j : j + 3] == 0.0), (i, j)
    # (GTSAM's Python API does not expose preintegrated_H_bias*: the bias Jacobian is checked
    # against the Python reference and central differences instead)


@pytest.mark.parametrize("seed", [0, 1])
def test_equals_gtsam_on_fast_rotation_uneven_dt_full_covariances(compiled, seed) -> None:
    """|θ| goes past π, dt varies 10×, every noise covariance is full and anisotropic."""
    n = 1500 if compiled else 300
    acc, gyro, dt, bias, p = _hard_case(seed, n)
    pim = gtsam_combined(p, bias, acc, gyro, dt)
    assert np.linalg.norm(gtsam.Rot3.Logmap(pim.deltaRij())) > 0.5  # a real rotation
    ours = preintegrate_combined(acc, gyro, dt, bias=bias, params=p, compiled=compiled)
    _assert_equals_gtsam(ours, pim)
    if compiled:  # the tangent θ sweeps past π on the way (up to ~5 rad)
        thetas = [
            preintegrate_combined(acc[:m], gyro[:m], dt[:m], bias=bias, params=p).preintegrated[:3]
            for m in range(100, n, 100)
        ]
        assert max(np.linalg.norm(thetas, axis=1)) > 4.0


@pytest.mark.parametrize("rate", [0.0, 1e-9, 1e-4])
def test_equals_gtsam_near_zero_rotation(compiled, rate) -> None:
    """|θ| stays below 1e-2: the series branch of every coefficient (exactly 0 for rate 0)."""
    n = 200
    acc, _, dt, _, p = _hard_case(3, n)
    bias = gtsam.imuBias.ConstantBias(np.array([0.01, 0.02, -0.01]), np.array([1e-3, -2e-3, 5e-4]))
    gyro = np.tile(bias.gyroscope(), (n, 1)) + rate * np.array([1.0, -0.5, 0.25])
    pim = gtsam_combined(p, bias, acc, gyro, dt)
    ours = preintegrate_combined(acc, gyro, dt, bias=bias, params=p, compiled=compiled)
    if rate == 0.0:
        assert np.all(ours.preintegrated[:3] == 0.0)
    _assert_equals_gtsam(ours, pim)


def test_the_kernels_agree_on_the_hard_case() -> None:
    """The compiled loop against the Python reference (the dense F Σ Fᵀ), same inputs."""
    if not _imu_kernel.COMPILED:
        pytest.skip("compiled kernel not built")
    acc, gyro, dt, bias, p = _hard_case(5, 400)
    a = preintegrate_combined(acc, gyro, dt, bias=bias, params=p, compiled=True)
    b = preintegrate_combined(acc, gyro, dt, bias=bias, params=p, compiled=False)
    for f in ("preintegrated", "covariance", "bias_jacobian"):
        assert rel(getattr(a, f), getattr(b, f)) < 1e-12, f


def test_acceptance_40k_kitti_samples_equal_gtsam() -> None:
    """The acceptance on 40,000 KITTI samples: ΔR, Δv, Δp (relative), Σ to 1e-9."""
    if not _imu_kernel.COMPILED:
        pytest.skip("compiled kernel not built (the Python loop would take minutes)")
    n = 40_000
    params = combined_params(anisotropic=True)
    pim = gtsam_combined(params, BIAS, ACC[:n], GYRO[:n], DT[:n])
    ours = preintegrate_combined(ACC[:n], GYRO[:n], DT[:n], bias=BIAS, params=params)
    assert np.abs(ours.delta_R - pim.deltaRij().matrix()).max() < 1e-9
    # Δv (~3.5e3 m/s) and Δp (~7e5 m), gravity excluded, relative to their size (400 s)
    assert rel(ours.delta_v, pim.deltaVij()) < 1e-9
    assert rel(ours.delta_p, pim.deltaPij()) < 1e-9
    assert rel(ours.covariance, pim.preintMeasCov()) < 1e-9


def test_differs_from_the_manifold_preintegration() -> None:
    """GTSAM's combined preintegration is the tangent one, not liebridge's manifold one."""
    n = 1000
    p = combined_params()
    ours = preintegrate_combined(ACC[:n], GYRO[:n], DT[:n], bias=BIAS, params=p)
    manifold = F.preintegrate(ACC[:n], GYRO[:n], DT[:n], bias=BIAS, params=p)
    assert np.abs(ours.delta_p - manifold.delta_p).max() > 1e-7


def test_bias_jacobian_matches_finite_differences() -> None:
    n = 200
    p = combined_params()
    b0 = BIAS.vector()
    ours = preintegrate_combined(ACC[:n], GYRO[:n], DT[:n], bias=b0, params=p)

    def f(b: np.ndarray) -> np.ndarray:
        return preintegrate_combined(ACC[:n], GYRO[:n], DT[:n], bias=b, params=p).preintegrated

    J = numerical_jacobian(f, b0)
    assert rel(ours.bias_jacobian, J) < 1e-6


def test_bad_input() -> None:
    with pytest.raises(TypeError, match="PreintegrationCombinedParams"):
        preintegrate_combined(ACC[:10], GYRO[:10], DT[:10], bias=BIAS,
                              params=gtsam.PreintegrationParams.MakeSharedU(9.8))  # fmt: skip
    p = combined_params()
    p.setBodyPSensor(SENSOR_ROT)
    with pytest.raises(ValueError, match="body_P_sensor is not supported"):
        preintegrate_combined(ACC[:10], GYRO[:10], DT[:10], bias=BIAS, params=p)
    dt = DT[:10].copy()
    dt[4] = -1.0
    with pytest.raises(ValueError, match=r"dt\[4\]"):
        preintegrate_combined(ACC[:10], GYRO[:10], dt, bias=BIAS, params=combined_params())
    r = preintegrate_combined(ACC[:10], GYRO[:10], DT[:10], bias=BIAS, params=combined_params())
    with pytest.raises(ValueError, match="read-only"):
        r.covariance[0, 0] = 1.0


@pytest.mark.parametrize(
    "mode", [gtsam.ImuFactorErrorMode.Logmap, gtsam.ImuFactorErrorMode.ComponentWise]
)
def test_residual_covariance_is_the_combined_factors_noise_model(mode) -> None:
    """CombinedImuFactor's noise model is residualCovariance(), not preintMeasCov() (measured)."""
    n = 2000
    p = combined_params()
    p.setImuFactorErrorMode(mode)
    pim = gtsam_combined(p, BIAS, ACC[:n], GYRO[:n], DT[:n])
    ours = preintegrate_combined(ACC[:n], GYRO[:n], DT[:n], bias=BIAS, params=p)
    factor = gtsam.CombinedImuFactor(1, 2, 3, 4, 5, 6, pim)
    R = factor.noiseModel().R()
    noise_cov = np.linalg.inv(R.T @ R)
    assert rel(noise_cov, pim.residualCovariance()) < 1e-9
    assert rel(ours.residual_covariance, pim.residualCovariance()) < 1e-9
    assert rel(pim.preintMeasCov(), pim.residualCovariance()) > 1e-2  # they are not the same
