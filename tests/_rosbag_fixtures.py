"""Bags written directly with rosbags (not through liebridge), for the liebridge.ros tests."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

rosbags = __import__("pytest").importorskip("rosbags")
from rosbags.highlevel import AnyReader  # noqa: E402
from rosbags.rosbag1 import Writer as Writer1  # noqa: E402
from rosbags.rosbag2 import StoragePlugin  # noqa: E402
from rosbags.rosbag2 import Writer as Writer2  # noqa: E402
from rosbags.typesys import Stores, get_types_from_msg, get_typestore  # noqa: E402

TYPES = (
    "geometry_msgs/msg/PoseWithCovariance",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
    "geometry_msgs/msg/TransformStamped",
    "tf2_msgs/msg/TFMessage",
    "nav_msgs/msg/Odometry",
    "sensor_msgs/msg/Imu",
)
STORAGES = ("rosbag1", "sqlite3", "mcap")


def typestore(storage: str) -> Any:
    if storage == "rosbag1":
        ts = get_typestore(Stores.ROS1_NOETIC)
        ts.register(
            get_types_from_msg(
                "geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"
            )
        )
        return ts
    return get_typestore(Stores.ROS2_HUMBLE)


def _ugly(rng: np.random.Generator, n: int) -> np.ndarray:
    """Floats with all 53 bits in use, mixed magnitudes and signs, a -0.0 and a -1."""
    x = rng.normal(size=n) * 10.0 ** rng.integers(-8, 4, size=n)
    if n > 2:
        x[0], x[1] = -0.0, -1.0
    return x


def _quat(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    return q if q[3] < 0 else -q  # stored with w < 0: the sign must survive


class MessageFactory:
    """Random messages of the supported types, built with one typestore's classes."""

    def __init__(self, ts: Any, ros1: bool, rng: np.random.Generator) -> None:
        self.t, self.ros1, self.rng = ts.types, ros1, rng

    def header(self, k: int) -> Any:
        kw = {"seq": 1000 + k} if self.ros1 else {}
        stamp = self.t["builtin_interfaces/msg/Time"](
            sec=1_700_000_000 + k, nanosec=int(self.rng.integers(0, 10**9))
        )
        return self.t["std_msgs/msg/Header"](stamp=stamp, frame_id=f"odom{k % 2}", **kw)

    def v3(self, name: str) -> Any:
        x = _ugly(self.rng, 3)
        return self.t[name](x=x[0], y=x[1], z=x[2])

    def q(self) -> Any:
        q = _quat(self.rng)
        return self.t["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3])

    def pose_cov(self) -> Any:
        pose = self.t["geometry_msgs/msg/Pose"](
            position=self.v3("geometry_msgs/msg/Point"), orientation=self.q()
        )
        return self.t["geometry_msgs/msg/PoseWithCovariance"](
            pose=pose, covariance=_ugly(self.rng, 36)
        )

    def transform(self, k: int) -> Any:
        tf = self.t["geometry_msgs/msg/Transform"](
            translation=self.v3("geometry_msgs/msg/Vector3"), rotation=self.q()
        )
        return self.t["geometry_msgs/msg/TransformStamped"](
            header=self.header(k), child_frame_id=f"base{k}", transform=tf
        )

    def make(self, mt: str, k: int) -> Any:
        t = self.t
        if mt == "geometry_msgs/msg/PoseWithCovariance":
            return self.pose_cov()
        if mt == "geometry_msgs/msg/PoseWithCovarianceStamped":
            return t[mt](header=self.header(k), pose=self.pose_cov())
        if mt == "geometry_msgs/msg/TransformStamped":
            return self.transform(k)
        if mt == "tf2_msgs/msg/TFMessage":
            return t[mt](transforms=[self.transform(k) for _ in range(1 + k % 3)])
        if mt == "nav_msgs/msg/Odometry":
            twist = t["geometry_msgs/msg/TwistWithCovariance"](
                twist=t["geometry_msgs/msg/Twist"](
                    linear=self.v3("geometry_msgs/msg/Vector3"),
                    angular=self.v3("geometry_msgs/msg/Vector3"),
                ),
                covariance=_ugly(self.rng, 36),
            )
            return t[mt](
                header=self.header(k), child_frame_id="base_link", pose=self.pose_cov(), twist=twist
            )
        unknown = k % 3 == 1  # ROS: orientation_covariance[0] = -1, orientation all zeros
        ocov = _ugly(self.rng, 9)
        ocov[0] = -1.0 if unknown else abs(ocov[0])
        o = t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=0.0) if unknown else self.q()
        return t[mt](
            header=self.header(k),
            orientation=o,
            orientation_covariance=ocov,
            angular_velocity=self.v3("geometry_msgs/msg/Vector3"),
            angular_velocity_covariance=_ugly(self.rng, 9),
            linear_acceleration=self.v3("geometry_msgs/msg/Vector3"),
            linear_acceleration_covariance=_ugly(self.rng, 9),
        )


def write_bag(
    path: Path, storage: str, topics: dict[str, tuple[str, list[Any]]], ts: Any = None
) -> Path:
    """Write ``{topic: (msgtype, [messages])}`` with rosbags; receive times 1.7e18 + 1e6·k ns."""
    ts = typestore(storage) if ts is None else ts
    if storage == "rosbag1":
        with Writer1(path) as w:
            for topic, (mt, msgs) in topics.items():
                c = w.add_connection(topic, mt, typestore=ts)
                for k, m in enumerate(msgs):
                    w.write(c, 1_700_000_000_000_000_000 + 1_000_003 * k, ts.serialize_ros1(m, mt))
        return path
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer2(path, version=9, storage_plugin=plugin) as w:
        for topic, (mt, msgs) in topics.items():
            c = w.add_connection(topic, mt, typestore=ts)
            for k, m in enumerate(msgs):
                w.write(c, 1_700_000_000_000_000_000 + 1_000_003 * k, ts.serialize_cdr(m, mt))
    return path


def raw_records(path: Path) -> list[tuple[str, str, int, bytes]]:
    """(topic, msgtype, receive time, serialized bytes) of every message, in bag order."""
    with AnyReader([path]) as r:
        return [
            (c.topic, c.msgtype, int(t), bytes(raw))
            for c, t, raw in r.messages(connections=r.connections)
        ]


def bag_path(tmp: Path, storage: str, name: str = "in") -> Path:
    return tmp / (f"{name}.bag" if storage == "rosbag1" else f"{name}_{storage}")
