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
