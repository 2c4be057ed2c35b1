"""``liebridge traj ape|rpe|nees REF EST``: evo's APE/RPE, and NEES with covariances.

The pipeline is evo's: read both files (TUM, KITTI or EuRoC, detected; the quaternion order per
file with ``--ref-quat-order``/``--est-quat-order``, of both with ``--quat-order``, a header that
names the order winning over a flag that contradicts it with an error; imperfect real files by
one policy, ``--duplicates`` for repeated stamps and ``--quat-tolerance`` for quaternions off
unit), associate by timestamp (``--max-diff`` 0.01 s, ``--offset`` 0 s), align the estimate to
the reference (``--align``: ``none`` by default as evo, ``se3``, ``sim3``, ``4dof``), then compute
the metric. ``nees`` also moves the estimate's covariances (``--cov`` ``(N, 6, 6)`` ``.npy``, one
per pose of EST, in ``--convention``) under the alignment, as that convention requires.
Without ``--cov``, ``nees`` takes the covariances EST carries: a bag topic's
``PoseWithCovarianceStamped`` / ``Odometry`` covariances, or the ``.npz`` of ``bag export --format
npz``. A ``nav_msgs/Path`` topic is one message (``--path-message``, default the last).
``--format json`` prints one JSON object on stdout (``rmse mean median std min max`` and more;
``anees`` for ``nees``); ``--plot`` writes the trajectories, the errors over time and, for
``nees``, the NEES against its χ² bounds. Every input error is one line on stderr.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validate import FloatArray
from ._common import (
    CLIError,
    check_output_path,
    convention_arg,
    deprecated_alias,
    need_matplotlib,
    npy_argument,
    one_line,
    save_figure,
    say,
)


def _inputs(args: argparse.Namespace) -> list[str | None]:
    """List the files a ``traj`` command reads (REF, EST, ``--cov``): never overwritten."""
    return [args.ref, args.est, getattr(args, "cov", None)]


__all__ = ["add_parser"]


@dataclass(frozen=True)
class _Prepared:
    t_ref: FloatArray
    T_ref: FloatArray  # associated
    T_est: FloatArray  # associated, before alignment
    T_aligned: FloatArray
    cov_est: FloatArray | None  # associated, before alignment, in the estimator's convention
    alignment: Any
    n_ref: int
    n_est: int
    resampled: str | None


def _read_topic(
    path: str,
    topic: str,
    what: str,
    path_message: int | None = None,
    cov_convention: Any = None,
    duplicates: str = "first",
) -> tuple[FloatArray, FloatArray, FloatArray | None, str]:
    """Stamps, poses, covariances and type of a bag topic (PoseStamped, Odometry, Path, TF...).

    Streamed: only stamps and poses (136 B a message) are kept — and, with ``cov_convention``,
    the pose covariances in that convention (288 B more), None for a type without them. Repeated
    stamps follow the file readers' policy (``duplicates``).
    """
    try:
        from ..ros import iter_messages
    except ImportError as exc:  # the 'ros' extra
        raise CLIError(f"{what}: {exc}") from None
    stamps: list[FloatArray] = []
    poses: list[FloatArray] = []
    covs: list[FloatArray] | None = [] if cov_convention is not None else None
    frames = None
    msgtype = ""
    try:
        for msgs in iter_messages(
            path, topic, convention=cov_convention or "ros", path_message=path_message
        ):
            msgtype = msgs.msgtype
            here = msgs.trajectory_frames()  # frame_id alternating map/odom is not one
            if len(msgs) and frames is not None and here != frames:
                raise ValueError(
                    f"topic {topic}: frames {here} differ from the first message's {frames}; "
                    "the topic holds poses in several frames, not one trajectory"
                )
            frames = frames or (here if len(msgs) else None)
            stamps.append(np.asarray(msgs.stamps, dtype=np.float64))
            poses.append(np.asarray(msgs.T, dtype=np.float64))
            if covs is not None and msgs.cov is not None:
                covs.append(np.array(msgs.cov, dtype=np.float64))
    except (ValueError, OSError, ImportError) as exc:
        text = one_line(str(exc)).replace("path_message", "--path-message")
        raise CLIError(f"{what}: {text}") from None
    t, T = np.concatenate(stamps), np.concatenate(poses)
    cov = np.concatenate(covs) if covs else None
    keep = _one_per_stamp(t, f"{path}:{topic}", what, duplicates)
    if keep is not None:
        t, T, cov = t[keep], T[keep], (cov[keep] if cov is not None else None)
    return t, T, cov, msgtype


#: Arrays of the ``.npz`` that ``liebridge bag export --format npz`` writes, read back here.
_NPZ_NEEDS = ("stamps", "T")


def _read_npz(path: str, what: str) -> tuple[FloatArray, FloatArray, FloatArray | None, str]:
    """Stamps, poses, covariances and their convention from ``bag export --format npz``'s file."""
    try:
        with np.load(path, allow_pickle=False) as d:
            missing = [k for k in _NPZ_NEEDS if k not in d.files]
            if missing:
                raise CLIError(
                    f"{what}: {path} has no {', '.join(missing)} array (an .npz as "
                    "'liebridge bag export --format npz' writes: stamps, T, cov, convention)"
                )
            t = np.asarray(d["stamps"])
            T = np.asarray(d["T"])
            cov = np.asarray(d["cov"]) if "cov" in d.files else None
            conv = str(d["convention"]) if "convention" in d.files else "ros"
    except CLIError:
        raise
    except (ValueError, OSError, KeyError, EOFError) as exc:
        raise CLIError(f"{what}: {path}: not a readable .npz ({one_line(str(exc))})") from None
    n = t.shape[0] if t.ndim == 1 else -1
    for name, a, shape in (("stamps", t, (n,)), ("T", T, (n, 4, 4)), ("cov", cov, (n, 6, 6))):
        if a is None:
            continue
        if a.shape != shape or not np.issubdtype(a.dtype, np.floating):
            raise CLIError(
                f"{what}: {path}: array {name!r} has shape {a.shape} and dtype {a.dtype}, "
                f"expected float {shape if n >= 0 else '(N,)'}"
            )
        bad = ~np.isfinite(a.reshape(max(n, 0), -1)).all(axis=-1)
        if bad.any():
            raise CLIError(
                f"{what}: {path}: array {name!r} is not finite at index {int(np.argmax(bad))} "
                f"({int(bad.sum())} of {n})"
            )
    return t.astype(np.float64), T.astype(np.float64), cov, conv


def _one_per_stamp(t: FloatArray, source: str, what: str, duplicates: str) -> Any:
    """Apply the file readers' repeated-stamp policy to a bag topic: indices kept, or None."""
    from ..io import sanity

    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", sanity.ImperfectFileWarning)
            keep = sanity.repeated_stamps(t, duplicates, source=source)
    except sanity.RepeatedStampError as exc:
        raise CLIError(
            f"{what}: {exc.detail}; --duplicates first or last keeps one of each"
        ) from None
    for w in caught:
        say(f"liebridge traj: warning: {what}: {one_line(str(w.message))}")
    return None if keep.size == t.size else keep


def _read(
    path: str,
    fmt: str,
    quat_order: str | None,
    what: str,
    topic: str | None = None,
    *,
    order_flag: str = "--quat-order",
    duplicates: str = "first",
    quat_tolerance: float = 1e-3,
    path_message: int | None = None,
) -> tuple[FloatArray, FloatArray]:
    from ..io import sanity, trajfile

    if topic is not None:
        if quat_order is not None and order_flag != "--quat-order":
            raise CLIError(
                f"{order_flag}: {what} is a bag topic; its messages name their quaternion fields"
            )
        return _read_topic(path, topic, what, path_message, duplicates=duplicates)[:2]
    if path.lower().endswith(".npz"):  # what 'bag export --format npz' writes
        return _read_npz(path, what)[:2]
    if quat_order is not None and order_flag != "--quat-order":
        try:
            kind = trajfile.detect_format(path) if fmt == "auto" else fmt
        except (ValueError, OSError):
            kind = fmt  # the reader below names the fault
        if kind == "kitti":
            raise CLIError(
                f"{order_flag}: {what} is a KITTI file (rotation matrices, no quaternions)"
            )
    hint = {
        sanity.QuaternionOrderConflictError: (
            "the header wins: drop --quat-order (it sets both files) and give the other file's "
            "order alone with --ref-quat-order or --est-quat-order"
            if order_flag == "--quat-order"
            else f"the header wins: drop {order_flag}"
        ),
        sanity.RepeatedStampError: "--duplicates first or last keeps one of each",
        sanity.QuaternionNormError: "--quat-tolerance accepts and normalises more",
    }
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", sanity.QuaternionOrderWarning)
            warnings.simplefilter("always", sanity.ImperfectFileWarning)
            out = trajfile.read_trajectory(
                path,
                fmt,
                quat_order=quat_order,
                duplicates=duplicates,
                quat_tolerance=quat_tolerance,
            )
    except (
        sanity.QuaternionOrderConflictError,
        sanity.RepeatedStampError,
        sanity.QuaternionNormError,
    ) as exc:
        raise CLIError(f"{what}: {exc.detail}; {hint[type(exc)]}") from None
    except (ValueError, OSError) as exc:
        raise CLIError(f"{what}: {exc}") from None
    for w in caught:  # one line each on stderr, never Python's two-line warning format
        say(f"liebridge traj: warning: {what}: {one_line(str(w.message))}")
    return out.stamps, out.T


def _order_read(path: str, fmt: str, order: str | None) -> str | None:
    """Return the quaternion order a file was read in (None: KITTI, no quaternions)."""
    from ..io import trajectory, trajfile

    kind = trajfile.detect_format(path) if fmt == "auto" else fmt
    if kind == "kitti":
        return None
    if kind == "euroc":
        return "wxyz"
    return order or trajectory.tum_header_order(path) or "xyzw"


def _check_pair_order(T_ref: FloatArray, T_est: FloatArray, est_order: str) -> None:
    """Warn when EST's rotations match REF's only in the other quaternion order."""
    from ..io import sanity

    with np.errstate(all="ignore"):
        try:
            ev = sanity.relative_order_evidence(T_ref[:, :3, :3], T_est[:, :3, :3], est_order)
        except ValueError:
            return
    if ev.likely_order is None or ev.likely_order == est_order:
        return
    say(
        f"liebridge traj: warning: REF and EST disagree on the quaternion order: EST read as "
        f"{est_order} matches REF's rotations only when read as {ev.likely_order} "
        f"({ev.confidence} evidence: {ev.reason}); if EST is {ev.likely_order}, pass "
        f"--est-quat-order {ev.likely_order} (if REF is the one misread, --ref-quat-order)"
    )


def _prepare(
    args: argparse.Namespace,
    cov: FloatArray | None = None,
    conv: Any = None,
    est: tuple[FloatArray, FloatArray] | None = None,
) -> _Prepared:
    from .. import traj

    tol = args.quat_tolerance
    if not (np.isfinite(tol) and tol >= 0):
        raise CLIError(f"--quat-tolerance: expected a finite number ≥ 0, got {tol:g}")
    pm = getattr(args, "path_message", None)
    files = []
    read_as: list[str | None] = []
    for what, path, fmt, topic, own, flag in (
        ("REF", args.ref, args.ref_format, args.ref_topic, args.ref_quat_order, "--ref-quat-order"),
        ("EST", args.est, args.est_format, args.est_topic, args.est_quat_order, "--est-quat-order"),
    ):
        order, used = (own, flag) if own is not None else (args.quat_order, "--quat-order")
        if what == "EST" and est is not None:  # read already (with its covariances)
            files.append(est)
            read_as.append(None)
            continue
        files.append(
            _read(
                path,
                fmt,
                order,
                what,
                topic,
                order_flag=used,
                duplicates=args.duplicates,
                quat_tolerance=tol,
                path_message=pm,
            )
        )
        read_as.append(None if topic is not None else _order_read(path, fmt, order))
    (t_ref, T_ref), (t_est, T_est) = files
    if cov is not None and cov.shape[0] != len(t_est):
        raise CLIError(
            f"--cov: {cov.shape[0]} covariances for {len(t_est)} poses of EST "
            f"(one per pose, in file order)"
        )
    try:
        traj.check_timestamps(t_ref, "REF timestamps")
        traj.check_timestamps(t_est, "EST timestamps")
        s = traj.synchronize(
            t_ref,
            T_ref,
            t_est,
            T_est,
            max_diff=args.max_diff,
            offset=args.offset,
            interpolate=args.interpolate,
            cov_est=cov,
            convention=conv,
        )
    except ValueError as exc:
        raise CLIError(str(exc)) from None
    if read_as[0] is not None and read_as[1] is not None:
        _check_pair_order(s.T_ref, s.T_est, read_as[1])
    try:
        A = traj.align(s.T_ref, s.T_est, args.align)
    except ValueError as exc:
        raise CLIError(f"--align {args.align}: {exc}") from None
    return _Prepared(
        s.t,
        s.T_ref,
        s.T_est,
        A.apply(s.T_est),
        s.cov_est,
        A,
        len(t_ref),
        len(t_est),
        s.resampled,
    )


def _stats_dict(errors: FloatArray) -> dict[str, float]:
    from ..traj import statistics

    return statistics(errors).as_dict()


def _emit(args: argparse.Namespace, result: dict[str, Any], unit: str) -> None:
    if args.format == "json":
        json.dump(result, sys.stdout, allow_nan=False)
        sys.stdout.write("\n")
        return
    head = {k: result[k] for k in ("metric", "pose_relation", "align") if k in result}
    print(" ".join(f"{k}={v}" for k, v in head.items()) + f" (n={result['n']})")
    for k in ("rmse", "mean", "median", "std", "min", "max"):
        print(f"  {k:<7}{result[k]:.6g} {unit}")
    for k in ("anees", "anees_lower", "anees_upper", "consistent", "fraction_inside"):
        if k in result:
            print(f"  {k:<16}{result[k]}")


def _unit(relation: str) -> str:
    return {"trans_part": "m", "point_distance": "m", "angle_deg": "deg", "angle_rad": "rad"}.get(
        relation, ""
    )


def _alignment_info(p: _Prepared) -> dict[str, Any]:
    A = p.alignment
    return {
        "align": A.kind,
        "scale": A.scale,
        "alignment_sim3": A.matrix.tolist(),
        "n_ref": p.n_ref,
        "n_est": p.n_est,
        "n_associated": int(p.T_ref.shape[0]),
        "resampled": p.resampled,
    }


def _plot(
    args: argparse.Namespace,
    p: _Prepared,
    x: FloatArray,
    y: FloatArray,
    ylabel: str,
    bounds: tuple[float, float] | None = None,
) -> None:
    plt = need_matplotlib()
    n = 2
    fig, axes = plt.subplots(1, n, figsize=(11, 4.2))
    ax = axes[0]
    ax.plot(p.T_ref[:, 0, 3], p.T_ref[:, 1, 3], "k-", lw=1, label="reference")
    ax.plot(
        p.T_aligned[:, 0, 3],
        p.T_aligned[:, 1, 3],
        "C1-",
        lw=1,
        label=f"estimate ({p.alignment.kind})",
    )
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(loc="best")
    ax = axes[1]
    ax.plot(x, y, "C0-", lw=1)
    if bounds is not None:
        ax.axhline(bounds[0], color="C3", ls="--", lw=1, label="per-pose χ² bounds")
        ax.axhline(bounds[1], color="C3", ls="--", lw=1)
        ax.axhline(float(np.mean(y)), color="C1", lw=1.5, label=f"ANEES {float(np.mean(y)):.4g}")
        ax.set_yscale("log")
        ax.legend(loc="best")
    ax.set_xlabel("time [s]")
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    fig.suptitle(f"liebridge traj {args.traj_command}: {args.est} vs {args.ref}", fontsize=9)
    fig.tight_layout()
    save_figure(fig, args.plot)
    plt.close(fig)
    say(f"wrote {args.plot}")


def _ape(args: argparse.Namespace) -> int:
    from .. import traj

    if args.plot:
        check_output_path(args.plot, "--plot", (".png", ".pdf", ".svg"), inputs=_inputs(args))
    p = _prepare(args)
    err = traj.ape(p.T_ref, p.T_aligned, args.pose_relation)
    result = {"metric": "ape", "pose_relation": args.pose_relation, **_stats_dict(err)}
    result.update(_alignment_info(p))
    _emit(args, result, _unit(args.pose_relation))
    if args.plot:
        _plot(args, p, p.t_ref, err, f"APE {args.pose_relation} [{_unit(args.pose_relation)}]")
    return 0


def _rpe(args: argparse.Namespace) -> int:
    from .. import traj

    if args.plot:
        check_output_path(args.plot, "--plot", (".png", ".pdf", ".svg"), inputs=_inputs(args))
    if args.unit == "frames" and not float(args.delta).is_integer():
        raise CLIError(f"--delta: expected an integer for --delta-unit frames, got {args.delta:g}")
    p = _prepare(args)
    try:
        err, pairs = traj.rpe(
            p.T_ref,
            p.T_aligned,
            args.delta,
            args.unit,
            args.pose_relation,
            all_pairs=args.all_pairs,
        )
    except ValueError as exc:
        raise CLIError(str(exc)) from None
    result: dict[str, Any] = {
        "metric": "rpe",
        "pose_relation": args.pose_relation,
        "delta": args.delta,
        "delta_unit": args.unit,
        "all_pairs": bool(args.all_pairs),
        **_stats_dict(err),
    }
    result.update(_alignment_info(p))
    if args.segments:
        try:
            k = traj.kitti_segment_errors(p.T_ref, p.T_aligned)
        except ValueError as exc:
            raise CLIError(f"--segments: {exc}") from None
        result["kitti_segments"] = {
            "lengths_m": k.lengths.tolist(),
            "translation_percent": k.translation_percent.tolist(),
            "rotation_deg_per_m": k.rotation_deg_per_m.tolist(),
            "count": k.count.tolist(),
            "translation_percent_mean": k.translation_percent_mean,
            "rotation_deg_per_m_mean": k.rotation_deg_per_m_mean,
        }
    _emit(args, result, _unit(args.pose_relation))
    if args.segments and args.format != "json":
        seg = result["kitti_segments"]
        print("  KITTI segments: length [m], translation [%], rotation [deg/m], count")
        for row in zip(
            *(seg[c] for c in ("lengths_m", "translation_percent", "rotation_deg_per_m", "count")),
            strict=True,
        ):
            print(f"    {row[0]:6g} {row[1]:10.4g} {row[2]:12.4g} {row[3]:6d}")
    if args.plot:
        _plot(args, p, p.t_ref[pairs[:, 1]], err, f"RPE {args.pose_relation}")
    return 0


def _nees_inputs(
    args: argparse.Namespace,
) -> tuple[FloatArray, Any, tuple[FloatArray, FloatArray] | None, str]:
    """EST's covariances, their convention, EST's poses where read here, and where from.

    ``--cov FILE.npy`` (with ``--convention``) wins; else the covariances EST carries: a bag
    topic of ``PoseWithCovarianceStamped`` / ``Odometry`` (``--est-topic``; ROS's convention,
    converted to ``--convention`` when given) or the ``.npz`` of ``bag export --format npz`` (its
    ``convention``, converted likewise).
    """
    if args.cov is not None:
        if args.convention is None:
            raise CLIError("--convention: required with --cov (the convention of FILE.npy)")
        conv = convention_arg(args.convention, "--convention")
        cov = npy_argument(args.cov, "--cov")
        if cov.ndim != 3 or cov.shape[1:] != (6, 6):
            raise CLIError(f"--cov: expected an array of shape (N, 6, 6), got {cov.shape}")
        return np.asarray(cov, dtype=np.float64), conv, None, "--cov"
    conv = convention_arg(args.convention or "ros", "--convention")
    if args.est_topic is not None:
        t, T, bag_cov, mt = _read_topic(
            args.est,
            args.est_topic,
            "EST",
            getattr(args, "path_message", None),
            conv,
            duplicates=getattr(args, "duplicates", "first"),
        )
        if bag_cov is None:
            raise CLIError(
                f"--cov: required: EST topic {args.est_topic} is {mt}, which carries no "
                "covariance (PoseWithCovarianceStamped and Odometry do)"
            )
        return bag_cov, conv, (t, T), f"EST topic {args.est_topic}"
    if args.est.lower().endswith(".npz"):
        t, T, npz_cov, src = _read_npz(args.est, "EST")
        if npz_cov is None:
            raise CLIError(f"--cov: required: EST {args.est} has no 'cov' array")
        cov = npz_cov
        if args.convention is None:
            conv = convention_arg(src, f"EST {args.est}: its 'convention'")
        elif src != conv.name:
            from ..conventions import convert_covariance

            try:
                cov = convert_covariance(cov, T, src, conv)
            except ValueError as exc:
                raise CLIError(f"EST {args.est}: cov: {one_line(str(exc))}") from None
        return cov, conv, (t, T), f"EST {args.est}"
    raise CLIError(
        "--cov: required: EST is a trajectory file without covariances; give --cov FILE.npy "
        "with --convention, or EST as a bag topic with covariances (--est-topic), or the .npz "
        "of 'liebridge bag export --format npz'"
    )


def _nees(args: argparse.Namespace) -> int:
    from .. import traj

    if args.plot:
        check_output_path(args.plot, "--plot", (".png", ".pdf", ".svg"), inputs=_inputs(args))
    cov, conv, est, source = _nees_inputs(args)
    p = _prepare(args, cov, conv, est)
    assert p.cov_est is not None
    flag = "--cov" if source == "--cov" else source
    try:
        C = p.alignment.transform_covariance(p.T_est, p.cov_est, conv)
        r = traj.nees(p.T_ref, p.T_aligned, C, conv, confidence=args.confidence)
    except ValueError as exc:
        raise CLIError(f"{flag}: {one_line(str(exc))}") from None
    result: dict[str, Any] = {
        "metric": "nees",
        "convention": conv.name,
        "covariance_source": source,
        **_stats_dict(r.nees),
        "anees": r.anees,
        "anees_lower": r.anees_bounds[0],
        "anees_upper": r.anees_bounds[1],
        "pose_lower": r.pose_bounds[0],
        "pose_upper": r.pose_bounds[1],
        "confidence": r.confidence,
        "consistent": r.consistent,
        "fraction_inside": r.fraction_inside,
    }
    result.update(_alignment_info(p))
    _emit(args, result, "")
    if args.plot:
        _plot(args, p, p.t_ref, r.nees, "NEES (6 dof)", r.pose_bounds)
    return 0


def _common(q: argparse.ArgumentParser) -> None:
    from ..traj import ALIGNMENTS

    q.add_argument(
        "ref", metavar="REF", help="reference trajectory file (TUM, KITTI, EuRoC), or a bag"
    )
    q.add_argument("est", metavar="EST", help="estimated trajectory file")
    q.add_argument(
        "--align",
        choices=ALIGNMENTS,
        default="none",
        help="Umeyama alignment of EST to REF (default: none, as evo)",
    )
    q.add_argument(
        "--format", choices=("text", "json"), default="text", help="json: one JSON object on stdout"
    )
    q.add_argument("--plot", metavar="OUT.png", help="write a figure")
    q.add_argument(
        "--max-diff",
        type=float,
        default=0.01,
        help="largest time difference of an associated pair [s] (0.01)",
    )
    q.add_argument("--offset", type=float, default=0.0, help="added to EST's stamps [s] (0)")
    q.add_argument(
        "--interpolate",
        choices=("lerp_slerp", "geodesic"),
        default=None,
        help="resample the longer trajectory at the other's matched stamps (evo's "
        "interpolation sync: lerp_slerp) instead of taking the nearest poses",
    )
    q.add_argument(
        "--ref-topic",
        metavar="TOPIC",
        help="REF is a ROS 1/2 bag and this its pose topic (PoseWithCovarianceStamped, "
        'Odometry, PoseStamped...; needs pip install ".[ros]" (from the checkout))',
    )
    q.add_argument("--est-topic", metavar="TOPIC", help="EST is a bag: its pose topic")
    q.add_argument(
        "--path-message",
        type=int,
        default=None,
        metavar="INDEX",
        help="nav_msgs/Path topics (each message a whole trajectory): the message to read, "
        "for --ref-topic and --est-topic alike (default -1, the last; 0 the first)",
    )
    q.add_argument("--ref-format", default="auto", choices=("auto", "tum", "kitti", "euroc"))
    q.add_argument("--est-format", default="auto", choices=("auto", "tum", "kitti", "euroc"))
    q.add_argument(
        "--quat-order",
        choices=("xyzw", "wxyz"),
        default=None,
        help="quaternion order of BOTH files (TUM; default: from the header, else xyzw); a "
        "header naming the other order is an error (the header wins)",
    )
    q.add_argument(
        "--ref-quat-order",
        choices=("xyzw", "wxyz"),
        default=None,
        help="quaternion order of REF only (overrides --quat-order for REF)",
    )
    q.add_argument(
        "--est-quat-order",
        choices=("xyzw", "wxyz"),
        default=None,
        help="quaternion order of EST only (overrides --quat-order for EST)",
    )
    q.add_argument(
        "--duplicates",
        choices=("first", "last", "error"),
        default="first",
        help="repeated timestamps in a file or topic: keep the first of each (default, with a "
        "warning giving the count), the last, or stop with an error",
    )
    q.add_argument(
        "--quat-tolerance",
        type=float,
        default=1e-3,
        metavar="TOL",
        help="quaternions off unit by at most TOL are normalised (warning with the worst "
        "deviation when the printed precision does not explain it); beyond it an error naming "
        "file and line (default 1e-3)",
    )


def _relation(q: argparse.ArgumentParser) -> None:
    from ..traj import POSE_RELATIONS

    q.add_argument(
        "--pose-relation",
        "-r",
        choices=POSE_RELATIONS,
        default="trans_part",
        help="what of the error pose is measured (default trans_part, as evo)",
    )


def add_parser(sub: Any) -> None:
    """Register ``liebridge traj`` and its subcommands."""
    p = sub.add_parser(
        "traj",
        help="trajectory evaluation: APE, RPE (as evo) and NEES with covariances",
        description="Trajectory evaluation: APE, RPE (evo's definitions) and NEES.",
    )
    tsub = p.add_subparsers(dest="traj_command", metavar="SUBCOMMAND")

    def _help(_: argparse.Namespace) -> int:
        p.print_help()
        return 0

    p.set_defaults(func=_help)
    a = tsub.add_parser(
        "ape",
        help="absolute pose error",
        description="Absolute pose error of EST against REF (evo_ape).",
    )
    _common(a)
    _relation(a)
    a.set_defaults(func=_ape)
    r = tsub.add_parser(
        "rpe",
        help="relative pose error",
        description="Relative pose error of EST against REF (evo_rpe).",
    )
    _common(r)
    _relation(r)
    r.add_argument("--delta", type=float, default=1, help="pair distance (default 1)")
    unit = r.add_argument(
        "--delta-unit",
        dest="unit",
        choices=("frames", "m"),
        default="frames",
        help="unit of --delta (frames, or metres of path on EST)",
    )
    deprecated_alias(r, unit, "--unit")
    r.add_argument(
        "--all-pairs",
        action="store_true",
        help="all pairs (i, i+delta) instead of non-overlapping ones",
    )
    r.add_argument(
        "--segments", action="store_true", help="also KITTI's per-segment errors (100..800 m)"
    )
    r.set_defaults(func=_rpe)
    n = tsub.add_parser(
        "nees",
        help="NEES/ANEES of EST's covariances",
        description="NEES of EST with its covariances, with chi-square bounds. The "
        "covariances are --cov (one 6x6 per pose of EST, in --convention's tangent) or, "
        "without --cov, those EST carries: a bag topic of PoseWithCovarianceStamped or "
        "Odometry (--est-topic; ROS's convention) or the .npz of 'liebridge bag export --to "
        "npz' (its own convention); --convention then names the convention NEES is computed "
        "in (default: theirs).",
    )
    _common(n)
    n.add_argument(
        "--cov",
        default=None,
        metavar="FILE.npy",
        help="(N, 6, 6) covariances (default: EST's own, from a bag topic or an .npz)",
    )
    n.add_argument(
        "--convention",
        default=None,
        help="the covariances' convention (a preset); required with --cov",
    )
    n.add_argument("--confidence", type=float, default=0.95, help="of the chi-square bounds")
    n.set_defaults(func=_nees)
