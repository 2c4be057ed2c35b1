"""Axis conventions: one physical motion in ENU/FLU and NED/FRD, covariances following."""

from __future__ import annotations

import numpy as np
import pytest

from liebridge import conventions as C
from liebridge.frames import Transform, axes
from liebridge.lie import se3, so3


def _rz(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _T(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T


def test_rotations_from_the_definitions() -> None:
    # ENU coordinates of a point given in NED: x_e = y_n (east), y_e = x_n (north), z_e = -z_n
    np.testing.assert_array_equal(axes.rotation("ENU", "NED"), [[0, 1, 0], [1, 0, 0], [0, 0, -1]])
    np.testing.assert_array_equal(axes.rotation("FLU", "FRD"), np.diag([1.0, -1.0, -1.0]))
    # optical z (forward) is body x; optical x (right) is body -y; optical y (down) is body -z
    np.testing.assert_array_equal(
        axes.rotation("FLU", "optical"), [[0, 0, 1], [-1, 0, 0], [0, -1, 0]]
    )
    # OpenGL: x right, y up, z backward = optical with y and z flipped
    np.testing.assert_array_equal(axes.rotation("RDF", "opengl"), np.diag([1.0, -1.0, -1.0]))
    for a in axes.names():
        for b in axes.names():
            if axes.get(a).kind == axes.get(b).kind:
                R = axes.rotation(a, b)
                np.testing.assert_array_equal(R @ axes.rotation(b, a), np.eye(3))
                assert np.linalg.det(R) == pytest.approx(1.0)


def test_bad_axes() -> None:
    with pytest.raises(ValueError, match=r"ENU \(world axes\) and FRD \(body axes\)"):
        axes.rotation("ENU", "FRD")
    with pytest.raises(ValueError, match="did you mean 'NED'"):
        axes.get("NDE")
    with pytest.raises(ValueError, match="not right-handed"):
        axes.Axes("bad", "body", "forward", "left", "down")


def test_same_physical_motion_in_enu_flu_and_ned_frd() -> None:
    """A vehicle heading north-east at 10 m height drives 1 m forward while yawing 10° left."""
    h = np.deg2rad(45.0)
    dyaw = np.deg2rad(10.0)
    # ENU/FLU, written from the definitions: heading 45° counter-clockwise from east about up
    T_enu_flu = _T(_rz(h), np.array([100.0, 50.0, 10.0]))
    step_flu = _T(_rz(dyaw), np.array([1.0, 0.0, 0.0]))  # left turn = +yaw about up
    # NED/FRD, written independently: heading 45° clockwise from north about down
    T_ned_frd = _T(_rz(h), np.array([50.0, 100.0, -10.0]))
    step_frd = _T(_rz(-dyaw), np.array([1.0, 0.0, 0.0]))  # left turn = -yaw about down

    after_enu = Transform(T_enu_flu @ step_flu, "map", "base_link")
    after_ned = T_ned_frd @ step_frd

    # liebridge: change the axes of the ENU/FLU result by composing constant frames
    A = axes.axes_transform("NED", "ENU", "map_ned", "map")
    B = axes.axes_transform("FLU", "FRD", "base_link", "base_link_frd")
    converted = A @ after_enu @ B
    assert converted.name == "T_map_ned_base_link_frd"
    np.testing.assert_allclose(converted.T, after_ned, atol=1e-12)
    # the physical point 2 m ahead and 1 m to the right of the vehicle, both ways
    p_enu = after_enu.apply([2.0, -1.0, 0.0])
    p_ned = after_ned[:3, :3] @ np.array([2.0, 1.0, 0.0]) + after_ned[:3, 3]
    np.testing.assert_allclose(p_ned, [p_enu[1], p_enu[0], -p_enu[2]], atol=1e-12)


@pytest.mark.parametrize("conv", ["gtsam", "ros"])
def test_covariance_follows_the_change_of_axes(conv: str) -> None:
    """Monte Carlo: perturb in ENU/FLU, change axes sample by sample, measure in NED/FRD."""
    rng = np.random.default_rng(4)
    cv = C.get(conv)
    T = se3.exp(np.array([0.1, -0.2, 0.8, 30.0, -5.0, 2.0]))
    sd = np.array([0.01, 0.02, 0.1, 0.5, 0.05, 0.2])  # yaw and east/forward dominate
    L = rng.normal(size=(6, 6)) * 0.2 + np.eye(6)
    Sigma = np.diag(sd) @ L @ L.T @ np.diag(sd)
    tf = Transform(T, "map", "base_link", Sigma, cv)
    A = axes.axes_transform("NED", "ENU", "map_ned", "map")
    B = axes.axes_transform("FLU", "FRD", "base_link", "base_link_frd")
    out = A @ tf @ B
    assert out.convention == cv
    d = rng.multivariate_normal(np.zeros(6), Sigma, size=40_000)
    samples = A.T @ C.unchecked.retract(cv, T, d) @ B.T
    emp = np.cov(C.unchecked.local(cv, out.T, samples).T)
    assert np.abs(emp - out.cov).max() / np.abs(out.cov).max() < 0.04
    if conv == "ros":  # world-frame position: ENU east variance is NED y (east) variance
        assert out.cov[1, 1] == pytest.approx(Sigma[0, 0], rel=1e-12)
        assert out.cov[2, 2] == pytest.approx(Sigma[2, 2], rel=1e-12)
    else:  # body-frame tangent: FLU y (left) variance is FRD y (right) variance, yaw sign flips
        assert out.cov[4, 4] == pytest.approx(Sigma[4, 4], rel=1e-12)
        assert out.cov[2, 5] == pytest.approx(Sigma[2, 5], rel=1e-12)  # (-1)(-1)
        assert out.cov[0, 1] == pytest.approx(-Sigma[0, 1], rel=1e-12)


def test_optical_frame_projection_convention() -> None:
    """A point 5 m ahead of a FLU body sits on the optical axis (z) of its RDF camera."""
    T_body_optical = axes.axes_transform("FLU", "RDF", "camera_link", "camera_optical")
    p_opt = T_body_optical.inverse().apply([5.0, 0.0, 0.0])
    np.testing.assert_allclose(p_opt, [0.0, 0.0, 5.0], atol=1e-15)
    # a point to the left (+y FLU) is at negative x (left of centre) in the image
    assert T_body_optical.inverse().apply([5.0, 1.0, 0.0])[0] < 0
    # OpenGL camera looks along -z
    T_gl_opt = axes.axes_transform("RUB", "RDF", "gl", "optical")
    assert T_gl_opt.apply([0.0, 0.0, 5.0])[2] == -5.0
    assert so3.log(axes.rotation("RUB", "RDF"))[0] == pytest.approx(np.pi)
