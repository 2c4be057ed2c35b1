"""ROS messages as batched numpy structures, with the covariance convention explicit.

One :class:`RosMessages` holds every message of one topic (one row per pose; a
``tf2_msgs/TFMessage`` contributes one row per transform). Its **raw fields** are the message
fields as stored, bit for bit — position, the quaternion with its sign, the 36 covariance numbers
in message order, the stamps as integer ``(sec, nanosec)``, frame ids, ROS 1 ``header.seq``,
the bag's receive times — so :func:`liebridge.ros.write_messages` writes the same bytes back.
The **derived fields** are what estimation code wants:

* ``T`` ``(N, 4, 4)``: ``T_parent_child``, the pose of the child frame (``child_frame_id``, or
  the body for a ``PoseWithCovariance``) in ``header.frame_id`` (maps child coordinates to parent
  coordinates);
* ``cov`` ``(N, 6, 6)``: the pose covariance in :attr:`RosMessages.convention`'s tangent. ROS
  (``geometry_msgs/PoseWithCovariance.msg``, noetic and ROS 2) defines it over
  ``(x, y, z, rotX, rotY, rotZ)``: the position error in the parent frame, then the rotation
  error about the **parent's fixed axes** — liebridge's ``ros`` preset, whose perturbation is
  ``(t + u, Exp(ω)·R)``. With the default ``convention="ros"`` ``cov`` is the message's own
  matrix, unchanged; any other convention goes through
  :func:`liebridge.conventions.convert_covariance` at ``T`` (for GTSAM, ``Σ_gtsam = M Σ_ros Mᵀ``
  with ``M = [[0, Rᵀ], [Rᵀ, 0]]``). False, and tempting: "the rotation block is about the body
  axes, so reordering a body-frame covariance gives the ROS one" — that is only true when
  ``R = I``.
* ``twist`` ``(N, 6)`` and ``twist_cov`` ``(N, 6, 6)`` (``nav_msgs/Odometry`` only): the twist as
  ROS defines it, **in the child frame** (``nav_msgs/Odometry.msg``: "The twist in this message
  should be specified in the coordinate frame given by the child_frame_id"): linear velocity of
  the child origin and angular velocity, both in child coordinates — i.e. the body twist
  ``T⁻¹·Ṫ`` of GTSAM's ``(ω, v)``, up to order. It is only reordered to the convention's tangent
  order (``(v, ω)`` for ``ros``, ``(ω, v)`` for ``gtsam``); a twist is a velocity, not a
  perturbation, so it is never re-expressed in another frame here. False, and common: "the
  twist is in ``header.frame_id``" (drivers that publish world-frame velocities;
  :func:`liebridge.ros.twist_frame_check` detects them).

Sources: ``geometry_msgs/msg/PoseWithCovariance.msg`` and ``nav_msgs/msg/Odometry.msg`` (ROS 1
noetic ``common_msgs``, ROS 2 ``common_interfaces``), as shipped in the ``rosbags`` type stores
(``rosbags.typesys.stores.ros1_noetic`` / ``ros2_humble``, rosbags 0.11).
"""

from __future__ import annotations

from dataclasses import MISSING, dataclass, field, fields, replace
from functools import cached_property
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import _validate as validate
from .._validate import QUATERNION_TOL, FloatArray
from ..conventions import Convention, ConventionLike, convert_covariance, get, single_group
from ..io.poses import from_matrix
from ..lie import quaternion as quat

__all__ = [
    "MESSAGE_TYPES",
    "RosMessages",
    "from_poses",
    "normalize_msgtype",
]

IntArray = npt.NDArray[np.int64]

#: The message types liebridge reads (ROS 2 spelling; ``pkg/Type`` is accepted too); all but
#: ``nav_msgs/Path`` are written too. A ``nav_msgs/Path`` message is a whole trajectory (one row
#: per ``poses[i]``, each with its own header); :func:`liebridge.ros.read_messages` reads one
#: message of such a topic (default: the last, the final trajectory; ``path_message``).
MESSAGE_TYPES: tuple[str, ...] = (
    "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/PoseWithCovariance",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
    "geometry_msgs/msg/TransformStamped",
    "tf2_msgs/msg/TFMessage",
    "nav_msgs/msg/Odometry",
    "sensor_msgs/msg/Imu",
    "nav_msgs/msg/Path",
)

#: Types with several rows (poses) per message.
_MULTI_ROW = {"tf2_msgs/msg/TFMessage", "nav_msgs/msg/Path"}
_PATH = "nav_msgs/msg/Path"

_WITH_POSE_COV = {
    "geometry_msgs/msg/PoseWithCovariance",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
    "nav_msgs/msg/Odometry",
}
_WITH_CHILD = {
    "geometry_msgs/msg/TransformStamped",
    "tf2_msgs/msg/TFMessage",
    "nav_msgs/msg/Odometry",
}
_ODOM = "nav_msgs/msg/Odometry"
_IMU = "sensor_msgs/msg/Imu"


def normalize_msgtype(msgtype: str) -> str:
    """``"nav_msgs/Odometry"`` → ``"nav_msgs/msg/Odometry"`` (ROS 2 spelling, as rosbags uses)."""
    parts = str(msgtype).split("/")
    if len(parts) == 2:
        parts = [parts[0], "msg", parts[1]]
    return "/".join(parts)


def _readonly(a: npt.NDArray[Any]) -> npt.NDArray[Any]:
    a = np.array(a)
    a.flags.writeable = False
    return a


def _frozen(a: npt.NDArray[Any]) -> npt.NDArray[Any]:
    """Return ``a`` itself, read-only (arrays handed over by their maker, never a caller's)."""
    a.flags.writeable = False
    return a


def _swap_halves(x: FloatArray) -> FloatArray:
    """Swap (a, b) → (b, a) on the last axis of a 6-vector, on both axes of a 6×6 matrix."""
    p = np.r_[3:6, 0:3]
    if x.shape[-1] == 6 and x.ndim >= 2 and x.shape[-2] == 6:
        return np.asarray(x[..., p, :][..., :, p], dtype=np.float64)
    return np.asarray(x[..., p], dtype=np.float64)


@dataclass(frozen=True, eq=False)
class RosMessages:
    """All messages of one topic, batched: raw fields as stored plus derived arrays.

    Build it with :func:`liebridge.ros.read_messages` (from a bag) or :func:`from_poses` (from
    poses and covariances, e.g. GTSAM results); change the covariance convention with
    :meth:`with_convention`. Rows are poses; ``message_index`` maps rows to messages (a
    ``TFMessage`` holds several transforms).

    Attributes
    ----------
    msgtype : str
        One of :data:`MESSAGE_TYPES` (ROS 2 spelling).
    stamp_sec, stamp_nanosec : ndarray of int64, shape (N,)
        ``header.stamp`` as stored. For the header-less ``PoseWithCovariance``: the bag's receive
        time. For ``nav_msgs/Path``: each ``poses[i].header.stamp`` (the path's own header
        stamp is not kept).
    frame_id : tuple of str, length N
        ``header.frame_id``: the parent frame the pose is expressed in ("" without a header).
        For ``nav_msgs/Path``: ``poses[i].header.frame_id``, or the path's ``header.frame_id``
        where that is empty (as nav2 and most publishers leave it).
    position : ndarray, shape (N, 3)
        ``pose.position`` / ``transform.translation`` (zeros for ``Imu``).
    orientation_xyzw : ndarray, shape (N, 4)
        The quaternion as stored, ``(x, y, z, w)`` order, sign and rounding kept.
    child_frame_id : tuple of str or None
        ``child_frame_id`` (``Odometry``, transforms); None for the other types.
    pose_covariance : ndarray, shape (N, 36) or None
        The 36 numbers of ``pose.covariance`` as stored (row-major over
        ``(x, y, z, rotX, rotY, rotZ)``).
    twist_linear_angular : ndarray, shape (N, 6) or None
        ``Odometry`` ``twist.twist``: ``(linear.x, .y, .z, angular.x, .y, .z)``, child frame.
    twist_covariance : ndarray, shape (N, 36) or None
        ``Odometry`` ``twist.covariance`` as stored, over ``(vx, vy, vz, wx, wy, wz)``.
    orientation_covariance, angular_velocity, angular_velocity_covariance, linear_acceleration,
    linear_acceleration_covariance : ndarray or None
        ``Imu`` fields as stored ((N, 9), (N, 3), (N, 9), (N, 3), (N, 9)); ROS marks an unknown
        orientation by ``orientation_covariance[0] = -1``.
    seq : ndarray of int64, shape (N,)
        ROS 1 ``header.seq`` (0 for ROS 2 bags, which have none).
    message_index : ndarray of int64, shape (N,)
        Message each row came from (``0..M-1``, non-decreasing).
    log_time_ns : ndarray of int64, shape (M,)
        The bag's receive time of each message, nanoseconds (written back as is).
    topic : str
    storage : {"rosbag1", "sqlite3", "mcap"} or None
        The bag format the batch was read from (the default of ``write_messages``).
    convention : Convention
        What ``cov`` (and the order of ``twist``/``twist_cov``) is expressed in; default ``ros``.
    quaternion_tol : float
        Accepted ``| ‖q‖ − 1 |`` of the stored quaternions (beyond: ``ValueError`` naming the
        message); within it ``T`` uses the normalised quaternion.

    Derived (read-only arrays): ``stamps`` (N,) seconds as float64 (``sec + 1e-9·nanosec``);
    ``T`` (N, 4, 4) ``T_parent_child`` (built at first use and kept: 128 B a message that a
    caller who only writes the fields back never pays); ``cov`` (N, 6, 6) or None; ``twist``
    (N, 6) or None; ``twist_cov`` (N, 6, 6) or None; ``orientation_known`` (N,) bool (``Imu``;
    else all True).
    """

    msgtype: str
    stamp_sec: IntArray
    stamp_nanosec: IntArray
    frame_id: tuple[str, ...]
    position: FloatArray
    orientation_xyzw: FloatArray
    child_frame_id: tuple[str, ...] | None = None
    pose_covariance: FloatArray | None = None
    twist_linear_angular: FloatArray | None = None
    twist_covariance: FloatArray | None = None
    orientation_covariance: FloatArray | None = None
    angular_velocity: FloatArray | None = None
    angular_velocity_covariance: FloatArray | None = None
    linear_acceleration: FloatArray | None = None
    linear_acceleration_covariance: FloatArray | None = None
    seq: IntArray | None = None
    message_index: IntArray | None = None
    log_time_ns: IntArray | None = None
    topic: str = ""
    storage: str | None = None
    convention: Convention = field(default_factory=lambda: single_group(get("ros")))
    quaternion_tol: float = QUATERNION_TOL

    stamps: FloatArray = field(init=False, repr=False)
    cov: FloatArray | None = field(init=False, repr=False)
    twist: FloatArray | None = field(init=False, repr=False)
    twist_cov: FloatArray | None = field(init=False, repr=False)
    orientation_known: npt.NDArray[np.bool_] = field(init=False, repr=False)

    def __len__(self) -> int:
        return int(self.stamp_sec.shape[0])

    def _set(self, name: str, value: Any) -> None:
        object.__setattr__(self, name, value)

    def _where(self, row: int) -> str:
        """E.g. ``topic /odom, message 12`` (the message index of row ``row``)."""
        assert self.message_index is not None
        t = f"topic {self.topic}, " if self.topic else ""
        return f"{t}message {int(self.message_index[row])}"

    @classmethod
    def _adopt(cls, **kw: Any) -> RosMessages:
        """Build from arrays the bag reader has just made: the same checks, no copies.

        The arrays are made read-only in place instead of copied (the reader hands them over),
        so :func:`~liebridge.ros.read_messages` peaks at its arrays, not twice them.
        """
        obj = object.__new__(cls)
        for f in fields(cls):
            if not f.init:
                continue
            if f.name in kw:
                value = kw.pop(f.name)
            elif f.default is not MISSING:
                value = f.default
            else:
                assert f.default_factory is not MISSING, f.name
                value = f.default_factory()
            object.__setattr__(obj, f.name, value)
        if kw:
            raise TypeError(f"RosMessages: unknown fields {sorted(kw)}")
        obj.__dict__["_adopted"] = True
        obj.__post_init__()
        return obj

    def __post_init__(self) -> None:
        adopted = bool(self.__dict__.pop("_adopted", False))
        mt = normalize_msgtype(self.msgtype)
        if mt not in MESSAGE_TYPES:
            raise ValueError(
                f"msgtype: {self.msgtype!r} is not supported "
                f"(supported: {', '.join(MESSAGE_TYPES)})"
            )
        self._set("msgtype", mt)
        self._set("convention", get(self.convention))
        n = int(np.shape(self.stamp_sec)[0]) if np.ndim(self.stamp_sec) == 1 else -1
        if n < 0:
            raise ValueError(f"stamp_sec: expected shape (N,), got {np.shape(self.stamp_sec)}")

        def ints(name: str, value: Any, length: int) -> IntArray:
            a = np.asarray(value)
            if a.shape != (length,) or (a.size and not np.issubdtype(a.dtype, np.integer)):
                raise ValueError(f"{name}: expected {length} integers, got shape {a.shape}")
            if adopted and a.dtype == np.int64:
                return _frozen(a)
            return _readonly(a.astype(np.int64))

        def floats(name: str, value: Any, width: int, required: bool) -> FloatArray | None:
            if value is None:
                if required:
                    raise ValueError(f"{name}: required for {mt}")
                return None
            a = validate.as_float_array(value, name)
            if a.shape != (n, width):
                k = next((i for i in range(min(n, len(a))) if np.shape(a[i]) != (width,)), None)
                at = f" (message row {k})" if k is not None else ""
                raise ValueError(f"{name}: expected shape ({n}, {width}), got {a.shape}{at}")
            return _frozen(a) if adopted and a.base is None else _readonly(a)

        def strings(name: str, value: Any) -> tuple[str, ...]:
            s = tuple(str(x) for x in value)
            if len(s) != n:
                raise ValueError(f"{name}: expected {n} strings, got {len(s)}")
            return s

        self._set("stamp_sec", ints("stamp_sec", self.stamp_sec, n))
        self._set("stamp_nanosec", ints("stamp_nanosec", self.stamp_nanosec, n))
        if ((self.stamp_nanosec < 0) | (self.stamp_nanosec >= 1_000_000_000)).any():
            k = int(np.argmax((self.stamp_nanosec < 0) | (self.stamp_nanosec >= 1_000_000_000)))
            raise ValueError(
                f"stamp_nanosec: {int(self.stamp_nanosec[k])} at row {k} not in [0, 1e9)"
            )
        self._set("frame_id", strings("frame_id", self.frame_id))
        if mt in _WITH_CHILD:
            if self.child_frame_id is None:
                raise ValueError(f"child_frame_id: required for {mt}")
            self._set("child_frame_id", strings("child_frame_id", self.child_frame_id))
        elif self.child_frame_id is not None:
            raise ValueError(f"child_frame_id: {mt} has no child_frame_id")
        self._set("position", floats("position", self.position, 3, True))
        self._set("orientation_xyzw", floats("orientation_xyzw", self.orientation_xyzw, 4, True))
        self._set(
            "pose_covariance",
            floats("pose_covariance", self.pose_covariance, 36, mt in _WITH_POSE_COV),
        )
        odom, imu = mt == _ODOM, mt == _IMU
        self._set(
            "twist_linear_angular",
            floats("twist_linear_angular", self.twist_linear_angular, 6, odom),
        )
        self._set("twist_covariance", floats("twist_covariance", self.twist_covariance, 36, odom))
        for name, width in (
            ("orientation_covariance", 9),
            ("angular_velocity", 3),
            ("angular_velocity_covariance", 9),
            ("linear_acceleration", 3),
            ("linear_acceleration_covariance", 9),
        ):
            self._set(name, floats(name, getattr(self, name), width, imu))
        for name in ("pose_covariance", "twist_linear_angular", "twist_covariance"):
            if getattr(self, name) is not None and mt not in (
                _WITH_POSE_COV if name == "pose_covariance" else {_ODOM}
            ):
                raise ValueError(f"{name}: {mt} has no such field")
        self._set("seq", ints("seq", np.zeros(n, np.int64) if self.seq is None else self.seq, n))
        mi = np.arange(n) if self.message_index is None else self.message_index
        self._set("message_index", ints("message_index", mi, n))
        assert self.message_index is not None
        if n and (self.message_index[0] != 0 or (np.diff(self.message_index) < 0).any()):
            raise ValueError("message_index: expected non-decreasing indices starting at 0")
        if n and mt not in _MULTI_ROW and (np.diff(self.message_index) != 1).any():
            raise ValueError(f"message_index: {mt} holds one pose per message")
        m = int(self.message_index[-1]) + 1 if n else 0
        if self.log_time_ns is None:
            first = np.r_[0, np.flatnonzero(np.diff(self.message_index)) + 1][:m] if n else []
            lt = self.stamp_sec[first] * 1_000_000_000 + self.stamp_nanosec[first]
        else:
            lt = self.log_time_ns
        self._set("log_time_ns", ints("log_time_ns", lt, m))
        self._derive()

    def _derive(self) -> None:
        n = len(self)
        self._set("stamps", _readonly(self.stamp_sec + 1e-9 * self.stamp_nanosec))
        q = self.orientation_xyzw
        known = np.ones(n, dtype=bool)
        if self.orientation_covariance is not None:
            known = self.orientation_covariance[:, 0] != -1.0
        self._set("orientation_known", _readonly(known))
        pos_bad = ~np.isfinite(self.position).all(axis=-1)
        if pos_bad.any():
            k = int(np.argmax(pos_bad))
            raise ValueError(f"{self._where(k)}: position is not finite: {self.position[k]}")
        norm = np.linalg.norm(np.where(known[:, None], q, 0.0), axis=-1)
        bad = known & ~(np.abs(norm - 1.0) <= self.quaternion_tol)
        if bad.any():
            k = int(np.argmax(bad))
            raise ValueError(
                f"{self._where(k)}: orientation quaternion norm {norm[k]!r} is off by "
                f"{abs(norm[k] - 1.0):.3g} (tolerance {self.quaternion_tol:g})"
            )
        conv = self.convention
        rot_first = conv.order == "rot_first"
        cov = None
        if self.pose_covariance is not None:
            cov_ros = self.pose_covariance.reshape(n, 6, 6)
            if conv.name == "ros":
                cov = cov_ros
            elif n:
                try:  # batched; only a failure goes row by row to name the message
                    cov = convert_covariance(cov_ros, self.T, "ros", conv)
                except ValueError:
                    self._check_cov(cov_ros, "pose.covariance")
                    raise
            else:
                cov = cov_ros
            if cov is not cov_ros:  # in ROS's own convention: a view of the read-only raw field
                cov = _readonly(cov)
        self._set("cov", cov)
        tw = twc = None
        if self.twist_linear_angular is not None:
            assert self.twist_covariance is not None
            tw = self.twist_linear_angular
            twc = self.twist_covariance.reshape(n, 6, 6)
            if rot_first:  # else views of the read-only raw fields (no copy: 336 B a message)
                tw, twc = _readonly(_swap_halves(tw)), _readonly(_swap_halves(twc))
        self._set("twist", tw)
        self._set("twist_cov", twc)

    @cached_property
    def T(self) -> FloatArray:
        """``(N, 4, 4)`` ``T_parent_child`` from ``position`` and the normalised quaternion.

        Read-only; built at first access (the quaternions were checked at construction) and
        kept. Rows of an ``Imu`` with unknown orientation hold the identity rotation.
        """
        q = self.orientation_xyzw
        n = len(self)
        known = self.orientation_known
        norm = np.linalg.norm(np.where(known[:, None], q, 0.0), axis=-1)
        qn = np.where(known[:, None], q / np.where(known, norm, 1.0)[:, None], [0, 0, 0, 1.0])
        T = np.zeros((n, 4, 4))
        T[:, :3, :3] = quat.to_matrix(qn, order="xyzw") if n else np.zeros((0, 3, 3))
        T[:, :3, 3] = self.position
        T[:, 3, 3] = 1.0
        return _readonly(T)

    def _check_cov(self, cov: FloatArray, field_name: str) -> None:
        for k in range(cov.shape[0]):
            try:
                validate.covariance(cov[k], field_name, 6)
            except ValueError as exc:
                raise ValueError(
                    f"{self._where(k)}: {exc} — cannot convert it to {self.convention.name!r}"
                ) from None

    def trajectory_frames(self) -> tuple[str, str | None]:
        """``(frame_id, child_frame_id)`` shared by every message: the frames of one trajectory.

        Chaining, exporting or comparing the poses as one trajectory ``T_parent_child(t)`` needs
        one parent and one child frame; a topic whose ``frame_id`` alternates (map, odom, map…)
        holds several trajectories interleaved.

        Raises
        ------
        ValueError
            Naming the first message whose ``frame_id`` (or ``child_frame_id``) differs from the
            first message's, and both names.
        """
        if len(self) == 0:
            return "", None
        for name in ("frame_id", "child_frame_id"):
            ids = getattr(self, name)
            if ids is None:
                continue
            first = ids[0]
            for k, f in enumerate(ids):
                if f != first:
                    raise ValueError(
                        f"{self._where(k)}: {name} {f!r} differs from the first message's "
                        f"{first!r}; the topic holds poses in several frames, not one trajectory "
                        "(select the messages of one frame first, e.g. with select())"
                    )
        return self.frame_id[0], None if self.child_frame_id is None else self.child_frame_id[0]

    def with_convention(self, convention: ConventionLike) -> RosMessages:
        """Return the same messages with ``cov``/``twist``/``twist_cov`` in ``convention``.

        The raw fields (what is written back) do not change.
        """
        return replace(self, convention=single_group(get(convention)))

    def select(self, rows: Any) -> RosMessages:
        """Rows ``rows`` (an index array or slice) as a new batch; messages renumbered."""
        idx = np.arange(len(self))[rows]
        assert self.message_index is not None and self.log_time_ns is not None
        mi = self.message_index[idx]
        uniq, new_mi = np.unique(mi, return_inverse=True)
        kw: dict[str, Any] = {}
        for name in (
            "stamp_sec",
            "stamp_nanosec",
            "position",
            "orientation_xyzw",
            "pose_covariance",
            "twist_linear_angular",
            "twist_covariance",
            "orientation_covariance",
            "angular_velocity",
            "angular_velocity_covariance",
            "linear_acceleration",
            "linear_acceleration_covariance",
            "seq",
        ):
            a = getattr(self, name)
            kw[name] = None if a is None else a[idx]
        kw["frame_id"] = tuple(self.frame_id[i] for i in idx)
        if self.child_frame_id is not None:
            kw["child_frame_id"] = tuple(self.child_frame_id[i] for i in idx)
        return replace(self, message_index=new_mi, log_time_ns=self.log_time_ns[uniq], **kw)


#: Seconds a ROS time can hold: ROS 2 ``builtin_interfaces/Time.sec`` is int32, ROS 1's
#: ``time.secs`` uint32; a stamp outside both cannot be written (and beyond ≈ 9.2e9 s its
#: nanoseconds overflow int64).
STAMP_MIN = -(2**31)
STAMP_MAX = 2**32 - 1


def _stamps_split(stamps: Any, n: int) -> tuple[IntArray, IntArray]:
    """Seconds → (sec, nanosec), rounded to the nearest nanosecond."""
    t = validate.as_float_array(stamps, "stamps")
    if t.shape != (n,):
        raise ValueError(f"stamps: expected shape ({n},), got {t.shape}")
    validate.check_finite(t, "stamps")
    out = (t < STAMP_MIN) | (t > STAMP_MAX)
    if out.any():
        k = int(np.flatnonzero(out)[0])
        raise ValueError(
            f"stamps: stamp {k} ({float(t[k])!r} s) is outside the seconds a ROS time holds "
            f"([{STAMP_MIN}, {STAMP_MAX}]: ROS 2's int32, ROS 1's uint32 seconds); "
            f"{int(out.sum())} such stamps"
        )
    ns = np.round(t * 1e9).astype(np.int64)
    return ns // 1_000_000_000, ns % 1_000_000_000


def from_poses(
    T: Any,
    cov: Any = None,
    *,
    convention: ConventionLike = "ros",
    stamps: Any,
    frame_id: str | tuple[str, ...] | list[str] = "map",
    msgtype: str = "geometry_msgs/msg/PoseWithCovarianceStamped",
    child_frame_id: str | tuple[str, ...] | list[str] | None = None,
    twist: Any = None,
    twist_cov: Any = None,
    topic: str = "",
) -> RosMessages:
    """Messages from poses ``T_parent_child`` and covariances in ``convention``.

    Parameters
    ----------
    T : array_like, shape (N, 4, 4)
        ``T_parent_child`` (e.g. GTSAM's ``T_world_body``).
    cov : array_like, shape (N, 6, 6), optional
        Pose covariance in ``convention``'s tangent at ``T``; converted to the ROS message's
        ``(x, y, z, rotX, rotY, rotZ)`` (parent-frame position, fixed-axis rotation) with
        :func:`liebridge.conventions.convert_covariance`. E.g. ``liebridge.gtsam.marginals(...)``
        output with ``convention="gtsam"``. Zeros if omitted.
    convention : Convention or str
        What ``cov`` (and ``twist``'s order) is in; also the returned batch's convention.
    stamps : array_like, shape (N,)
        Seconds (rounded to the nearest nanosecond).
    frame_id, child_frame_id : str or sequence of str
        Parent frame; child frame (``Odometry`` / transforms, default ``"base_link"``).
    msgtype : str
        One of :data:`MESSAGE_TYPES` except ``Imu`` and ``Path``.
    twist, twist_cov : array_like, shape (N, 6) / (N, 6, 6), optional
        ``Odometry``: the body (child-frame) twist and its covariance in ``convention``'s order.

    Returns
    -------
    RosMessages
        Quaternions with ``w ≥ 0``; ``seq`` zero; receive time = stamp.
    """
    conv = single_group(get(convention))
    mt = normalize_msgtype(msgtype)
    if mt == _IMU:
        raise ValueError("msgtype: from_poses does not build sensor_msgs/Imu messages")
    if mt == _PATH:
        raise ValueError(
            "msgtype: from_poses does not build nav_msgs/Path messages (read only); "
            "use geometry_msgs/msg/PoseStamped for one pose per message"
        )
    Tm = validate.pose(T, "T")
    if Tm.ndim != 3:
        raise ValueError(f"T: expected shape (N, 4, 4), got {Tm.shape}")
    n = Tm.shape[0]
    x = from_matrix(Tm, layout="xyz_qxyzw") if n else np.zeros((0, 7))
    sec, nsec = _stamps_split(stamps, n)
    kw: dict[str, Any] = {}
    if mt in _WITH_POSE_COV:
        if cov is None:
            c_ros = np.zeros((n, 6, 6))
        else:
            c = validate.covariance(cov, "cov", 6)
            if c.shape != (n, 6, 6):
                raise ValueError(f"cov: expected shape ({n}, 6, 6), got {c.shape}")
            c_ros = c if conv.name == "ros" else convert_covariance(c, Tm, conv, "ros")
        kw["pose_covariance"] = c_ros.reshape(n, 36)
    elif cov is not None:
        raise ValueError(f"cov: {mt} carries no covariance")

    def names(value: Any, name: str) -> tuple[str, ...]:
        if isinstance(value, str):
            return (value,) * n
        out = tuple(str(s) for s in value)
        if len(out) != n:
            raise ValueError(f"{name}: expected {n} names, got {len(out)}")
        return out

    if mt in _WITH_CHILD:
        kw["child_frame_id"] = names(
            "base_link" if child_frame_id is None else child_frame_id, "child_frame_id"
        )
    if mt == _ODOM:
        tw = np.zeros((n, 6)) if twist is None else validate.vector(twist, "twist", 6)
        twc = (
            np.zeros((n, 6, 6)) if twist_cov is None else validate.square(twist_cov, "twist_cov", 6)
        )
        if tw.shape != (n, 6) or twc.shape != (n, 6, 6):
            raise ValueError(f"twist, twist_cov: expected shapes ({n}, 6), ({n}, 6, 6)")
        if conv.order == "rot_first":
            tw, twc = _swap_halves(tw), _swap_halves(twc)
        kw["twist_linear_angular"] = tw
        kw["twist_covariance"] = twc.reshape(n, 36)
    elif twist is not None or twist_cov is not None:
        raise ValueError(f"twist: {mt} carries no twist")
    return RosMessages(
        msgtype=mt,
        stamp_sec=sec,
        stamp_nanosec=nsec,
        frame_id=names(frame_id, "frame_id"),
        position=x[:, :3],
        orientation_xyzw=x[:, 3:],
        topic=topic,
        convention=conv,
        **kw,
    )
