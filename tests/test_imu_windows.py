"""``preintegrate_windows``: every window equals ``preintegrate`` on it (both kernels) and GTSAM."""

from __future__ import annotations

import gtsam
import numpy as np
import pytest
from test_imu_preintegration import (
    ACC,
    BIAS,
    DT,
    GYRO,
    SENSOR_ARM,
    SENSOR_ROT,
    gtsam_bias_jacobian,
    gtsam_manifold,
    make_params,
    rel,
)

import liebridge.factors as F
from liebridge.imu import PreintegratedImu, PreintegratedWindows, preintegrate, preintegrate_windows
from liebridge.imu import kernel as _imu_kernel

FIELDS = ("delta_R", "delta_p", "delta_v", "covariance", "dR_dbg", "dp_dba", "dp_dbg", "dv_dba")
FIELDS += ("dv_dbg",)


@pytest.fixture(params=["compiled", "numpy"])
def kernel(request, monkeypatch):
    if request.param == "compiled":
        if not _imu_kernel.COMPILED:
            pytest.skip("compiled kernel not built")
    else:
        monkeypatch.setattr(_imu_kernel, "_imu_ext", None)
    return request.param


def _starts(n: int, seed: int = 0) -> np.ndarray:
    """Uneven window lengths, 1 to 250 samples, starting at 0."""
    rng = np.random.default_rng(seed)
    lengths = rng.integers(1, 250, size=n // 60)
    s = np.concatenate([[0], np.cumsum(lengths)])
    return s[s < n]


def assert_window_equals(w: PreintegratedImu, ref: PreintegratedImu) -> None:
    assert w.n_samples == ref.n_samples
    assert abs(w.delta_t - ref.delta_t) < 1e-12
    for f in FIELDS:
        a, b = getattr(w, f), getattr(ref, f)
        scale = max(float(np.abs(b).max()), 1e-300)
        assert np.abs(a - b).max() <= 1e-9 * scale, f
    assert np.array_equal(w.bias_hat, ref.bias_hat)


@pytest.mark.parametrize(
    "sensor", [None, SENSOR_ROT, SENSOR_ARM], ids=["body", "rotated", "lever_arm"]
)
def test_every_window_equals_preintegrate_on_it(kernel, sensor) -> None:
    n = 3000
    params = make_params(body_P_sensor=sensor)
    starts = _starts(n)
    res = F.preintegrate_windows(ACC[:n], GYRO[:n], DT[:n], starts, bias=BIAS, params=params)
    assert isinstance(res, PreintegratedWindows) and len(res) == len(starts)
    ends = np.append(starts[1:], n)
    assert np.array_equal(res.n_samples, ends - starts)
    for k, (s, e) in enumerate(zip(starts, ends, strict=True)):
        ref = preintegrate(ACC[s:e], GYRO[s:e], DT[s:e], bias=BIAS, params=params)
        assert_window_equals(res[k], ref)
    assert res.covariance.shape == (len(starts), 9, 9)
    assert res.bias_jacobian.shape == (len(starts), 9, 6)
    assert np.array_equal(res.bias_jacobian[3], res[3].bias_jacobian)


def test_the_two_kernels_agree_on_a_whole_sequence(monkeypatch) -> None:
    if not _imu_kernel.COMPILED:
        pytest.skip("compiled kernel not built")
    params = make_params()
    starts = np.arange(0, len(DT), 100)
    c = preintegrate_windows(ACC, GYRO, DT, starts, bias=BIAS, params=params)
    monkeypatch.setattr(_imu_kernel, "_imu_ext", None)
    k = np.array([0, 1, len(starts) // 2, len(starts) - 1])
    s, e = starts[k], np.append(starts[1:], len(DT))[k]
    for kk, ss, ee in zip(k, s, e, strict=True):
        ref = preintegrate(ACC[ss:ee], GYRO[ss:ee], DT[ss:ee], bias=BIAS, params=params)
        assert_window_equals(c[int(kk)], ref)


def test_windows_equal_gtsam_with_reset_between_windows(kernel) -> None:
    params = make_params()
    starts = np.array([0, 100, 300, 350])
    n = 500
    res = preintegrate_windows(ACC[:n], GYRO[:n], DT[:n], starts, bias=BIAS, params=params)
    ends = np.append(starts[1:], n)
    for k, (s, e) in enumerate(zip(starts, ends, strict=True)):
        pim = gtsam_manifold(params, BIAS, ACC[s:e], GYRO[s:e], DT[s:e])
        assert np.abs(res.delta_R[k] - pim.deltaRij().matrix()).max() < 1e-9
        assert np.abs(res.delta_p[k] - pim.deltaPij()).max() < 1e-9
        assert np.abs(res.delta_v[k] - pim.deltaVij()).max() < 1e-9
        assert rel(res.covariance[k], pim.preintMeasCov()) < 1e-9
        assert rel(res.bias_jacobian[k], gtsam_bias_jacobian(pim, BIAS)) < 1e-9


def test_one_bias_per_window_and_a_start_after_zero(kernel) -> None:
    params = make_params()
    rng = np.random.default_rng(3)
    starts = np.array([7, 50, 51, 180])
    biases = rng.normal(scale=[0.1, 0.1, 0.1, 0.01, 0.01, 0.01], size=(4, 6))
    n = 260
    res = preintegrate_windows(ACC[:n], GYRO[:n], DT[:n], starts, bias=biases, params=params)
    ends = np.append(starts[1:], n)
    for k, (s, e) in enumerate(zip(starts, ends, strict=True)):
        ref = preintegrate(ACC[s:e], GYRO[s:e], DT[s:e], bias=biases[k], params=params)
        assert_window_equals(res[k], ref)
    assert res[-1].n_samples == 80 and res[2].n_samples == 129


def test_scalar_dt_and_anisotropic_noise(kernel) -> None:
    params = make_params(anisotropic=True)
    starts = [0, 40, 90]
    res = preintegrate_windows(ACC[:120], GYRO[:120], 0.01, starts, bias=BIAS, params=params)
    ref = preintegrate(ACC[40:90], GYRO[40:90], 0.01, bias=BIAS, params=params)
    assert_window_equals(res[1], ref)


def test_factors_are_imu_factors_between_consecutive_keys() -> None:
    params = make_params()
    res = preintegrate_windows(ACC[:300], GYRO[:300], DT[:300], [0, 100, 200], bias=BIAS,
                               params=params)  # fmt: skip
    X = gtsam.symbol_shorthand.X
    V = gtsam.symbol_shorthand.V
    B = gtsam.symbol_shorthand.B
    fs = res.factors([X(k) for k in range(4)], [V(k) for k in range(4)], B(0))
    assert len(fs) == 3
    assert list(fs[1].keys()) == [X(1), V(1), X(2), V(2), B(0)]
    # the factor's error at the state predicted by window 1 is zero
    vals = gtsam.Values()
    T1 = np.eye(4)
    T2, v2 = res[1].predict(T1, np.zeros(3), BIAS)
    vals.insert(X(1), gtsam.Pose3(T1))
    vals.insert(V(1), np.zeros(3))
    vals.insert(X(2), gtsam.Pose3(T2))
    vals.insert(V(2), v2)
    vals.insert(B(0), BIAS)
    assert fs[1].error(vals) < 1e-18
    with pytest.raises(ValueError, match="pose_keys: expected 4 keys"):
        res.factors([X(0)], [V(k) for k in range(4)], B(0))


@pytest.mark.parametrize(
    ("starts", "exc", "match"),
    [
        ([0, 10, 10, 20], ValueError, r"strictly increasing.*starts\[1\] = 10, starts\[2\] = 10"),
        ([0, 30, 20], ValueError, r"starts\[1\] = 30, starts\[2\] = 20"),
        ([-1, 20], ValueError, r"starts\[0\] = -1 is outside \[0, 100\)"),
        ([0, 100], ValueError, r"starts\[1\] = 100 is outside"),
        ([], ValueError, "non-empty"),
        ([[0, 10]], ValueError, "1-D"),
        ([0.5, 10], TypeError, "integer"),
        (["a"], TypeError, "integer"),
    ],
)
def test_bad_starts_are_one_clear_error(starts, exc, match) -> None:
    with pytest.raises(exc, match=match):
        preintegrate_windows(ACC[:100], GYRO[:100], DT[:100], starts, bias=BIAS,
                             params=make_params())  # fmt: skip


def test_bad_bias_batch_and_index() -> None:
    with pytest.raises(ValueError, match=r"bias: expected shape \(6,\) or \(2, 6\)"):
        preintegrate_windows(ACC[:100], GYRO[:100], DT[:100], [0, 50], bias=np.zeros((3, 6)),
                             params=make_params())  # fmt: skip
    res = preintegrate_windows(ACC[:100], GYRO[:100], DT[:100], [0, 50], bias=BIAS,
                               params=make_params())  # fmt: skip
    with pytest.raises(IndexError, match="window 2 out of range for 2 windows"):
        res[2]
    with pytest.raises(ValueError, match="read-only"):
        res.delta_p[0, 0] = 1.0


def test_overflow_names_the_window(kernel) -> None:
    acc = ACC[:100].copy()
    acc[60] = 1e300
    with pytest.raises(ValueError, match=r"overflows float64.*\(window 1: samples 50 to 99\)"):
        preintegrate_windows(acc, GYRO[:100], DT[:100], [0, 50], bias=BIAS, params=make_params())
