"""Bag trajectories into GTSAM, GTSAM estimates and marginals back into ROS messages.

Into GTSAM (:func:`odometry_factors`): consecutive poses of a trajectory topic become
``BetweenFactorPose3`` with ``Z = T_k⁻¹·T_{k+1}``. The increment's covariance is never the
message's covariance copied: the messages' ROS covariances (parent-frame position, fixed-axis
rotation) are first converted to GTSAM's body-frame tangent at each pose with
:func:`liebridge.conventions.convert_covariance`, then

* ``increment="difference"`` (dead-reckoning odometry whose covariance grows, e.g. wheel or VIO
  odometry integrating its own increments): with independent increments,
  ``Σ_{k+1} = Ad(Z⁻¹) Σ_k Ad(Z⁻¹)ᵀ + Σ_Z`` in GTSAM's tangent (``T_{k+1}·Exp(ξ_{k+1}) =
  T_k·Exp(ξ_k)·Z·Exp(ξ_Z)`` to first order), so ``Σ_Z = Σ_{k+1} − Ad(Z⁻¹) Σ_k Ad(Z⁻¹)ᵀ``,
  required positive semi-definite (else the error names the message);
* ``increment="twist"`` (``Odometry`` only): the child-frame twist is GTSAM's body twist, so
  ``Σ_Z = Δt² · Σ_twist`` reordered to ``(ω, v)`` (a first-order model of the increment);
* ``increment="independent"`` (absolute estimates, e.g. nav2/amcl's ``/amcl_pose``
  ``PoseWithCovarianceStamped`` or a GNSS fix, whose covariance does not grow): the assumption
  is that the **absolute** errors ``ξ_k`` of consecutive poses are independent; to first order
  ``ξ_Z = ξ_{k+1} − Ad(Z⁻¹) ξ_k``, so ``Σ_Z = Σ_{k+1} + Ad(Z⁻¹) Σ_k Ad(Z⁻¹)ᵀ`` in GTSAM's
  tangent. Consecutive estimates of a filter are in truth correlated (positively, mostly), so
  this over-states the increment's uncertainty: a conservative edge, never an over-confident
  one.

A planar covariance (zero in z, roll and pitch, as amcl publishes) gives a rank-3 ``Σ_Z``: its
information is singular, and :func:`increment_information` returns the pseudo-inverse with the
rank — zero information in the directions the messages do not constrain.

Out of GTSAM (:func:`messages_from_gtsam`): poses from ``gtsam.Values`` and marginals from
:func:`liebridge.gtsam.marginals` converted to ``ros`` — the message covariance rviz,
robot_localization and evo read as ROS defines it.

Navigation state as ``Odometry`` (:func:`odometry_from_navstate`, :func:`odometry_from_gtsam`):
pose covariance converted to ROS; twist in the child frame — linear velocity ``Rᵀ v_world`` from
the state, angular velocity from the bias-corrected gyro with its covariance; the pose–twist
cross-covariance, which ``Odometry`` cannot hold, is returned as dropped (with its largest
correlation coefficient).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from .. import _validate as validate
from .._validate import SINGULAR_ATOL, FloatArray
from ..conventions import convert_covariance, tangent_map
from ..gtsam import between, from_values, marginals, prior
from ..lie import se3, so3
from .messages import RosMessages, from_poses

__all__ = [
    "INCREMENTS",
    "DroppedCrossCovariance",
    "increment_covariances",
    "increment_information",
    "messages_from_gtsam",
    "odometry_factors",
    "odometry_from_gtsam",
    "odometry_from_navstate",
]


def _swap(cov: FloatArray) -> FloatArray:
    p = np.r_[3:6, 0:3]
    return np.asarray(cov[..., p, :][..., :, p], dtype=np.float64)


Increment = Literal["difference", "twist", "independent"]
INCREMENTS: tuple[str, ...] = ("difference", "twist", "independent")

#: Eigenvalues of an increment covariance below ``RANK_RTOL · λ_max`` count as zero in
#: :func:`increment_information` (directions the messages do not constrain).
RANK_RTOL = 1e-12


def increment_covariances(
    msgs: RosMessages, increment: Increment = "difference"
) -> tuple[FloatArray, FloatArray]:
    """Relative poses ``Z_k = T_k⁻¹T_{k+1}`` and their covariances in GTSAM's tangent.

    Parameters
    ----------
    msgs : RosMessages
        One trajectory (one pair of frames), at least two poses.
    increment : {"difference", "twist", "independent"}
        How the increment covariance follows from the messages (module docstring): growing
        dead-reckoning covariances, the ``Odometry`` twist covariance × Δt², or independent
        absolute covariances propagated to first order.

    Returns
    -------
    Z : ndarray, shape (N-1, 4, 4)
    cov_Z : ndarray, shape (N-1, 6, 6)
        Over ``(ω, v)`` of ``Z·Exp(ξ)`` (GTSAM's right perturbation); possibly singular (a
        planar or all-zero message covariance): see :func:`increment_information`.
    """
    if increment not in INCREMENTS:
        raise ValueError(
            f"increment: expected one of {', '.join(map(repr, INCREMENTS))}, got {increment!r}"
        )
    if msgs.cov is None and increment != "twist":
        raise ValueError(
            f"msgs: {msgs.msgtype} carries no pose covariance (topic {msgs.topic or '?'}); "
            "an odometry chain needs PoseWithCovariance(Stamped) or Odometry messages"
        )
    msgs.trajectory_frames()  # a chain of one trajectory: one pair of frames
    n = len(msgs)
    if n < 2:
        raise ValueError("msgs: need at least two poses for an odometry chain")
    T = msgs.T
    Z = se3.inverse(T[:-1]) @ T[1:]
    if increment == "independent":
        cov = msgs.with_convention("gtsam").cov
        assert cov is not None
        A = se3.adjoint(se3.inverse(Z))
        cz = cov[1:] + A @ cov[:-1] @ np.swapaxes(A, -1, -2)
        return Z, 0.5 * (cz + np.swapaxes(cz, -1, -2))
    if increment == "difference":
        cov = msgs.with_convention("gtsam").cov
        assert cov is not None
        A = se3.adjoint(se3.inverse(Z))
        cz = cov[1:] - A @ cov[:-1] @ np.swapaxes(A, -1, -2)
        cz = 0.5 * (cz + np.swapaxes(cz, -1, -2))
        scale = np.maximum(np.abs(cov[1:]).max(axis=(-1, -2)), 1e-300)
        lam = np.linalg.eigvalsh(cz)[:, 0]
        bad = lam < -1e-9 * scale
        if bad.any():
            k = int(np.argmax(bad))
            raise ValueError(
                f"{msgs._where(k + 1)}: pose covariance does not grow from message "
                f"{int(msgs.message_index[k]) if msgs.message_index is not None else k} as "
                f"independent odometry increments would (increment covariance has eigenvalue "
                f"{lam[k]:.3g}); absolute estimates (e.g. amcl) need increment 'independent', "
                "Odometry may use increment 'twist'"
            )
        return Z, cz
    if msgs.twist_covariance is None:
        raise ValueError(
            f"msgs: increment 'twist' needs nav_msgs/Odometry, got {msgs.msgtype} "
            "(absolute poses with covariances: increment 'independent')"
        )
    dt = np.diff(msgs.stamps)
    if not (dt > 0).all():
        k = int(np.argmax(~(dt > 0)))
        raise ValueError(f"{msgs._where(k + 1)}: stamps do not increase")
    tc = _swap(msgs.twist_covariance.reshape(n, 6, 6))  # (v, ω) → (ω, v), child = body frame
    cz = (dt**2)[:, None, None] * 0.5 * (tc[:-1] + tc[1:])
    return Z, cz


def increment_information(
    cov: FloatArray, rtol: float = RANK_RTOL
) -> tuple[FloatArray, npt.NDArray[np.int64]]:
    """Information matrices of increment covariances: the (pseudo-)inverse, with its rank.

    Parameters
    ----------
    cov : array_like, shape (M, 6, 6)
        Symmetric PSD covariances, e.g. :func:`increment_covariances`' (any tangent: the
        information is over the same one).
    rtol : float
        Eigenvalues ``λ ≤ rtol · λ_max`` (or ``λ_max`` itself below
        :data:`liebridge._validate.SINGULAR_ATOL`) count as zero.

    Returns
    -------
    information : ndarray, shape (M, 6, 6)
        ``Σ⁻¹`` where ``Σ`` has full rank; else the Moore–Penrose pseudo-inverse
        ``V diag(1/λ_i) Vᵀ`` over the non-zero eigenvalues — zero information along the
        directions the covariance has no variance in (a planar ``/amcl_pose`` covariance: z,
        roll, pitch), which a least-squares edge then leaves unconstrained. The tempting false
        reading, "zero variance = exactly known = infinite information", is not what ROS
        publishers mean by a zero block; it is why the pseudo-inverse is right here.
    rank : ndarray of int, shape (M,)
        Number of non-zero eigenvalues (6: full rank; 0: an all-zero covariance, whose
        information is all zero).
    """
    c = validate.covariance(cov, "cov", 6)
    c = 0.5 * (c + np.swapaxes(c, -1, -2))
    lam, V = np.linalg.eigh(c)
    top = lam[..., -1:]
    keep = (lam > rtol * top) & (top >= SINGULAR_ATOL)
    inv = np.where(keep, 1.0 / np.where(keep, lam, 1.0), 0.0)
    info = (V * inv[..., None, :]) @ np.swapaxes(V, -1, -2)
    info = 0.5 * (info + np.swapaxes(info, -1, -2))
    return info, keep.sum(axis=-1).astype(np.int64)


def odometry_factors(
    msgs: RosMessages,
    keys: Sequence[int] | None = None,
    *,
    increment: Increment = "difference",
    prior_on_first: bool = True,
    native: bool = True,
) -> list[Any]:
    """GTSAM factors for a trajectory topic: a prior on the first pose and between factors.

    Parameters
    ----------
    msgs : RosMessages
        ``PoseWithCovariance(Stamped)`` or ``Odometry`` (one pose per message).
    keys : sequence of int, optional
        GTSAM keys of the poses (default ``0..N-1``).
    increment : {"difference", "twist", "independent"}
        How the increment covariance is obtained (module docstring).
    prior_on_first : bool
        Add ``PriorFactorPose3`` at the first pose with its own covariance (converted to GTSAM's
        tangent; the ``ros`` → ``gtsam`` change of chart is first order).
    native : bool
        See :func:`liebridge.gtsam.between`.

    Returns
    -------
    list of gtsam factors
        Add them to a ``gtsam.NonlinearFactorGraph``; initial values: ``msgs.T``.
    """
    n = len(msgs)
    ks = list(range(n)) if keys is None else [int(k) for k in keys]
    if len(ks) != n:
        raise ValueError(f"keys: expected {n} keys, got {len(ks)}")
    Z, cz = increment_covariances(msgs, increment)
    out: list[Any] = []
    if prior_on_first:
        c0 = msgs.with_convention("gtsam").cov
        if c0 is None:
            raise ValueError(f"msgs: {msgs.msgtype} carries no pose covariance for the prior")
        out.append(prior(ks[0], msgs.T[0], c0[0], "gtsam", native=native))
    for k in range(n - 1):
        out.append(between(ks[k], ks[k + 1], Z[k], cz[k], "gtsam", native=native))
    return out


def messages_from_gtsam(
    graph: Any,
    values: Any,
    keys: Sequence[int],
    *,
    stamps: Any,
    frame_id: str = "map",
    msgtype: str = "geometry_msgs/msg/PoseWithCovarianceStamped",
    child_frame_id: str | None = None,
    marginals_object: Any = None,
) -> RosMessages:
    """GTSAM ``Pose3`` estimates and their marginal covariances as ROS messages.

    Parameters
    ----------
    graph : gtsam.NonlinearFactorGraph
    values : gtsam.Values
        The estimate (``T_world_body`` per key, ``world`` = ``frame_id``).
    keys : sequence of int
    stamps : array_like, shape (len(keys),)
        Seconds.
    frame_id, msgtype, child_frame_id :
        As in :func:`liebridge.ros.from_poses` (``Odometry`` gets a zero twist).
    marginals_object : gtsam.Marginals, optional

    Returns
    -------
    RosMessages
        Covariance: ``gtsam.Marginals.marginalCovariance`` (GTSAM's ``(ω, v)`` at the estimate)
        converted with :func:`liebridge.gtsam.marginals` to ``ros``; ``convention = ros``.
    """
    ks = [int(k) for k in keys]
    T = from_values(values, ks)
    cov = marginals(graph, values, ks, "ros", marginals_object=marginals_object)
    t = validate.as_float_array(stamps, "stamps")
    return from_poses(
        T,
        cov,
        convention="ros",
        stamps=t,
        frame_id=frame_id,
        msgtype=msgtype,
        child_frame_id=child_frame_id,
    )


@dataclass(frozen=True)
class DroppedCrossCovariance:
    """What an ``Odometry`` message cannot hold: the pose–twist cross-covariance.

    Attributes
    ----------
    cov_pose_twist : ndarray, shape (N, 6, 6)
        Cross-covariance between the pose error in the ROS pose tangent
        ``(x, y, z, rotX, rotY, rotZ)`` and the twist error in ROS twist order
        ``(vx, vy, vz, wx, wy, wz)`` (child frame); its angular columns are zero (the gyro's
        correlation with the state is not modelled).
    max_abs_correlation : ndarray, shape (N,)
        Largest ``|ρ|`` among those entries per message (0: nothing of substance was dropped).
    """

    cov_pose_twist: FloatArray
    max_abs_correlation: FloatArray


def odometry_from_navstate(
    T: Any,
    v_world: Any,
    cov_joint: Any,
    omega_body: Any,
    omega_cov: Any,
    *,
    stamps: Any,
    frame_id: str = "map",
    child_frame_id: str = "base_link",
) -> tuple[RosMessages, DroppedCrossCovariance]:
    """Express a navigation-state estimate as ``nav_msgs/Odometry``; report what it drops.

    Parameters
    ----------
    T : array_like, shape (N, 4, 4)
        ``T_world_body`` estimates (GTSAM ``Pose3``).
    v_world : array_like, shape (N, 3)
        Velocity of the body origin in the world frame (GTSAM's ``NavState`` / ``Vector3``
        velocity).
    cov_joint : array_like, shape (N, 9, 9)
        Joint marginal over ``(δθ, δp, δv)``: GTSAM's ``Pose3`` tangent ``(ω, v)`` (body frame,
        ``T·Exp(ξ)``) then the additive world-frame velocity error — e.g.
        ``gtsam.Marginals.jointMarginalCovariance([x_k, v_k]).fullMatrix()``.
    omega_body : array_like, shape (N, 3)
        Angular velocity in the body frame (the bias-corrected gyro, ``ω_meas − b_g``).
    omega_cov : array_like, shape (N, 3, 3)
        Its covariance (gyro noise plus the bias marginal).
    stamps, frame_id, child_frame_id :
        As in :func:`liebridge.ros.from_poses`.

    Returns
    -------
    msgs : RosMessages
        ``Odometry``: pose covariance = the pose block converted to ROS with
        :func:`liebridge.conventions.convert_covariance`; twist = ``(Rᵀ v_world, ω_body)`` in
        the child frame with covariance ``[[J Σ Jᵀ, 0], [0, omega_cov]]``,
        ``J = [[v_b]×, 0, Rᵀ]`` (from ``Exp(δθ)ᵀRᵀ(v + δv) ≈ v_b + [v_b]× δθ + Rᵀ δv``).
    dropped : DroppedCrossCovariance
        The pose–twist cross-covariance the message cannot carry.
    """
    Tm = validate.pose(T, "T")
    if Tm.ndim != 3:
        raise ValueError(f"T: expected shape (N, 4, 4), got {Tm.shape}")
    n = Tm.shape[0]
    vw = validate.vector(v_world, "v_world", 3)
    S = validate.covariance(cov_joint, "cov_joint", 9)
    om = validate.vector(omega_body, "omega_body", 3)
    oc = validate.covariance(omega_cov, "omega_cov", 3)
    for name, a, shape in (
        ("v_world", vw, (n, 3)),
        ("cov_joint", S, (n, 9, 9)),
        ("omega_body", om, (n, 3)),
        ("omega_cov", oc, (n, 3, 3)),
    ):
        if a.shape != shape:
            raise ValueError(f"{name}: expected shape {shape}, got {a.shape}")
    Rt = np.swapaxes(Tm[:, :3, :3], -1, -2)
    vb = np.einsum("nij,nj->ni", Rt, vw)
    J = np.zeros((n, 3, 9))
    J[:, :, :3] = so3.hat(vb)
    J[:, :, 6:] = Rt
    cov_vb = J @ S @ np.swapaxes(J, -1, -2)
    pose_cov = convert_covariance(S[:, :6, :6], Tm, "gtsam", "ros")
    twist_cov = np.zeros((n, 6, 6))
    twist_cov[:, :3, :3] = cov_vb
    twist_cov[:, 3:, 3:] = oc
    msgs = from_poses(
        Tm,
        pose_cov,
        convention="ros",
        stamps=stamps,
        frame_id=frame_id,
        child_frame_id=child_frame_id,
        msgtype="nav_msgs/msg/Odometry",
        twist=np.concatenate([vb, om], axis=-1),
        twist_cov=twist_cov,
    )
    # cross-covariance, pose in the ROS tangent: the same first-order map as the pose block
    M = tangent_map(Tm, "gtsam", "ros")
    cross = np.zeros((n, 6, 6))
    cross[:, :, :3] = M @ S[:, :6, :] @ np.swapaxes(J, -1, -2)
    sd_pose = np.sqrt(np.maximum(np.einsum("nii->ni", pose_cov), 0.0))
    sd_tw = np.sqrt(np.maximum(np.einsum("nii->ni", twist_cov), 0.0))
    denom = sd_pose[:, :, None] * sd_tw[:, None, :]
    rho = np.divide(np.abs(cross), denom, out=np.zeros_like(cross), where=denom > 0)
    return msgs, DroppedCrossCovariance(cross, rho.max(axis=(-1, -2)))


def odometry_from_gtsam(
    graph: Any,
    values: Any,
    pose_keys: Sequence[int],
    velocity_keys: Sequence[int],
    omega_body: Any,
    omega_cov: Any,
    *,
    stamps: Any,
    frame_id: str = "map",
    child_frame_id: str = "base_link",
    marginals_object: Any = None,
) -> tuple[RosMessages, DroppedCrossCovariance]:
    """:func:`odometry_from_navstate` from a GTSAM graph with ``Pose3`` and ``Vector3`` keys.

    The joint marginal of each ``(pose_keys[k], velocity_keys[k])`` pair comes from
    ``gtsam.Marginals.jointMarginalCovariance`` (GTSAM's ``Pose3`` tangent, then the velocity).
    """
    import gtsam

    pk = [int(k) for k in pose_keys]
    vk = [int(k) for k in velocity_keys]
    if len(pk) != len(vk):
        raise ValueError(f"velocity_keys: expected {len(pk)} keys, got {len(vk)}")
    m = marginals_object if marginals_object is not None else gtsam.Marginals(graph, values)
    S = np.stack(
        [
            np.asarray(m.jointMarginalCovariance([a, b]).fullMatrix())
            for a, b in zip(pk, vk, strict=True)
        ]
    )
    S = 0.5 * (S + np.swapaxes(S, -1, -2))
    T = from_values(values, pk)
    vw = np.stack([np.asarray(values.atVector(b), dtype=np.float64) for b in vk])
    return odometry_from_navstate(
        T,
        vw,
        S,
        omega_body,
        omega_cov,
        stamps=stamps,
        frame_id=frame_id,
        child_frame_id=child_frame_id,
    )
