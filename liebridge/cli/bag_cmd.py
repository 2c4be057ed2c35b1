"""``liebridge bag``: ROS 1 / ROS 2 bags without ROS (info, export, write-marginals).

``bag info BAG`` lists the topics and which ones liebridge reads; ``bag export BAG --topic T
--format tum|g2o|npz OUT`` writes one trajectory topic as a TUM file (exact stamps, ``repr``
floats), a g2o odometry chain (information over GTSAM's tangent, converted from the messages' ROS
covariances — never copied) or an ``.npz`` of arrays with the covariance in ``--convention``;
``bag write-marginals IN OUT`` optimizes a pose graph (a g2o file, or a bag trajectory topic as an
odometry chain) with GTSAM and writes the estimates with their marginal covariances, converted
to ROS's ``PoseWithCovariance`` convention, as messages into a new bag. Bad input is one line.
"""

from __future__ import annotations

import argparse
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from ..frames.transform import frame_name
from ._common import (
    CLIError,
    check_connected,
    check_output_path,
    convention_arg,
    deprecated_alias,
    one_line,
    say,
)

__all__ = ["add_parser"]

_MSGTYPES = {
    "pose": "geometry_msgs/msg/PoseWithCovarianceStamped",
    "odometry": "nav_msgs/msg/Odometry",
}


def _ros() -> Any:
    try:
        from .. import ros

        ros.require_rosbags()
    except ImportError as exc:
        raise CLIError(str(exc)) from None
    return ros


def _progress(what: str) -> Any:
    def report(done: int, total: int) -> None:
        if total >= 2000:
            say(f"{what}: {done}/{total} messages")

    return report


def _info(args: argparse.Namespace) -> int:
    ros = _ros()
    storage, start, end, topics = ros.bag_info(args.bag)
    print(
        f"{args.bag}: {storage}, {sum(t.count for t in topics)} messages, "
        f"{end - start:.3f} s ({start!r} .. {end!r})"
    )
    width = max([len(t.topic) for t in topics] + [5])
    for t in topics:
        mark = "reads" if t.supported else "-"
        print(f"  {t.topic.ljust(width)}  {t.count:8d}  {t.msgtype}  [{mark}]")
    return 0


def _read(ros: Any, bag: str, topic: str, convention: Any, path_message: Any = None) -> Any:
    try:
        return ros.read_messages(
            bag,
            topic,
            convention=convention,
            progress=_progress(f"read {topic}"),
            path_message=path_message,
        )
    except ValueError as exc:
        raise CLIError(_flags(one_line(str(exc)))) from None


def _flags(text: str) -> str:
    """Name the CLI flag where a library message names the ``increment`` argument."""
    text = re.sub(r"^msgs: ", "", text)  # the Python argument's name, not the command's
    text = text.replace("path_message", "--path-message")
    return re.sub(r"\bincrement '(\w+)'", r"--increment \1", text)


def _default_increment(msgtype: str) -> str:
    """``--increment`` when not given: growing covariances for Odometry, else independent."""
    return "difference" if msgtype == "nav_msgs/msg/Odometry" else "independent"


def _export_g2o(ros: Any, args: argparse.Namespace, m: Any, out: Path) -> None:
    """Write an odometry chain: one edge per pair of consecutive messages (``ros.graph``).

    Policy for the increment information: the inverse of the increment covariance where it has
    full rank; its pseudo-inverse, with the rank printed, where it is rank-deficient (a planar
    covariance, zero in z, roll and pitch); refused, naming the message, where it is all zero
    (ROS publishers leave an unknown covariance zero: there is no information to write).
    """
    from ..io import g2o as g2o_io

    if m.cov is None and args.increment != "twist":
        raise CLIError(
            f"--topic {args.topic}: {m.msgtype} carries no covariance, and a g2o edge needs "
            "one (topics of PoseWithCovarianceStamped or Odometry; or export with --format tum)"
        )
    increment = args.increment or _default_increment(m.msgtype)
    try:
        Z, cz = ros.increment_covariances(m, increment)
        info, rank = ros.increment_information(cz)
    except ValueError as exc:
        raise CLIError(f"--topic {args.topic}: {_flags(one_line(str(exc)))}") from None
    if (rank == 0).any():
        k = int(np.argmax(rank == 0))
        odom = m.msgtype == "nav_msgs/msg/Odometry" and increment != "twist"
        which = "twist" if increment == "twist" else "pose"
        raise CLIError(
            f"--topic {args.topic}: the covariance of the increment from message {k} to {k + 1} "
            f"is all zero, singular ({int((rank == 0).sum())} of {len(rank)} increments; the "
            f"messages' {which} covariances are zero, ROS's 'unknown'): no information to write "
            f"as a g2o edge (try {'--increment twist' if odom else '--format tum'})"
        )
    n = len(m)
    g = g2o_io.G2OGraph.from_matrices(
        np.arange(n), m.T, np.c_[np.arange(n - 1), np.arange(1, n)], Z, info
    )
    with ros.atomic_output(out) as tmp:
        g2o_io.write(tmp, g)
    deficient = int((rank < 6).sum())
    note = (
        f"; {deficient} rank-deficient (rank {int(rank.min())}..{int(rank.max())}: "
        "pseudo-inverse, zero information where the messages have no variance)"
        if deficient
        else ""
    )
    print(
        f"wrote {out}: {n} vertices, {n - 1} odometry edges (--increment {increment}, "
        f"from the messages' ROS covariance{note})"
    )


def _export(args: argparse.Namespace) -> int:
    ros = _ros()
    conv = convention_arg(args.convention, "--convention")
    suffixes = {"tum": None, "g2o": (".g2o", ".txt"), "npz": (".npz",)}[args.to]
    out = check_output_path(args.out, "OUT", suffixes, inputs=[args.bag])
    if args.to == "tum":  # streamed: memory is one batch of messages, whatever the bag's size
        seen: list[Any] = []

        def batches() -> Any:
            for m in ros.iter_messages(
                args.bag,
                args.topic,
                convention=conv,
                progress=_progress(f"read {args.topic}"),
                path_message=args.path_message,
            ):
                seen.append((len(m), m.trajectory_frames() if len(m) else None))
                yield m

        try:
            ros.write_tum(out, batches())
        except ValueError as exc:
            raise CLIError(_flags(one_line(str(exc)))) from None
        n = sum(k for k, _ in seen)
        frames = next((f for _, f in seen if f is not None), ("", None))
        print(
            f"wrote {out}: {n} poses T_{frames[0] if n else ''}_"
            f"{(frames[1] or 'body') if n else ''} (TUM, exact stamps, repr floats)"
        )
        return 0
    m = _read(ros, args.bag, args.topic, conv, args.path_message)
    if args.to == "g2o":
        _export_g2o(ros, args, m, out)
        return 0
    arrays: dict[str, Any] = {
        "stamps": m.stamps,
        "stamp_sec": m.stamp_sec,
        "stamp_nanosec": m.stamp_nanosec,
        "T": m.T,
        "frame_id": np.array(m.frame_id, dtype=str),
        "convention": np.array(conv.name),
        "msgtype": np.array(m.msgtype),
    }
    for name in ("cov", "twist", "twist_cov", "child_frame_id"):
        val = getattr(m, name)
        if val is not None:
            arrays[name] = np.array(val, dtype=str) if name == "child_frame_id" else val
    with ros.atomic_output(out) as tmp, open(tmp, "wb") as fh:
        np.savez(fh, **arrays)
    print(f"wrote {out}: {len(m)} poses; cov in {conv.name!r} ({', '.join(sorted(arrays))})")
    return 0


def _write_marginals(args: argparse.Namespace) -> int:
    import gtsam

    ros = _ros()
    inp = Path(args.input)
    is_g2o = inp.is_file() and inp.suffix.lower() in (".g2o", ".txt")
    out = check_output_path(args.output, "OUT", inputs=[args.input, getattr(args, "bag", None)])
    ros.check_topic(args.out_topic, "--out-topic")  # before the optimization, not after
    if not (math.isfinite(args.prior_sigma) and args.prior_sigma > 0.0):
        raise CLIError(f"--prior-sigma: expected a finite number > 0, got {args.prior_sigma!r}")
    if not (math.isfinite(args.period) and args.period > 0.0):
        raise CLIError(f"--period: expected a finite number of seconds > 0, got {args.period!r}")
    if is_g2o:
        from ..io import g2o as g2o_io

        g = g2o_io.read(inp)
        if g.vertex_ids.shape[0] == 0:
            raise CLIError(f"{inp}: no 3D pose graph in it (no VERTEX_SE3:QUAT line)")
        keys = [int(k) for k in g.vertex_ids]
        k0 = keys[0] if not g.fixed else int(g.fixed[0])
        if k0 not in set(keys):
            raise CLIError(f"{inp}: FIX {k0} names no vertex of the graph")
        check_connected(keys, g.edges.tolist(), [k0])
        last = (len(keys) - 1) * args.period
        if last > ros.messages.STAMP_MAX:
            raise CLIError(
                f"--period: {len(keys)} vertices {args.period!r} s apart end at {last!r} s, "
                f"beyond the {ros.messages.STAMP_MAX} s a ROS time holds"
            )
        graph, initial = g.to_gtsam(prior=None)  # the prior of --prior-sigma follows
        graph.add(
            gtsam.PriorFactorPose3(
                k0, initial.atPose3(k0), gtsam.noiseModel.Isotropic.Sigma(6, args.prior_sigma)
            )
        )
        stamps = np.arange(len(keys), dtype=np.float64) * args.period
        frame = "map" if args.frame_id is None else frame_name(args.frame_id, "--frame-id")
        say(
            f"read {inp}: {len(keys)} poses, {g.edges.shape[0]} edges; prior sigma "
            f"{args.prior_sigma} on pose {k0}"
        )
    else:
        if args.topic is None:
            raise CLIError("--topic: required when IN is a bag (the trajectory topic to optimize)")
        m = _read(ros, args.input, args.topic, "ros", args.path_message)
        graph = gtsam.NonlinearFactorGraph()
        try:
            _, cz = ros.increment_covariances(m, args.increment)
            rank = ros.increment_information(cz)[1]
            if (rank < 6).any():
                k = int(np.argmax(rank < 6))
                raise CLIError(
                    f"--topic {args.topic}: the covariance of the increment from message {k} to "
                    f"{k + 1} has rank {int(rank[k])} of 6 ({int((rank < 6).sum())} of "
                    f"{len(rank)} increments; zero or planar message covariances): GTSAM's "
                    "marginals need every edge of full rank; 'bag export --format g2o' writes it "
                    "with its rank-deficient information"
                )
            factors = ros.odometry_factors(m, increment=args.increment)
        except ValueError as exc:
            raise CLIError(f"--topic {args.topic}: {_flags(one_line(str(exc)))}") from None
        for f in factors:
            graph.add(f)
        keys = list(range(len(m)))
        initial = gtsam.Values()
        for k in keys:
            initial.insert(k, gtsam.Pose3(m.T[k]))
        stamps = m.stamps
        frame = args.frame_id or (m.trajectory_frames()[0] or "map")
        frame = frame_name(frame, "--frame-id")
        say(f"read {args.input} {args.topic}: {len(m)} poses as an odometry chain")
    params = gtsam.LevenbergMarquardtParams()
    result = gtsam.LevenbergMarquardtOptimizer(graph, initial, params).optimize()
    say(
        f"optimized: error {graph.error(initial):.6g} -> {graph.error(result):.6g}; "
        f"marginals of {len(keys)} poses"
    )
    msgs = ros.messages_from_gtsam(
        graph,
        result,
        keys,
        stamps=stamps,
        frame_id=frame,
        msgtype=_MSGTYPES[args.msgtype],
        child_frame_id=args.child_frame_id,
    )
    ros.write_messages(
        out,
        args.out_topic,
        msgs,
        storage=args.storage,
        progress=_progress(f"write {args.out_topic}"),
    )
    print(
        f"wrote {out}: {len(msgs)} {msgs.msgtype} on {args.out_topic} in frame {frame!r}, "
        f"covariance = GTSAM marginals converted to ROS (x, y, z, rotX, rotY, rotZ)"
    )
    return 0


def _path_message_option(q: argparse.ArgumentParser) -> None:
    q.add_argument(
        "--path-message",
        type=int,
        default=None,
        metavar="INDEX",
        help="nav_msgs/Path topics (each message a whole trajectory): the message to read "
        "(default -1, the last; 0 the first)",
    )


def add_parser(sub: Any) -> None:
    """Register ``liebridge bag`` and its subcommands."""
    p = sub.add_parser(
        "bag",
        help="ROS 1/2 bags without ROS: info, export a topic, write GTSAM marginals as messages",
        description="ROS 1 (.bag) and ROS 2 (sqlite3, mcap) bags via the rosbags library "
        '(pip install ".[ros]" from the checkout).',
    )
    bsub = p.add_subparsers(dest="bag_command", metavar="SUBCOMMAND")
    i = bsub.add_parser("info", help="topics, types, counts; which topics liebridge reads")
    i.add_argument("bag", metavar="BAG")
    i.set_defaults(func=_info)

    e = bsub.add_parser(
        "export",
        help="one pose topic as TUM, g2o or npz",
        description="Export a PoseStamped, PoseWithCovariance(Stamped), Odometry, "
        "TransformStamped, TFMessage or nav_msgs/Path (one message: --path-message) topic. "
        "tum: 'sec.nanosec x y z qx qy qz qw' exactly as stored; g2o (topics with "
        "covariances): an odometry chain whose edge information is the increment covariance's "
        "(pseudo-)inverse in GTSAM's tangent; "
        "npz: stamps, T (N,4,4), cov (N,6,6) in --convention, twist/twist_cov (child frame).",
    )
    e.add_argument("bag", metavar="BAG")
    e.add_argument("--topic", required=True)
    fmt = e.add_argument(
        "--format", dest="to", required=True, choices=("tum", "g2o", "npz"), help="what OUT is"
    )
    deprecated_alias(e, fmt, "--to")
    e.add_argument("out", metavar="OUT")
    e.add_argument(
        "--convention",
        default="ros",
        help="covariance convention of the npz 'cov' (default ros: as stored)",
    )
    e.add_argument(
        "--increment",
        default=None,
        choices=("difference", "twist", "independent"),
        help="g2o: increment covariance from growing pose covariances (difference; default for "
        "Odometry), the Odometry twist covariance × dt² (twist), or independent absolute "
        "covariances propagated to first order (independent; default for "
        "PoseWithCovariance(Stamped), e.g. /amcl_pose). A rank-deficient increment "
        "covariance (planar: zero z, roll, pitch) is written as its pseudo-inverse",
    )
    _path_message_option(e)
    e.set_defaults(func=_export)

    w = bsub.add_parser(
        "write-marginals",
        help="optimize a pose graph with GTSAM, write poses + marginals as messages to a bag",
        description="IN is a g2o file (.g2o/.txt; a prior fixes its first vertex) or a bag with "
        "--topic (a trajectory topic read as an odometry chain with a prior on its first pose). "
        "OUT is a new bag (.bag: ROS 1; .mcap: mcap; otherwise a ROS 2 sqlite3 directory) with "
        "one message per pose, its covariance the GTSAM marginal converted to ROS's convention.",
    )
    w.add_argument("input", metavar="IN")
    w.add_argument("output", metavar="OUT")
    w.add_argument("--topic", help="trajectory topic of IN when IN is a bag")
    w.add_argument("--out-topic", default="/liebridge/poses")
    w.add_argument(
        "--msgtype",
        choices=tuple(_MSGTYPES),
        default="pose",
        help="pose: PoseWithCovarianceStamped (default); odometry: nav_msgs/Odometry "
        "with a zero twist",
    )
    w.add_argument("--frame-id", help="parent frame (default: the input's, or 'map')")
    w.add_argument("--child-frame-id", default=None, help="Odometry child frame (base_link)")
    w.add_argument("--storage", choices=("rosbag1", "sqlite3", "mcap"), default=None)
    w.add_argument(
        "--increment", default="difference", choices=("difference", "twist", "independent")
    )
    _path_message_option(w)
    w.add_argument(
        "--prior-sigma",
        type=float,
        default=1e-6,
        help="g2o input: sigma of the prior on the first vertex",
    )
    w.add_argument(
        "--period",
        type=float,
        default=1.0,
        help="g2o input: seconds between the stamps of consecutive vertices",
    )
    w.set_defaults(func=_write_marginals)
