"""Transform: frames checked when composing; inverse and compose with covariance vs Monte Carlo."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from liebridge import conventions as C
from liebridge.frames import FrameMismatchError, Transform
from liebridge.lie import se3


def _pose(rng: np.random.Generator, scale: float = 1.0) -> np.ndarray:
    return se3.exp(np.concatenate([rng.normal(size=3), scale * rng.normal(size=3)]))


def _cov(rng: np.random.Generator, rot: float = 0.05, trans: float = 0.1) -> np.ndarray:
    A = rng.normal(size=(6, 6)) * 0.3 + np.eye(6)
    D = np.diag([rot] * 3 + [trans] * 3)
    return D @ A @ A.T @ D / 2.0


def test_compose_mismatched_frames_names_both() -> None:
    T_a_b = Transform(np.eye(4), "a", "b")
    T_c_d = Transform(np.eye(4), "c", "d")
    with pytest.raises(FrameMismatchError) as exc:
        T_a_b @ T_c_d
    msg = str(exc.value)
    assert "'b'" in msg and "'c'" in msg and "T_a_b" in msg and "T_c_d" in msg


def test_compose_and_inverse_frames_and_points() -> None:
    rng = np.random.default_rng(1)
    T_w_b = Transform(_pose(rng, 30.0), "world", "body")
    T_b_c = Transform(_pose(rng), "body", "cam")
    T_w_c = T_w_b @ T_b_c
    assert (T_w_c.target_frame, T_w_c.source_frame) == ("world", "cam")
    p_cam = rng.normal(size=(5, 3))
    np.testing.assert_allclose(T_w_c.apply(p_cam), T_w_b.apply(T_b_c.apply(p_cam)), atol=1e-12)
    back = T_w_c.inverse().apply(T_w_c.apply(p_cam))
    np.testing.assert_allclose(back, p_cam, atol=1e-12)
    assert T_w_c.inverse().name == "T_cam_world"


def test_inputs_not_aliased_and_read_only() -> None:
    T = np.eye(4)
    tf = Transform(T, "a", "b")
    T[0, 3] = 5.0
    assert tf.T[0, 3] == 0.0
    with pytest.raises(ValueError):
        tf.T[0, 3] = 1.0


@pytest.mark.parametrize(
    ("bad", "match"),
    [
        (np.diag([1.0, 1.0, 2.0, 1.0]), "not a rotation"),
        (np.diag([1.0, 1.0, -1.0, 1.0]), "reflection"),
        (np.ones((3, 3)), "expected shape"),
    ],
)
def test_bad_matrix_named(bad: np.ndarray, match: str) -> None:
    with pytest.raises(ValueError, match=match) as exc:
        Transform(bad, "cam0", "imu0")
    assert "T_cam0_imu0" in str(exc.value)


def test_bad_frame_names() -> None:
    with pytest.raises(ValueError, match="target_frame"):
        Transform(np.eye(4), "my cam", "imu")
    with pytest.raises(TypeError, match="source_frame"):
        Transform(np.eye(4), "cam", None)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="expected a Transform"):
        Transform(np.eye(4), "a", "b").compose(np.eye(4))  # type: ignore[arg-type]


@given(st.integers(0, 10_000))
def test_batched_compose_matches_one_by_one(seed: int) -> None:
    rng = np.random.default_rng(seed)
    A = np.stack([_pose(rng, 10.0) for _ in range(4)])
    B = _pose(rng)
    ab = Transform(A, "a", "b") @ Transform(B, "b", "c")
    for i in range(4):
        one = Transform(A[i], "a", "b") @ Transform(B, "b", "c")
        np.testing.assert_allclose(ab[i].T, one.T, atol=1e-12)


def _mc_cov(samples: np.ndarray, mean: np.ndarray, conv: C.Convention) -> np.ndarray:
    d = C.unchecked.local(conv, mean, samples)
    return np.asarray(np.cov(d.T))


def _close(emp: np.ndarray, ana: np.ndarray, rel: float) -> None:
    err = np.abs(emp - ana).max() / np.abs(ana).max()
    assert err < rel, f"Monte Carlo vs first order: relative max error {err:.3g}"


@pytest.mark.parametrize("conv", ["gtsam", "sophus", "ros", "barfoot"])
def test_inverse_covariance_monte_carlo(conv: str) -> None:
    rng = np.random.default_rng(7)
    cv = C.get(conv)
    T = _pose(rng, 5.0)
    Sigma = _cov(rng)
    tf = Transform(T, "a", "b", Sigma, cv)
    inv = tf.inverse()
    assert inv.convention == cv
    n = 40_000
    d = rng.multivariate_normal(np.zeros(6), Sigma, size=n)
    samples = se3.inverse(C.unchecked.retract(cv, T, d))
    _close(_mc_cov(samples, inv.T, cv), inv.cov, 0.04)


@pytest.mark.parametrize("conv", ["gtsam", "pytransform3d_global", "ros"])
def test_compose_covariance_monte_carlo(conv: str) -> None:
    rng = np.random.default_rng(11)
    cv = C.get(conv)
    T1, T2 = _pose(rng, 20.0), _pose(rng, 2.0)
    S1, S2 = _cov(rng), _cov(rng, 0.03, 0.2)
    ab = Transform(T1, "a", "b", S1, cv)
    bc = Transform(T2, "b", "c", S2, cv)
    ac = ab @ bc
    n = 40_000
    d1 = rng.multivariate_normal(np.zeros(6), S1, size=n)
    d2 = rng.multivariate_normal(np.zeros(6), S2, size=n)
    samples = C.unchecked.retract(cv, T1, d1) @ C.unchecked.retract(cv, T2, d2)
    _close(_mc_cov(samples, ac.T, cv), ac.cov, 0.05)
    # one operand without covariance: only the other's, carried through
    only = Transform(T1, "a", "b", S1, cv) @ Transform(T2, "b", "c")
    samples1 = C.unchecked.retract(cv, T1, d1) @ T2
    _close(_mc_cov(samples1, only.T, cv), only.cov, 0.05)


def test_inverse_covariance_is_not_unchanged() -> None:
    """The tempting Σ_inv = Σ is wrong away from the identity: measured, not assumed."""
    rng = np.random.default_rng(3)
    T = _pose(rng, 10.0)
    Sigma = _cov(rng)
    inv = Transform(T, "a", "b", Sigma).inverse()
    assert np.abs(inv.cov - Sigma).max() > 0.1 * np.abs(Sigma).max()


@pytest.mark.parametrize(
    "xi",
    [
        np.zeros(6),
        np.array([1e-12, 0.0, 0.0, 30.0, -30.0, 30.0]),
        np.array([np.pi, 0.0, 0.0, 30.0, 5.0, -30.0]),  # exactly π, 30 m
        np.array([0.0, (np.pi - 1e-9) / np.sqrt(2), (np.pi - 1e-9) / np.sqrt(2), 1.0, 2.0, 3.0]),
    ],
)
def test_inverse_and_compose_covariance_edge_poses(xi: np.ndarray) -> None:
    rng = np.random.default_rng(12)
    T = se3.exp(xi)
    S = _cov(rng, 0.02, 0.05)
    tf = Transform(T, "a", "b", S)
    n = 30_000
    d = rng.multivariate_normal(np.zeros(6), S, size=n)
    inv = tf.inverse()
    samples = se3.inverse(C.unchecked.retract(C.GTSAM, T, d))
    _close(_mc_cov(samples, inv.T, C.GTSAM), inv.cov, 0.05)
