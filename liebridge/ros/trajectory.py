"""One topic of a bag as a :class:`liebridge.io.Trajectory`, the result type of every reader.

:func:`read_trajectory` is the bag reader among the trajectory readers (TUM, KITTI, EuRoC in
:mod:`liebridge.io`): the same ``stamps``/``T``/``cov``/``frame_id``/``child_frame_id``/``source``
record, here with the messages' covariances in a named convention. :func:`to_trajectory` turns a
:class:`~liebridge.ros.RosMessages` batch already read into one.
"""

from __future__ import annotations

import os

import numpy as np

from ..conventions import ConventionLike
from ..io.trajectory import Trajectory
from .bag import Progress, read_messages
from .messages import RosMessages

__all__ = ["read_trajectory", "to_trajectory"]

PathLike = str | os.PathLike[str]


def to_trajectory(msgs: RosMessages, source: str | None = None) -> Trajectory:
    """Return the poses of ``msgs`` as a :class:`~liebridge.io.Trajectory`.

    Parameters
    ----------
    msgs : RosMessages
        One topic; every row must name the same parent frame (and child frame, where the type has
        one): a topic whose ``frame_id`` changes (map/odom) is two trajectories, refused here.
    source : str, optional
        Default ``msgs.topic``.

    Returns
    -------
    Trajectory
        ``stamps`` seconds (``sec + 1e-9·nanosec``), ``T`` ``T_{frame_id}_{child_frame_id}``,
        ``cov`` in ``msgs.convention`` (None for types without a pose covariance),
        ``convention`` its name.
    """
    if not isinstance(msgs, RosMessages):
        raise TypeError(f"msgs: expected RosMessages, got {type(msgs).__name__}")
    frames = sorted(set(msgs.frame_id))
    if len(frames) > 1:
        first = next(i for i, f in enumerate(msgs.frame_id) if f != msgs.frame_id[0])
        raise ValueError(
            f"msgs: frame_id changes within topic {msgs.topic!r} ({', '.join(map(repr, frames))}; "
            f"first at batch index ({first},)): not one trajectory"
        )
    children = sorted(set(msgs.child_frame_id)) if msgs.child_frame_id else []
    if len(children) > 1:
        raise ValueError(
            f"msgs: child_frame_id changes within topic {msgs.topic!r} "
            f"({', '.join(map(repr, children))}): not one trajectory"
        )
    cov = None if msgs.cov is None else np.array(msgs.cov, dtype=np.float64)
    return Trajectory(
        np.array(msgs.stamps, dtype=np.float64),
        np.array(msgs.T, dtype=np.float64),
        cov,
        frame_id=(frames[0] if frames else "") or "world",
        child_frame_id=(children[0] if children else "") or "body",
        source=msgs.topic if source is None else source,
        convention=None if cov is None else msgs.convention.name,
    )


def read_trajectory(
    bag: PathLike,
    topic: str,
    *,
    convention: ConventionLike = "ros",
    progress: Progress | None = None,
    path_message: int | None = None,
) -> Trajectory:
    """Read one topic of ``bag`` as a :class:`~liebridge.io.Trajectory` (``source`` ``BAG:TOPIC``).

    Parameters and errors as :func:`liebridge.ros.read_messages` (``convention`` is the one of
    the returned ``cov``; ``path_message`` picks the message of a ``nav_msgs/Path`` topic,
    default the last) and :func:`to_trajectory`.
    """
    msgs = read_messages(
        bag, topic, convention=convention, progress=progress, path_message=path_message
    )
    return to_trajectory(msgs, source=f"{os.fspath(bag)}:{topic}")
