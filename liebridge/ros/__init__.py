"""ROS 1 / ROS 2 messages and bags without a ROS install, conventions explicit at the boundary.

Layer above :mod:`liebridge.gtsam` and :mod:`liebridge.imu`, below the command line. Needs the
optional extra ``ros`` (the pure-Python ``rosbags`` library): ``pip install ".[ros]"`` from the
checkout; it is imported when a bag is opened, with that hint if missing.

* :func:`read_messages` / :func:`write_messages`: one topic of a bag ↔ :class:`RosMessages`
  (raw fields bit for bit, plus ``T``, ``cov`` in any convention, ``twist`` in the child frame);
* :func:`from_poses`: messages from poses and covariances in any convention;
* :func:`transform_messages`: re-parent poses by a fixed transform, the covariance rotated;
* :func:`twist_frame_check`: whether an ``Odometry`` twist is in the child frame (as ROS says)
  or in the parent frame (a common driver bug);
* :func:`odometry_factors`, :func:`messages_from_gtsam`: bag trajectories into GTSAM and GTSAM
  estimates with marginals back into messages; :func:`odometry_from_gtsam` /
  :func:`odometry_from_navstate`: a pose + velocity estimate as ``Odometry`` (the pose–twist
  cross-covariance reported as dropped).

See ``docs/ros.md``.
"""

from .bag import (
    STORAGES,
    BagError,
    TopicSummary,
    atomic_output,
    bag_info,
    check_topic,
    iter_messages,
    read_messages,
    require_rosbags,
    write_messages,
    write_tum,
)
from .frames import (
    TwistFrameCheck,
    transform_messages,
    twist_frame_check,
    twist_from_parent_frame,
)
from .graph import (
    INCREMENTS,
    DroppedCrossCovariance,
    increment_covariances,
    increment_information,
    messages_from_gtsam,
    odometry_factors,
    odometry_from_gtsam,
    odometry_from_navstate,
)
from .messages import MESSAGE_TYPES, RosMessages, from_poses, normalize_msgtype
from .trajectory import read_trajectory, to_trajectory

__all__ = [
    "INCREMENTS",
    "MESSAGE_TYPES",
    "STORAGES",
    "BagError",
    "DroppedCrossCovariance",
    "RosMessages",
    "TopicSummary",
    "TwistFrameCheck",
    "atomic_output",
    "bag_info",
    "check_topic",
    "from_poses",
    "increment_covariances",
    "increment_information",
    "iter_messages",
    "messages_from_gtsam",
    "normalize_msgtype",
    "odometry_factors",
    "odometry_from_gtsam",
    "odometry_from_navstate",
    "read_messages",
    "read_trajectory",
    "require_rosbags",
    "to_trajectory",
    "transform_messages",
    "twist_frame_check",
    "twist_from_parent_frame",
    "write_messages",
    "write_tum",
]
