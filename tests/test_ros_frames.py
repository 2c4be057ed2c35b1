"""liebridge.ros frames: the Odometry twist frame, and TF re-parenting rotates the covariance."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rosbags")

from liebridge import ros
from liebridge.lie import se3, so3

XI_BODY = np.array([0.3, -0.2, 0.5, 1.5, 0.2, -0.1])  # GTSAM (ω, v): a constant body twist


def _trajectory(n: int = 60, dt: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    T0 = se3.exp(np.array([0.4, -1.0, 0.7, 3.0, -2.0, 1.0]))
    t = np.arange(n) * dt
    return t, T0 @ se3.exp(t[:, None] * XI_BODY)


@pytest.mark.parametrize("storage", ["rosbag1", "mcap"])
def test_twist_frame_correct_and_world_frame(tmp_path: Path, storage: str) -> None:
    t, T = _trajectory()
    v_b, w_b = XI_BODY[3:], XI_BODY[:3]
    body = np.tile(np.r_[v_b, w_b], (len(t), 1))  # ROS (linear, angular), child frame: correct
    R = T[:, :3, :3]
    world = np.concatenate([R @ v_b, R @ w_b], axis=-1)  # a driver's world-frame twist: wrong
    name = "o.bag" if storage == "rosbag1" else "o"
    for label, tw in (("correct", body), ("world", world)):
        m = ros.from_poses(
            T,
            np.tile(np.eye(6) * 1e-4, (len(t), 1, 1)),
            stamps=t + 100.0,
            msgtype="nav_msgs/Odometry",
            frame_id="odom",
            child_frame_id="base_link",
            twist=tw,
            twist_cov=np.tile(np.diag([1e-2, 2e-2, 3e-2, 1e-3, 2e-3, 3e-3]), (len(t), 1, 1)),
        )
        p = ros.write_messages(tmp_path / f"{label}_{name}", "/odom", m, storage=storage)
        got = ros.read_messages(p, "/odom", convention="gtsam")
        chk = ros.twist_frame_check(got)
        if label == "correct":
            # liebridge's twist is the body twist (GTSAM order), equal to the motion of the poses
            assert got.twist is not None
            np.testing.assert_allclose(got.twist, np.tile(XI_BODY, (len(t), 1)), atol=1e-12)
            fd = se3.log(se3.inverse(got.T[:-1]) @ got.T[1:]) / np.diff(got.stamps)[:, None]
            np.testing.assert_allclose(fd, got.twist[:-1], atol=1e-6)
            assert chk.frame == "child" and chk.rms_child < 1e-6 < chk.rms_parent
        else:
            assert chk.frame == "parent" and chk.rms_parent < 1e-6 < chk.rms_child
            fixed = ros.twist_from_parent_frame(got)
            assert fixed.twist is not None and fixed.twist_cov is not None
            np.testing.assert_allclose(fixed.twist, np.tile(XI_BODY, (len(t), 1)), atol=1e-12)
            assert ros.twist_frame_check(fixed).frame == "child"
            # the twist covariance rotated with it: B Σ Bᵀ with B = diag(Rᵀ, Rᵀ) (ROS order)
            assert got.twist_cov is not None
            k = 17
            Rt = R[k].T
            B = np.zeros((6, 6))
            B[:3, :3] = B[3:, 3:] = Rt
            assert m.twist_covariance is not None
            cov_in = m.twist_covariance[k].reshape(6, 6)
            assert fixed.twist_covariance is not None
            np.testing.assert_allclose(
                fixed.twist_covariance[k].reshape(6, 6), B @ cov_in @ B.T, atol=1e-15
            )


def test_twist_frame_undetermined_without_rotation() -> None:
    t = np.arange(10) * 0.1
    T = se3.exp(t[:, None] * np.array([0, 0, 0, 1.0, 0, 0]))
    m = ros.from_poses(
        T, None, stamps=t, msgtype="nav_msgs/Odometry", twist=np.tile([1.0, 0, 0, 0, 0, 0], (10, 1))
    )
    assert ros.twist_frame_check(m).frame == "undetermined"


def test_tf_rotates_pose_covariance_monte_carlo(tmp_path: Path) -> None:
    """PoseWithCovarianceStamped in `odom`, moved to `map` by a fixed TF (rotation 1.2 rad)."""
    rng = np.random.default_rng(11)
    T_odom_base = se3.exp(np.array([0.3, 0.5, -0.2, 4.0, 1.0, 0.5]))
    A = rng.normal(size=(6, 6))
    cov = (A @ A.T + np.eye(6)) * 1e-3  # ROS: (x, y, z, rotX, rotY, rotZ)
    cov[:3, :3] += np.diag([0.04, 0.01, 0.0025])  # anisotropic in position: rotation shows
    m = ros.from_poses(T_odom_base[None], cov[None], stamps=[1.0], frame_id="odom")
    p = ros.write_messages(tmp_path / "p.mcap", "/pose", m)
    m = ros.read_messages(p, "/pose")
    T_map_odom = se3.exp(np.array([0.0, 0.0, 1.2, 10.0, -5.0, 0.0]))
    out = ros.transform_messages(m, T_map_odom, "map")
    assert out.frame_id == ("map",)
    np.testing.assert_allclose(out.T[0], T_map_odom @ T_odom_base, atol=1e-12)

    # Monte Carlo: perturb the odom-frame pose as ROS defines it, map it through the TF, and
    # measure the ROS covariance of the result about its mean in the map frame
    n = 200_000
    d = rng.multivariate_normal(np.zeros(6), cov, size=n)
    Ts = np.broadcast_to(T_odom_base, (n, 4, 4)).copy()
    Ts[:, :3, 3] += d[:, :3]
    Ts[:, :3, :3] = so3.exp(d[:, 3:]) @ T_odom_base[:3, :3]
    Tm = T_map_odom @ Ts
    T_ref = out.T[0]
    u = Tm[:, :3, 3] - T_ref[:3, 3]
    w = so3.log(Tm[:, :3, :3] @ T_ref[:3, :3].T)
    emp = np.cov(np.c_[u, w].T)
    assert out.cov is not None
    got = out.cov[0]
    err_rotated = np.abs(emp - got).max()
    err_copied = np.abs(emp - cov).max()
    tol = 4 * np.sqrt(2 / n) * np.abs(cov).max() * 3  # a few sampling standard errors
    assert err_rotated < tol, (err_rotated, tol)
    assert err_copied > 10 * tol  # copying it unrotated (the tf2 bug) is measurably wrong
    # and it is B Σ Bᵀ with B = diag(R, R)
    R = T_map_odom[:3, :3]
    B = np.zeros((6, 6))
    B[:3, :3] = B[3:, 3:] = R
    np.testing.assert_allclose(got, B @ cov @ B.T, atol=1e-15)
