"""Reading and writing ROS 1 / ROS 2 bags with the pure-Python ``rosbags`` library (no ROS).

``rosbags`` (PyPI, Apache-2.0; checked with 0.11.9) reads ROS 1 ``.bag`` files and ROS 2 bags
(sqlite3 ``.db3`` or ``.mcap`` storage, as a bag directory or a bare storage file) and carries
the standard message definitions (``rosbags.typesys.Stores.ROS1_NOETIC`` /
``ROS2_HUMBLE``). It is the optional extra ``ros``: ``pip install ".[ros]" (from the checkout)``.

Everything written goes to a temporary file or directory beside the target first and is renamed
into place when complete: a failure leaves no half-written bag.
"""

from __future__ import annotations

import itertools
import os
import re
import shutil
import tempfile
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from .._validate import FloatArray
from ..conventions import ConventionLike, get, single_group
from ..io.atomic import atomic_path, atomic_write
from ..io.trajectory import stamp_text, write_tum_chunks
from .messages import MESSAGE_TYPES, RosMessages, normalize_msgtype

__all__ = [
    "STORAGES",
    "BagError",
    "TopicSummary",
    "atomic_output",
    "bag_info",
    "check_topic",
    "iter_messages",
    "read_messages",
    "require_rosbags",
    "write_messages",
    "write_tum",
]

PathLike = str | os.PathLike[str]
Progress = Callable[[int, int], None]

#: Bag formats: ROS 1 ``.bag``; ROS 2 with sqlite3 storage; ROS 2 with mcap storage.
STORAGES: tuple[str, ...] = ("rosbag1", "sqlite3", "mcap")

_PROGRESS_EVERY = 2000
_PATH = "nav_msgs/msg/Path"


class BagError(ValueError):
    """A bag that cannot be read or written; the message names the file, topic and message."""


def require_rosbags() -> Any:
    """Import ``rosbags`` or fail naming the extra that installs it."""
    try:
        import rosbags.highlevel
        import rosbags.rosbag1
        import rosbags.rosbag2
        import rosbags.typesys
    except ImportError:  # pragma: no cover - exercised only without the extra
        raise ImportError(
            'liebridge.ros needs the "rosbags" package, an optional extra: '
            'pip install ".[ros]" (from the checkout)'
        ) from None
    return rosbags


@dataclass(frozen=True)
class TopicSummary:
    """One topic of a bag: name, type (ROS 2 spelling), message count, whether liebridge reads."""

    topic: str
    msgtype: str
    count: int
    supported: bool


def _storage_of(path: Path) -> str:
    if path.is_dir():
        if any(path.glob("*.mcap")):
            return "mcap"
        return "sqlite3"
    suffix = path.suffix.lower()
    return {".bag": "rosbag1", ".mcap": "mcap", ".db3": "sqlite3"}.get(suffix, "sqlite3")


@contextmanager
def _open_reader(path: Path) -> Iterator[Any]:
    rb = require_rosbags()
    if not path.exists():
        raise BagError(f"{path}: no such bag")
    try:
        reader = rb.highlevel.AnyReader(
            [path], default_typestore=rb.typesys.get_typestore(rb.typesys.Stores.ROS2_HUMBLE)
        )
        reader.open()
    except Exception as exc:  # rosbags raises its own error classes, struct and OS errors
        raise BagError(f"{path}: not a readable bag ({type(exc).__name__}: {exc})") from None
    try:
        yield reader
    finally:
        try:
            reader.close()
        except Exception:
            pass


def bag_info(bag: PathLike) -> tuple[str, float, float, list[TopicSummary]]:
    """Storage format, start and end time (seconds) and the topics of ``bag``.

    Returns
    -------
    storage : str
        One of :data:`STORAGES`.
    start, end : float
        Receive times of the first and last message (0.0 for an empty bag).
    topics : list of TopicSummary
    """
    path = Path(bag)
    with _open_reader(path) as r:
        topics = [
            TopicSummary(
                name,
                info.msgtype,
                int(info.msgcount),
                normalize_msgtype(info.msgtype) in MESSAGE_TYPES,
            )
            for name, info in sorted(r.topics.items())
        ]
        count = sum(t.count for t in topics)
        start = r.start_time * 1e-9 if count else 0.0
        end = (r.end_time - 1) * 1e-9 if count else 0.0  # rosbags: one past the last
    return _storage_of(path), start, end, topics


def _fixed(value: Any, n: int, where: str) -> list[float]:
    a = np.asarray(value, dtype=np.float64).ravel()
    if a.shape != (n,):
        raise BagError(f"{where}: expected {n} numbers, got {a.shape[0]}")
    out: list[float] = a.tolist()
    return out


class _Rows:
    """Column lists filled message by message (one Python pass, then one array per field)."""

    def __init__(self, where: Callable[[int], str], names: dict[str, str]) -> None:
        self.cols: dict[str, list[Any]] = {}
        self.where = where
        self.names = names  # frame names seen, to share one str object per name

    def name(self, s: Any) -> str:
        text = str(s)
        return self.names.setdefault(text, text)

    def arrays(self, first: int) -> dict[str, Any]:
        """Return the columns as arrays (``message_index`` from ``first``) or tuples (names)."""
        out: dict[str, Any] = {}
        for name, col in self.cols.items():
            if name in ("frame_id", "child_frame_id"):
                out[name] = tuple(col)
            elif name in _FLOAT_WIDTH:
                out[name] = np.array(col, dtype=np.float64)
            else:
                out[name] = np.array(col, dtype=np.int64)
        if "message_index" in out:
            out["message_index"] = out["message_index"] - first
        self.cols = {}
        return out

    def add(self, **kw: Any) -> None:
        for k, val in kw.items():
            self.cols.setdefault(k, []).append(val)

    def header(self, h: Any, k: int) -> None:
        self.add(
            stamp_sec=int(h.stamp.sec),
            stamp_nanosec=int(h.stamp.nanosec),
            frame_id=self.name(h.frame_id),
            seq=int(getattr(h, "seq", 0)),
            message_index=k,
        )

    def pose(self, p: Any) -> None:
        self.add(
            position=[p.position.x, p.position.y, p.position.z],
            orientation_xyzw=[p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w],
        )

    def transform(self, t: Any, k: int) -> None:
        self.header(t.header, k)
        tr, q = t.transform.translation, t.transform.rotation
        self.add(
            child_frame_id=self.name(t.child_frame_id),
            position=[tr.x, tr.y, tr.z],
            orientation_xyzw=[q.x, q.y, q.z, q.w],
        )

    def message(self, mt: str, msg: Any, k: int, log_ns: int) -> None:
        w = self.where(k)
        if mt == "geometry_msgs/msg/PoseStamped":
            self.header(msg.header, k)
            self.pose(msg.pose)
        elif mt == "nav_msgs/msg/Path":
            parent = str(msg.header.frame_id)
            for ps in msg.poses:
                self.header(ps.header, k)
                if not self.cols["frame_id"][-1]:
                    self.cols["frame_id"][-1] = self.name(parent)
                self.pose(ps.pose)
        elif mt == "geometry_msgs/msg/PoseWithCovariance":
            self.add(
                stamp_sec=log_ns // 1_000_000_000,
                stamp_nanosec=log_ns % 1_000_000_000,
                frame_id="",
                seq=0,
                message_index=k,
            )
            self.pose(msg.pose)
            self.add(pose_covariance=_fixed(msg.covariance, 36, f"{w}: field pose.covariance"))
        elif mt == "geometry_msgs/msg/PoseWithCovarianceStamped":
            self.header(msg.header, k)
            self.pose(msg.pose.pose)
            cov = _fixed(msg.pose.covariance, 36, f"{w}: field pose.covariance")
            self.add(pose_covariance=cov)
        elif mt == "nav_msgs/msg/Odometry":
            self.header(msg.header, k)
            self.add(child_frame_id=self.name(msg.child_frame_id))
            self.pose(msg.pose.pose)
            tl, ta = msg.twist.twist.linear, msg.twist.twist.angular
            self.add(
                pose_covariance=_fixed(msg.pose.covariance, 36, f"{w}: field pose.covariance"),
                twist_linear_angular=[tl.x, tl.y, tl.z, ta.x, ta.y, ta.z],
                twist_covariance=_fixed(msg.twist.covariance, 36, f"{w}: field twist.covariance"),
            )
        elif mt == "geometry_msgs/msg/TransformStamped":
            self.transform(msg, k)
        elif mt == "tf2_msgs/msg/TFMessage":
            for t in msg.transforms:
                self.transform(t, k)
        else:  # sensor_msgs/msg/Imu
            self.header(msg.header, k)
            o, g, a = msg.orientation, msg.angular_velocity, msg.linear_acceleration
            self.add(
                position=[0.0, 0.0, 0.0],
                orientation_xyzw=[o.x, o.y, o.z, o.w],
                orientation_covariance=_fixed(
                    msg.orientation_covariance, 9, f"{w}: field orientation_covariance"
                ),
                angular_velocity=[g.x, g.y, g.z],
                angular_velocity_covariance=_fixed(
                    msg.angular_velocity_covariance, 9, f"{w}: field angular_velocity_covariance"
                ),
                linear_acceleration=[a.x, a.y, a.z],
                linear_acceleration_covariance=_fixed(
                    msg.linear_acceleration_covariance,
                    9,
                    f"{w}: field linear_acceleration_covariance",
                ),
            )


_FLOAT_WIDTH = {
    "position": 3,
    "orientation_xyzw": 4,
    "pose_covariance": 36,
    "twist_linear_angular": 6,
    "twist_covariance": 36,
    "orientation_covariance": 9,
    "angular_velocity": 3,
    "angular_velocity_covariance": 9,
    "linear_acceleration": 3,
    "linear_acceleration_covariance": 9,
}


def read_messages(
    bag: PathLike,
    topic: str,
    *,
    convention: ConventionLike = "ros",
    quaternion_tol: float | None = None,
    progress: Progress | None = None,
    path_message: int | None = None,
) -> RosMessages:
    """All messages of ``topic`` in ``bag`` as one :class:`RosMessages` batch.

    The bag is read in batches of :data:`BATCH_MESSAGES` messages whose fields go into arrays
    at once: memory is the returned arrays (≈ 0.9 kB an ``Odometry`` message) plus one batch,
    not a Python object per field. :func:`iter_messages` streams the batches instead.

    Parameters
    ----------
    bag : str or os.PathLike
        A ROS 1 ``.bag`` file, a ROS 2 bag directory (sqlite3 or mcap storage), or a bare
        ``.mcap`` / ``.db3`` file.
    topic : str
        A topic of one of the types in :data:`liebridge.ros.MESSAGE_TYPES`.
    convention : Convention or str
        The convention of the returned ``cov`` and of ``twist``'s order (default ``"ros"``: the
        message's own covariance, bit for bit).
    quaternion_tol : float, optional
        Accepted ``| ‖q‖ − 1 |`` of the stored quaternions (default
        :data:`liebridge._validate.QUATERNION_TOL`, 1e-6).
    progress : callable(done, total), optional
        Called every 2000 messages and at the end (the command line prints it on stderr).
    path_message : int, optional
        ``nav_msgs/Path`` topics only, where each message is a whole trajectory: the index of
        the message to read (Python's: ``-1``, the default, is the last — the final, most
        refined trajectory a SLAM system published; ``0`` the first). Only that message is
        deserialized. Its poses become the rows (stamps and frames from each
        ``poses[i].header``, the path's ``frame_id`` where a pose's is empty).

    Returns
    -------
    RosMessages
        Messages in the bag's order (receive time); for a ``Path``, the chosen message's poses
        in their order in the message.

    Raises
    ------
    BagError
        (a ``ValueError``) naming the file, and the topic, message index and field where it
        applies: an unreadable, truncated or corrupt bag, a missing topic, a topic of an
        unsupported type, a field of the wrong length.
    ValueError
        A quaternion off the unit sphere or a covariance that cannot be converted, naming the
        topic and message index.
    """
    single_group(get(convention))  # a bad convention is refused before the bag is read
    pm = _check_path_message(path_message)
    batches = list(_column_batches(bag, topic, progress, None, pm))
    mt, storage = batches[0][0], batches[0][1]
    if len(batches) == 1:
        cols, log_times = batches[0][2], batches[0][3]
    else:
        log_times = np.concatenate([b[3] for b in batches])
        cols = {}
        for name in list(batches[0][2]):  # column by column, each batch's part freed at once
            parts = [b[2].pop(name) for b in batches]
            if isinstance(parts[0], tuple):
                cols[name] = tuple(x for part in parts for x in part)
            else:
                if name == "message_index":  # counted from each batch's first message
                    parts = [part + b[4] for part, b in zip(parts, batches, strict=True)]
                cols[name] = np.concatenate(parts)
        del batches
    return _messages(Path(bag), topic, mt, storage, cols, log_times, convention, quaternion_tol)


#: Messages read into Python objects before their fields become arrays (bounds the memory of
#: :func:`read_messages` and :func:`iter_messages` beyond their arrays: ≈ 6 kB a message).
BATCH_MESSAGES = 5_000


def iter_messages(
    bag: PathLike,
    topic: str,
    *,
    convention: ConventionLike = "ros",
    quaternion_tol: float | None = None,
    progress: Progress | None = None,
    batch: int | None = None,
    path_message: int | None = None,
) -> Iterator[RosMessages]:
    """Stream the messages of ``topic`` as :class:`RosMessages` batches of ``batch`` messages.

    ``batch`` defaults to :data:`BATCH_MESSAGES`. Memory stays one batch whatever the bag's
    size, where :func:`read_messages` holds every message's arrays. Each batch is
    what :func:`read_messages` would return for its messages, with ``message_index`` counted
    from the batch's first message; errors name the message's index in the topic. A
    ``nav_msgs/Path`` topic gives one batch: the poses of message ``path_message`` (default
    ``-1``, the last; see :func:`read_messages`).
    """
    batch = BATCH_MESSAGES if batch is None else batch
    if isinstance(batch, bool) or not isinstance(batch, int) or batch < 1:
        raise ValueError(f"batch: expected a positive int, got {batch!r}")
    single_group(get(convention))  # refused at the call, not at the first batch
    pm = _check_path_message(path_message)
    return _iter_messages(Path(bag), topic, convention, quaternion_tol, progress, batch, pm)


def _iter_messages(
    path: Path,
    topic: str,
    convention: ConventionLike,
    quaternion_tol: float | None,
    progress: Progress | None,
    batch: int,
    path_message: int | None,
) -> Iterator[RosMessages]:
    batches = _column_batches(path, topic, progress, batch, path_message)
    for mt, storage, cols, log_times, first in batches:
        try:
            yield _messages(path, topic, mt, storage, cols, log_times, convention, quaternion_tol)
        except ValueError as exc:  # "message j" of the batch → of the topic
            raise type(exc)(_shift_message_index(str(exc), first)) from None


def _shift_message_index(text: str, first: int) -> str:
    return re.sub(r"message (\d+)", lambda m: f"message {int(m.group(1)) + first}", text)


def _path_index(path: Path, topic: str, path_message: int | None, total: int) -> int:
    """Return the index of the ``nav_msgs/Path`` message to read (negative: from the end)."""
    k = -1 if path_message is None else path_message
    if total == 0:
        raise BagError(f"{path}: topic {topic} (nav_msgs/msg/Path) has no messages")
    if not -total <= k < total:
        raise BagError(
            f"{path}: topic {topic}: path_message {k} does not exist; the topic has {total} "
            f"nav_msgs/Path messages (index 0..{total - 1}, or -1 for the last)"
        )
    return k % total


def _check_path_message(path_message: Any) -> int | None:
    if path_message is None:
        return None
    if isinstance(path_message, bool) or not isinstance(path_message, int | np.integer):
        raise TypeError(
            f"path_message: expected an int (a message index, -1 the last), "
            f"got {type(path_message).__name__}"
        )
    return int(path_message)


def _column_batches(
    bag: PathLike,
    topic: str,
    progress: Progress | None,
    batch: int | None = None,
    path_message: int | None = None,
) -> Iterator[tuple[str, str, dict[str, Any], npt.NDArray[np.int64], int]]:
    """``(msgtype, storage, columns, log_times, first message)`` per batch of messages.

    Columns are arrays (numbers) or tuples (frame ids, interned); ``message_index`` counts from
    the batch's first message. At least one (possibly empty) batch is yielded. For a
    ``nav_msgs/Path`` topic, one batch: the rows of message ``path_message`` (only that message
    is deserialized; the others are skipped as raw bytes).
    """
    path = Path(bag)
    batch = BATCH_MESSAGES if batch is None else batch
    with _open_reader(path) as r:
        conns = [c for c in r.connections if c.topic == topic]
        if not conns:
            have = ", ".join(sorted(r.topics)) or "none"
            raise BagError(f"{path}: no topic {topic!r} (topics: {have})")
        types = {normalize_msgtype(c.msgtype) for c in conns}
        if len(types) != 1:
            raise BagError(f"{path}: topic {topic} has several types: {sorted(types)}")
        mt = types.pop()
        if mt not in MESSAGE_TYPES:
            raise BagError(
                f"{path}: topic {topic} has type {mt}, which liebridge.ros does not read "
                f"(supported: {', '.join(MESSAGE_TYPES)})"
            )
        total = sum(int(c.msgcount) for c in conns)
        storage = _storage_of(path)
        names: dict[str, str] = {}  # one str object per frame name, not one per message
        rows = _Rows(lambda k: f"{path}: topic {topic}, message {k}", names)
        log_times: list[int] = []
        k = first = 0
        want = _path_index(path, topic, path_message, total) if mt == _PATH else None
        try:
            for con, log_ns, raw in r.messages(connections=conns):
                if want is not None:  # a Path topic: one message is the trajectory
                    if k != want:
                        k += 1
                        continue
                    first = k
                if k - first == batch:
                    yield mt, storage, rows.arrays(first), np.array(log_times), first
                    rows = _Rows(lambda k: f"{path}: topic {topic}, message {k}", names)
                    log_times, first = [], k
                try:
                    msg = r.deserialize(raw, con.msgtype)
                except Exception as exc:
                    raise BagError(
                        f"{path}: topic {topic}, message {k}: cannot deserialize "
                        f"({type(exc).__name__}: {exc})"
                    ) from None
                rows.message(mt, msg, k, int(log_ns))
                log_times.append(int(log_ns))
                if want is not None:
                    if not msg.poses:
                        raise BagError(
                            f"{path}: topic {topic}, message {k}: the nav_msgs/Path holds no "
                            "poses (choose another message with path_message)"
                        )
                    k += 1
                    break
                k += 1
                if progress is not None and k % _PROGRESS_EVERY == 0:
                    progress(k, total)
        except BagError:
            raise
        except Exception as exc:  # a truncated chunk, a bad index, a decompression error
            raise BagError(
                f"{path}: topic {topic}, message {k}: bag is truncated or corrupt "
                f"({type(exc).__name__}: {exc})"
            ) from None
        if progress is not None:
            progress(k, total)
    yield mt, storage, rows.arrays(first), np.array(log_times, dtype=np.int64), first


def _messages(
    path: Path,
    topic: str,
    mt: str,
    storage: str,
    cols: dict[str, Any],
    log_times: npt.NDArray[np.int64],
    convention: ConventionLike,
    quaternion_tol: float | None,
) -> RosMessages:
    """One :class:`RosMessages` of a topic's columns (see :func:`_column_batches`)."""
    conv = single_group(get(convention))
    n = len(cols.get("stamp_sec", ()))
    kw: dict[str, Any] = {}
    for name, width in _FLOAT_WIDTH.items():
        if name in cols:
            arr = cols[name]
            kw[name] = arr if arr.shape == (n, width) else arr.reshape(n, width)
    if "child_frame_id" in cols or mt in ("tf2_msgs/msg/TFMessage",):
        kw["child_frame_id"] = tuple(cols.get("child_frame_id", []))
    if mt == "sensor_msgs/msg/Imu" or n == 0:
        kw.setdefault("position", np.zeros((n, 3)))
    kw.setdefault("orientation_xyzw", np.zeros((n, 4)))
    if n == 0:
        for name in ("pose_covariance", "twist_linear_angular", "twist_covariance"):
            if name not in kw and _needs(mt, name):
                kw[name] = np.zeros((0, _FLOAT_WIDTH[name]))
        if mt == "sensor_msgs/msg/Imu":
            for name in list(_FLOAT_WIDTH)[5:]:
                kw[name] = np.zeros((0, _FLOAT_WIDTH[name]))
        if mt in ("nav_msgs/msg/Odometry", "geometry_msgs/msg/TransformStamped"):
            kw["child_frame_id"] = ()
    if quaternion_tol is not None:
        kw["quaternion_tol"] = float(quaternion_tol)
    try:
        return RosMessages._adopt(  # the arrays are this reader's: frozen, not copied
            msgtype=mt,
            stamp_sec=np.asarray(cols.get("stamp_sec", []), dtype=np.int64),
            stamp_nanosec=np.asarray(cols.get("stamp_nanosec", []), dtype=np.int64),
            frame_id=tuple(cols.get("frame_id", [])),
            seq=np.asarray(cols.get("seq", []), dtype=np.int64),
            message_index=np.asarray(cols.get("message_index", []), dtype=np.int64),
            log_time_ns=np.asarray(log_times, dtype=np.int64),
            topic=topic,
            storage=storage,
            convention=conv,
            **kw,
        )
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def _needs(mt: str, name: str) -> bool:
    if name == "pose_covariance":
        return mt in (
            "geometry_msgs/msg/PoseWithCovariance",
            "geometry_msgs/msg/PoseWithCovarianceStamped",
            "nav_msgs/msg/Odometry",
        )
    return mt == "nav_msgs/msg/Odometry"


@contextmanager
def atomic_output(path: PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` only on success.

    :func:`liebridge.io.atomic.atomic_path` under the bag writers' name: files are replaced
    atomically (a symbolic link is followed, a hard link is never written through); a directory
    (a ROS 2 bag) is renamed into place and ``path`` must not exist yet. A FIFO or a character
    device (``/dev/null``) is never renamed onto: the result is written to the temporary first
    and then copied through. Anything else that is not a regular file is refused. On any
    exception the temporary is removed and ``path`` is untouched. Errors are :class:`BagError`.
    """
    try:
        with atomic_path(path, name=str(path)) as tmp:
            if tmp is not None:
                yield tmp
                return
            with tempfile.TemporaryDirectory(prefix=".liebridge-", suffix=".tmp") as d:
                staged = Path(d) / Path(path).name
                yield staged
                if staged.is_dir():
                    raise ValueError(f"{path}: a bag directory cannot be written to a device")
                with open(staged, "rb") as src, atomic_write(path, "wb") as dst:
                    shutil.copyfileobj(src, dst)
    except ValueError as exc:
        if isinstance(exc, BagError):
            raise
        raise BagError(str(exc)) from None


def _time(types: Any, sec: int, nsec: int) -> Any:
    return types["builtin_interfaces/msg/Time"](sec=int(sec), nanosec=int(nsec))


class _Builder:
    """Message objects of one typestore from the raw fields of a batch."""

    def __init__(self, types: Any, ros1: bool, m: RosMessages) -> None:
        self.t, self.ros1, self.m = types, ros1, m

    def header(self, i: int) -> Any:
        m, t = self.m, self.t
        assert m.seq is not None
        kw: dict[str, Any] = {"seq": int(m.seq[i])} if self.ros1 else {}
        return t["std_msgs/msg/Header"](
            stamp=_time(t, m.stamp_sec[i], m.stamp_nanosec[i]), frame_id=m.frame_id[i], **kw
        )

    def vec3(self, name: str, a: Any) -> Any:
        return self.t[name](x=float(a[0]), y=float(a[1]), z=float(a[2]))

    def quat(self, q: Any) -> Any:
        return self.t["geometry_msgs/msg/Quaternion"](
            x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])
        )

    def pose_cov(self, i: int) -> Any:
        m, t = self.m, self.t
        assert m.pose_covariance is not None
        pose = t["geometry_msgs/msg/Pose"](
            position=self.vec3("geometry_msgs/msg/Point", m.position[i]),
            orientation=self.quat(m.orientation_xyzw[i]),
        )
        return t["geometry_msgs/msg/PoseWithCovariance"](
            pose=pose, covariance=np.array(m.pose_covariance[i])
        )

    def transform(self, i: int) -> Any:
        m, t = self.m, self.t
        assert m.child_frame_id is not None
        tf = t["geometry_msgs/msg/Transform"](
            translation=self.vec3("geometry_msgs/msg/Vector3", m.position[i]),
            rotation=self.quat(m.orientation_xyzw[i]),
        )
        return t["geometry_msgs/msg/TransformStamped"](
            header=self.header(i), child_frame_id=m.child_frame_id[i], transform=tf
        )

    def build(self, rows: range) -> Any:
        m, t = self.m, self.t
        i = rows[0] if len(rows) else -1
        mt = m.msgtype
        if mt == "geometry_msgs/msg/PoseStamped":
            pose = t["geometry_msgs/msg/Pose"](
                position=self.vec3("geometry_msgs/msg/Point", m.position[i]),
                orientation=self.quat(m.orientation_xyzw[i]),
            )
            return t[mt](header=self.header(i), pose=pose)
        if mt == "geometry_msgs/msg/PoseWithCovariance":
            return self.pose_cov(i)
        if mt == "geometry_msgs/msg/PoseWithCovarianceStamped":
            return t[mt](header=self.header(i), pose=self.pose_cov(i))
        if mt == "geometry_msgs/msg/TransformStamped":
            return self.transform(i)
        if mt == "tf2_msgs/msg/TFMessage":
            return t[mt](transforms=[self.transform(j) for j in rows])
        if mt == "nav_msgs/msg/Odometry":
            assert m.twist_linear_angular is not None and m.twist_covariance is not None
            assert m.child_frame_id is not None
            tw = m.twist_linear_angular[i]
            twist = t["geometry_msgs/msg/TwistWithCovariance"](
                twist=t["geometry_msgs/msg/Twist"](
                    linear=self.vec3("geometry_msgs/msg/Vector3", tw[:3]),
                    angular=self.vec3("geometry_msgs/msg/Vector3", tw[3:]),
                ),
                covariance=np.array(m.twist_covariance[i]),
            )
            return t[mt](
                header=self.header(i),
                child_frame_id=m.child_frame_id[i],
                pose=self.pose_cov(i),
                twist=twist,
            )
        assert m.orientation_covariance is not None and m.angular_velocity is not None
        assert m.angular_velocity_covariance is not None and m.linear_acceleration is not None
        assert m.linear_acceleration_covariance is not None
        return t[mt](
            header=self.header(i),
            orientation=self.quat(m.orientation_xyzw[i]),
            orientation_covariance=np.array(m.orientation_covariance[i]),
            angular_velocity=self.vec3("geometry_msgs/msg/Vector3", m.angular_velocity[i]),
            angular_velocity_covariance=np.array(m.angular_velocity_covariance[i]),
            linear_acceleration=self.vec3("geometry_msgs/msg/Vector3", m.linear_acceleration[i]),
            linear_acceleration_covariance=np.array(m.linear_acceleration_covariance[i]),
        )


def _storage_for(path: Path, storage: str | None, msgs: RosMessages) -> str:
    if storage is None:
        storage = msgs.storage
    if storage is None:
        suffix = path.suffix.lower()
        storage = {".bag": "rosbag1", ".mcap": "mcap"}.get(suffix, "sqlite3")
    if storage not in STORAGES:
        raise ValueError(f"storage: {storage!r} is not one of {', '.join(STORAGES)}")
    if storage == "rosbag1" and path.suffix.lower() != ".bag":
        raise ValueError(f"{path}: a ROS 1 bag needs the suffix .bag (readers go by it)")
    if storage != "rosbag1" and path.suffix.lower() == ".bag":
        raise ValueError(f"{path}: the suffix .bag is for ROS 1 bags, not storage {storage!r}")
    return storage


#: A ROS graph resource name as ROS 1 and ROS 2 accept it for a topic: optional leading ``/``
#: or ``~``, tokens of letters, digits and underscores (not starting with a digit) separated by
#: single slashes, substitutions ``{…}`` allowed; no trailing slash (ROS 2 ``rcl``
#: ``validate_topic_name``; ROS 1 ``ros::names::validate``).
_TOPIC = re.compile(r"[/~]?(?:[A-Za-z_{][A-Za-z0-9_{}]*)(?:/[A-Za-z_{][A-Za-z0-9_{}]*)*")


def check_topic(topic: Any, name: str = "topic") -> str:
    """Return ``topic`` if it is a valid ROS topic name; else a ``ValueError`` naming it.

    An empty name (``--out-topic ''``) is written by rosbags without complaint and gives a bag
    that no reader opens; a name with spaces, ``//`` or a trailing ``/`` is refused by ROS.
    """
    if not isinstance(topic, str):
        raise TypeError(f"{name}: expected a topic name (str), got {type(topic).__name__}")
    if not _TOPIC.fullmatch(topic):
        raise ValueError(
            f"{name}: {topic!r} is not a ROS topic name (expected e.g. '/liebridge/poses': "
            "letters, digits, '_' in '/'-separated tokens, not starting with a digit)"
        )
    return topic


def write_messages(
    bag: PathLike,
    topic: str,
    msgs: RosMessages,
    *,
    storage: str | None = None,
    progress: Progress | None = None,
) -> Path:
    """Write ``msgs`` as the only topic of a new bag ``bag``.

    Parameters
    ----------
    bag : str or os.PathLike
        Output: a ROS 1 ``.bag`` file; for ROS 2, a bag directory, or — for mcap storage and a
        path ending in ``.mcap`` — a bare ``.mcap`` file (what ``ros2 bag record -s mcap`` puts in
        its directory; rosbags, Foxglove and ``ros2 bag`` read it).
    topic : str
    msgs : RosMessages
        E.g. what :func:`read_messages` returned (its raw fields are written, so a round trip is
        bit for bit) or :func:`liebridge.ros.from_poses` built.
    storage : {"rosbag1", "sqlite3", "mcap"}, optional
        Default: the format ``msgs`` was read from; else from the path (``.bag`` → ROS 1,
        ``.mcap`` → mcap, otherwise a ROS 2 sqlite3 bag).
    progress : callable(done, total), optional

    Returns
    -------
    pathlib.Path
        The bag written. Nothing is left at ``bag`` if writing fails.
    """
    if not isinstance(msgs, RosMessages):
        raise TypeError(f"msgs: expected RosMessages, got {type(msgs).__name__}")
    check_topic(topic)
    if msgs.msgtype == _PATH:
        raise ValueError(
            "msgs: nav_msgs/Path is read, not written (one message would have to invent the "
            "path's own header); write the poses as geometry_msgs/msg/PoseStamped"
        )
    rb = require_rosbags()
    path = Path(bag)
    kind = _storage_for(path, storage, msgs)
    ts_name = rb.typesys.Stores.ROS1_NOETIC if kind == "rosbag1" else rb.typesys.Stores.ROS2_HUMBLE
    typestore = rb.typesys.get_typestore(ts_name)
    if kind == "rosbag1":  # noetic's store has no tf2_msgs; its definition (md5 94810edd...)
        typestore.register(
            rb.typesys.get_types_from_msg(
                "geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"
            )
        )
    builder = _Builder(typestore.types, kind == "rosbag1", msgs)
    mt = msgs.msgtype
    assert msgs.message_index is not None and msgs.log_time_ns is not None
    bounds = np.r_[0, np.flatnonzero(np.diff(msgs.message_index)) + 1, len(msgs)]
    total = len(msgs.log_time_ns)
    if total != len(bounds) - 1 and len(msgs):
        raise ValueError(f"msgs: {total} receive times for {len(bounds) - 1} messages")

    log_time_ns = msgs.log_time_ns

    def records() -> Iterator[tuple[int, Any]]:
        for k in range(total):
            rows = range(int(bounds[k]), int(bounds[k + 1])) if len(msgs) else range(0)
            yield int(log_time_ns[k]), builder.build(rows)
            if progress is not None and (k + 1) % _PROGRESS_EVERY == 0:
                progress(k + 1, total)

    with atomic_output(path) as tmp:
        if kind == "rosbag1":
            with rb.rosbag1.Writer(tmp) as w:
                conn = w.add_connection(topic, mt, typestore=typestore)
                for t_ns, msg in records():
                    w.write(conn, t_ns, typestore.serialize_ros1(msg, mt))
        else:
            bare = kind == "mcap" and path.suffix.lower() == ".mcap"
            bagdir = tmp.parent / (tmp.stem if bare else tmp.name)
            plugin = (
                rb.rosbag2.StoragePlugin.MCAP
                if kind == "mcap"
                else rb.rosbag2.StoragePlugin.SQLITE3
            )
            with rb.rosbag2.Writer(bagdir, version=9, storage_plugin=plugin) as w:
                conn = w.add_connection(topic, mt, typestore=typestore)
                for t_ns, msg in records():
                    w.write(conn, t_ns, typestore.serialize_cdr(msg, mt))
            if bare:
                os.replace(bagdir / f"{bagdir.name}.mcap", tmp)
        if progress is not None:
            progress(total, total)
    return path


def write_tum(path: PathLike, msgs: RosMessages | Iterable[RosMessages]) -> None:
    """Write ``msgs``'s poses as a TUM file: ``stamp x y z qx qy qz qw`` per line.

    The stamp is written exactly as decimal seconds with nine decimals from the integer
    ``sec``/``nanosec`` (sign-correct: −1.5 s is ``-1.500000000``;
    :func:`liebridge.io.trajectory.stamp_text`); position and quaternion with ``repr`` (the
    stored doubles; the quaternion's sign by the TUM writers' one rule, first ``w ≥ 0`` then
    hemisphere continuity). The header comment names the frames. Written by the one TUM writer,
    :func:`liebridge.io.trajectory.write_tum_chunks`, through the one atomic-write helper.

    ``msgs`` may be an iterable of batches (:func:`iter_messages`): they are written as they
    come, so memory stays one batch. Every batch must hold the same pair of frames (one
    trajectory); otherwise a ``BagError`` names the message, and nothing is left at ``path``.
    """
    batches = iter((msgs,)) if isinstance(msgs, RosMessages) else iter(msgs)
    first: RosMessages | None = None
    for m in batches:  # the first batch with messages names the frames of the header
        if not isinstance(m, RosMessages):
            raise TypeError(f"msgs: expected RosMessages, got {type(m).__name__}")
        first = m
        if len(m):
            break
    if first is None:
        raise ValueError("msgs: no batch of messages given")
    frames = first.trajectory_frames() if len(first) else ("", None)
    parent, child = frames[0], frames[1] or "body"

    def chunks() -> Iterator[tuple[list[str], FloatArray, FloatArray]]:
        done = 0
        for m in itertools.chain((first,), batches):
            if not isinstance(m, RosMessages):
                raise TypeError(f"msgs: expected RosMessages, got {type(m).__name__}")
            if len(m) and done and m.trajectory_frames() != frames:
                raise ValueError(
                    f"topic {m.topic}, message {done}: frames {m.trajectory_frames()} differ "
                    f"from the first message's {frames}; the topic holds poses in several "
                    "frames, not one trajectory"
                )
            yield (
                stamp_text(m.stamp_sec, m.stamp_nanosec),
                np.asarray(m.position, dtype=np.float64).reshape(-1, 3),
                np.asarray(m.orientation_xyzw, dtype=np.float64).reshape(-1, 4),
            )
            done += len(m)

    try:
        write_tum_chunks(
            path, chunks(), comment=f"T_{parent or 'parent'}_{child}; topic {first.topic}"
        )
    except ValueError as exc:
        raise BagError(str(exc)) from None
