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
  ``Σ_Z = Δt² · Σ_twist`` reordered to ``(ω, v)`` (a first-order model of the increment).

Out of GTSAM (:func:`messages_from_gtsam`): poses from ``gtsam.Values`` and marginals from
:func:`liebridge.gtsam.marginals` converted to ``ros`` — the message covariance rviz,
robot_localization and evo read as ROS defines it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Literal

import numpy as np

from .. import _validate as v
from .._validate import FloatArray
from ..gtsam import between, from_values, marginals, prior
from ..lie import se3
from .messages import RosMessages, from_poses

__all__ = ["increment_covariances", "messages_from_gtsam", "odometry_factors"]


def _swap(cov: FloatArray) -> FloatArray:
    p = np.r_[3:6, 0:3]
    return np.asarray(cov[..., p, :][..., :, p], dtype=np.float64)


def increment_covariances(
    msgs: RosMessages, increment: Literal["difference", "twist"] = "difference"
) -> tuple[FloatArray, FloatArray]:
    """Relative poses ``Z_k = T_k⁻¹T_{k+1}`` and their covariances in GTSAM's tangent.

    Returns
    -------
    Z : ndarray, shape (N-1, 4, 4)
    cov_Z : ndarray, shape (N-1, 6, 6)
        Over ``(ω, v)`` of ``Z·Exp(ξ)``; see the module docstring for ``increment``.
    """
    if msgs.cov is None and increment == "difference":
        raise ValueError(f"msgs: {msgs.msgtype} carries no pose covariance")
    n = len(msgs)
    if n < 2:
        raise ValueError("msgs: need at least two poses for an odometry chain")
    T = msgs.T
    Z = se3.inverse(T[:-1]) @ T[1:]
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
                f"{lam[k]:.3g}); use increment='twist' or give the covariances yourself"
            )
        return Z, cz
    if increment != "twist":
        raise ValueError(f"increment: expected 'difference' or 'twist', got {increment!r}")
    if msgs.twist_covariance is None:
        raise ValueError(f"msgs: increment='twist' needs nav_msgs/Odometry, got {msgs.msgtype}")
    dt = np.diff(msgs.stamps)
    if not (dt > 0).all():
        k = int(np.argmax(~(dt > 0)))
        raise ValueError(f"{msgs._where(k + 1)}: stamps do not increase")
    tc = _swap(msgs.twist_covariance.reshape(n, 6, 6))  # (v, ω) → (ω, v), child = body frame
    cz = (dt**2)[:, None, None] * 0.5 * (tc[:-1] + tc[1:])
    return Z, cz


def odometry_factors(
    msgs: RosMessages,
    keys: Sequence[int] | None = None,
    *,
    increment: Literal["difference", "twist"] = "difference",
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
    increment : {"difference", "twist"}
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
    t = v.as_float_array(stamps, "stamps")
    return from_poses(
        T,
        cov,
        convention="ros",
        stamps=t,
        frame_id=frame_id,
        msgtype=msgtype,
        child_frame_id=child_frame_id,
    )
