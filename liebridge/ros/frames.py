"""Frame changes of ROS messages: re-parenting by a fixed transform, and the Odometry twist frame.

Re-parenting (what ``tf2::doTransform`` does to a ``PoseWithCovarianceStamped``): a pose
``T_old_child`` becomes ``T_new_child = T_new_old·T_old_child``. Its ROS covariance is over the
position error in the parent frame and the rotation error about the parent's fixed axes, so it
**must rotate** with the parent: ``Σ' = B Σ Bᵀ``, ``B = diag(R_new_old, R_new_old)``. False, and
shipped: "the covariance is unchanged" (ROS 2 ``tf2_geometry_msgs`` copied it unrotated:
ros2/geometry2 issues #372 (C++, fixed by PR #430) and #431 (Python); ROS 1's
``tf2::transformCovariance`` applies ``B``). liebridge gets ``B`` from the conventions, not by hand:
the body-frame (GTSAM, right-perturbation) covariance of ``T_old_child`` does not change when a
fixed transform is applied on the left, so ``Σ' = M(T', gtsam→ros) · M(T, ros→gtsam) Σ (…)ᵀ`` with
:func:`liebridge.conventions.convert_covariance` — the product of the two first-order maps is ``B``
exactly (``[[0, R'], [R', 0]]·[[0, Rᵀ], [Rᵀ, 0]] = diag(R_new_old, R_new_old)``), checked by Monte
Carlo in ``tests/test_ros_frames.py``.

The ``Odometry`` twist is defined in ``child_frame_id`` (``nav_msgs/Odometry.msg``) and does not
change under re-parenting. Drivers that publish it in ``header.frame_id`` instead are found by
:func:`twist_frame_check` and repaired by :func:`twist_from_parent_frame`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions import convert_covariance
from ..frames.transform import frame_name
from ..io.poses import from_matrix
from ..lie import se3
from .messages import RosMessages

__all__ = ["TwistFrameCheck", "transform_messages", "twist_frame_check", "twist_from_parent_frame"]


def transform_messages(msgs: RosMessages, T_new_old: Any, new_frame_id: str) -> RosMessages:
    """Re-parent poses by a fixed transform, the covariance rotated with the frame.

    Parameters
    ----------
    msgs : RosMessages
        Poses ``T_old_child`` (any type with a pose; ``Imu`` is not accepted).
    T_new_old : array_like, shape (4, 4)
        The fixed transform from the old parent frame to ``new_frame_id`` (as in a
        ``TransformStamped`` with ``header.frame_id = new_frame_id``, ``child_frame_id = old``).
    new_frame_id : str

    Returns
    -------
    RosMessages
        ``T = T_new_old·T_old_child`` (quaternions ``w ≥ 0``), the ROS covariance
        ``diag(R, R)·Σ·diag(R, R)ᵀ`` obtained through the conventions (see the module docstring);
        twist (child frame) and everything else unchanged; same ``convention`` as ``msgs``.
    """
    if not isinstance(msgs, RosMessages):
        raise TypeError(f"msgs: expected RosMessages, got {type(msgs).__name__}")
    if msgs.msgtype == "sensor_msgs/msg/Imu":
        raise ValueError("msgs: sensor_msgs/Imu carries no pose to transform")
    frame_name(new_frame_id, "new_frame_id")  # an empty name would be written as it is
    Tf = validate.pose(T_new_old, "T_new_old")
    if Tf.shape != (4, 4):
        raise ValueError(f"T_new_old: expected one pose (4, 4), got {Tf.shape}")
    n = len(msgs)
    T_new = Tf @ msgs.T
    x = from_matrix(T_new, layout="xyz_qxyzw") if n else np.zeros((0, 7))
    kw: dict[str, Any] = {}
    if msgs.pose_covariance is not None and n:
        cov_ros = msgs.pose_covariance.reshape(n, 6, 6)
        msgs.with_convention("gtsam")  # validates every covariance, naming the message
        cov_body = convert_covariance(cov_ros, msgs.T, "ros", "gtsam")
        kw["pose_covariance"] = convert_covariance(cov_body, T_new, "gtsam", "ros").reshape(n, 36)
    return replace(
        msgs,
        position=x[:, :3],
        orientation_xyzw=x[:, 3:],
        frame_id=(str(new_frame_id),) * n,
        **kw,
    )


@dataclass(frozen=True)
class TwistFrameCheck:
    """Which frame an ``Odometry`` twist is in, measured against the poses' own motion.

    Attributes
    ----------
    frame : {"child", "parent", "undetermined"}
        ``"child"``: as ROS defines it; ``"parent"``: the twist is in ``header.frame_id`` (a bug
        to repair with :func:`twist_from_parent_frame`); ``"undetermined"``: the two readings
        agree (the rotation barely changes, or the robot is still) or neither fits.
    rms_child, rms_parent : float
        RMS difference between the finite-difference body twist ``Log(T_k⁻¹T_{k+1})/Δt`` and the
        messages' twist read in the child frame, resp. rotated from the parent frame (units:
        rad/s and m/s mixed, as ``(ω, v)``).
    scale : float
        RMS of the finite-difference twist (what the residuals compare with).
    """

    frame: Literal["child", "parent", "undetermined"]
    rms_child: float
    rms_parent: float
    scale: float


def _rotate_twist(R: FloatArray, tw: FloatArray, cov: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``(v, ω)`` and its covariance expressed in another frame: ``B = diag(R, R)``."""
    B = np.zeros((*R.shape[:-2], 6, 6))
    B[..., :3, :3] = R
    B[..., 3:, 3:] = R
    tw2 = np.einsum("...ij,...j->...i", B, tw)
    cov2 = B @ cov @ np.swapaxes(B, -1, -2)
    return tw2, cov2


def twist_frame_check(msgs: RosMessages, *, ratio: float = 3.0) -> TwistFrameCheck:
    """Measure whether an ``Odometry`` topic's twist is in the child frame or the parent frame.

    The finite-difference body twist ``ξ_k = Log(T_k⁻¹·T_{k+1}) / Δt`` (GTSAM's ``(ω, v)``,
    exact for a constant body twist) is compared with the mean of the two messages' twists read
    as ROS says (child frame) and read as if they were in the parent frame (rotated by ``Rᵀ``).

    Parameters
    ----------
    msgs : RosMessages
        ``nav_msgs/Odometry``, at least two messages with increasing stamps.
    ratio : float
        How much smaller one residual must be than the other to decide.

    Returns
    -------
    TwistFrameCheck
    """
    if isinstance(ratio, bool) or not isinstance(ratio, int | float | np.integer | np.floating):
        raise TypeError(f"ratio: expected a number ≥ 1, got {type(ratio).__name__}")
    if not (np.isfinite(ratio) and ratio >= 1.0):  # NaN decided nothing and said so nowhere
        raise ValueError(f"ratio: expected a finite number ≥ 1, got {ratio!r}")
    if msgs.msgtype != "nav_msgs/msg/Odometry" or msgs.twist_linear_angular is None:
        raise ValueError(f"msgs: expected nav_msgs/Odometry, got {msgs.msgtype}")
    if len(msgs) < 2:
        raise ValueError("msgs: need at least two messages to measure the motion")
    dt = np.diff(msgs.stamps)
    if not (dt > 0).all():
        k = int(np.argmax(~(dt > 0)))
        raise ValueError(f"{msgs._where(k + 1)}: stamps do not increase")
    T = msgs.T
    xi = se3.log(se3.inverse(T[:-1]) @ T[1:]) / dt[:, None]  # (ω, v), body
    raw = msgs.twist_linear_angular  # (v, ω)
    zero = np.zeros((len(msgs), 6, 6))
    child = np.concatenate([raw[:, 3:], raw[:, :3]], axis=-1)
    par, _ = _rotate_twist(np.swapaxes(T[:, :3, :3], -1, -2), raw, zero)
    parent = np.concatenate([par[:, 3:], par[:, :3]], axis=-1)

    def rms(a: FloatArray) -> float:
        return float(np.sqrt(np.mean(np.sum(a**2, axis=-1))))

    r_child = rms(0.5 * (child[:-1] + child[1:]) - xi)
    r_parent = rms(0.5 * (parent[:-1] + parent[1:]) - xi)
    scale = rms(xi)
    frame: Literal["child", "parent", "undetermined"] = "undetermined"
    if r_child * ratio < r_parent:
        frame = "child"
    elif r_parent * ratio < r_child:
        frame = "parent"
    return TwistFrameCheck(frame, r_child, r_parent, scale)


def twist_from_parent_frame(msgs: RosMessages) -> RosMessages:
    """Repair ``Odometry`` whose twist was published in ``header.frame_id`` (not the child).

    The linear and angular velocity are rotated into the child frame, ``v_child = Rᵀ v_parent``,
    ``ω_child = Rᵀ ω_parent``, and the twist covariance with them, ``Σ' = B Σ Bᵀ``,
    ``B = diag(Rᵀ, Rᵀ)`` (a velocity changes frame by rotation; no tangent convention enters).
    Use it only after :func:`twist_frame_check` reported ``"parent"``.
    """
    if msgs.msgtype != "nav_msgs/msg/Odometry" or msgs.twist_linear_angular is None:
        raise ValueError(f"msgs: expected nav_msgs/Odometry, got {msgs.msgtype}")
    assert msgs.twist_covariance is not None
    n = len(msgs)
    Rt = np.swapaxes(msgs.T[:, :3, :3], -1, -2)
    tw, cov = _rotate_twist(Rt, msgs.twist_linear_angular, msgs.twist_covariance.reshape(n, 6, 6))
    return replace(msgs, twist_linear_angular=tw, twist_covariance=cov.reshape(n, 36))
