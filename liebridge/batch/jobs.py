"""One call per log: :func:`evaluate` and :func:`convert`, pure, picklable, never raising on data.

Each returns one flat ``dict`` (JSON-serialisable: str, int, float, bool, None) that names the
inputs, every option (defaults filled in), liebridge's version, the numbers and, when the log
could not be processed, ``status = "error"`` and the error text instead of an exception. The key
set depends only on the metrics asked for, never on success, so rows of one batch form a table.
A process pool or a Dask cluster maps these module-level functions over a manifest
(:func:`liebridge.batch.run`).
"""

from __future__ import annotations

import functools
import os
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from .read import Log, read_log, split_topic

__all__ = [
    "CONVERT_OPTIONS",
    "EVALUATE_OPTIONS",
    "METRICS",
    "STAT_KEYS",
    "convert",
    "evaluate",
    "output_name",
]

#: Metrics :func:`evaluate` computes, by name.
METRICS: tuple[str, ...] = ("ape", "rpe", "nees")

#: The statistics columns of each metric (``ape_rmse``, ``rpe_max``...), as ``liebridge traj``.
STAT_KEYS: tuple[str, ...] = ("rmse", "mean", "median", "std", "min", "max", "sse", "n")

#: :func:`evaluate`'s options and their defaults (those of ``liebridge traj``).
EVALUATE_OPTIONS: dict[str, Any] = {
    "align": "none",
    "max_diff": 0.01,
    "offset": 0.0,
    "interpolate": None,
    "pose_relation": "trans_part",
    "delta": 1.0,
    "delta_unit": "frames",
    "all_pairs": False,
    "ref_format": "auto",
    "est_format": "auto",
    "quat_order": None,
    "ref_topic": None,
    "est_topic": None,
    "est_cov": None,
    "convention": None,
    "confidence": 0.95,
}

#: :func:`convert`'s options and their defaults.
CONVERT_OPTIONS: dict[str, Any] = {
    "src_format": "auto",
    "src_topic": None,
    "quat_order": None,
    "out_quat_order": "xyzw",
    "cov": None,
    "convention": None,
    "name": None,
}

_NEES_KEYS = (
    "anees",
    "anees_lower",
    "anees_upper",
    "pose_lower",
    "pose_upper",
    "consistent",
    "fraction_inside",
)
_ALIGN_KEYS = ("n_ref", "n_est", "n_associated", "resampled", "scale")
_SUFFIX = {"tum": ".txt", "kitti": ".txt", "euroc": ".csv"}


@functools.lru_cache(maxsize=1)
def _version() -> str:
    """Liebridge's installed version (the package's own ``__init__`` is above this floor)."""
    import importlib.metadata

    try:
        return importlib.metadata.version("liebridge")
    except importlib.metadata.PackageNotFoundError:  # run from a checkout without installing
        return "unknown"


def _error_text(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {' '.join(str(exc).split())}"


def _options(given: dict[str, Any], defaults: dict[str, Any], func: str) -> dict[str, Any]:
    unknown = sorted(set(given) - set(defaults))
    if unknown:
        raise TypeError(
            f"{func}: unknown option(s) {', '.join(unknown)} (expected: {', '.join(defaults)})"
        )
    out = dict(defaults)
    out.update(given)
    for k, v in out.items():
        if isinstance(v, os.PathLike):
            out[k] = os.fspath(v)
    return out


def _metrics(metrics: str | Iterable[str]) -> tuple[str, ...]:
    names = tuple(m.strip() for m in metrics.split(",")) if isinstance(metrics, str) else metrics
    names = tuple(str(m).strip().lower() for m in names)
    bad = [m for m in names if m not in METRICS]
    if bad or not names:
        raise ValueError(
            f"metrics: expected a non-empty subset of {', '.join(METRICS)}, got {list(names)}"
        )
    return tuple(dict.fromkeys(names))


def evaluate(
    ref: str | os.PathLike[str],
    est: str | os.PathLike[str],
    *,
    metrics: str | Iterable[str] = ("ape", "rpe", "nees"),
    **options: Any,
) -> dict[str, Any]:
    """Evaluate one estimated trajectory against its reference: one flat row.

    The pipeline and numbers are those of ``liebridge traj ape|rpe|nees`` (evo's definitions):
    read both logs, associate by timestamp, align the estimate to the reference, compute each
    metric's statistics. Poses are ``T_world_body`` (N, 4, 4); NEES uses the estimate's
    covariances in the tangent of ``convention`` (a preset name), moved under the alignment as
    that convention requires — the tempting false step is to compare a covariance given in one
    tangent order (ROS: ``(x, y, z, rotX, rotY, rotZ)``) as if it were in another (GTSAM:
    rotation first).

    Parameters
    ----------
    ref, est : str or os.PathLike
        Trajectory files (TUM, KITTI, EuRoC; format detected) or bag topics ``"BAG:/topic"``.
    metrics : str or iterable of str
        A subset of ``("ape", "rpe", "nees")`` (a comma-separated string is accepted).
        ``nees`` is skipped, with a note in the row, when the estimate has no covariances.
    **options
        Keys of :data:`EVALUATE_OPTIONS`: ``align`` (``none``/``se3``/``sim3``/``4dof``),
        ``max_diff`` [s], ``offset`` [s] (added to EST's stamps), ``interpolate`` (None,
        ``lerp_slerp``, ``geodesic``), ``pose_relation`` (APE and RPE), ``delta``,
        ``delta_unit`` (``frames``/``m``), ``all_pairs``, ``ref_format``, ``est_format``,
        ``quat_order``, ``ref_topic``, ``est_topic``, ``est_cov`` (a ``.npy`` of (M, 6, 6), one
        per pose of EST), ``convention`` (of ``est_cov``; of a bag's covariances, default
        ``ros``), ``confidence`` (of NEES's χ² bounds).

    Returns
    -------
    dict
        ``ref``, ``est``, ``metrics``, every option, ``liebridge_version``, ``status``
        (``"ok"``/``"error"``), ``error`` (the error text or ``""``), ``note`` (skipped metrics,
        reader warnings), ``n_ref``, ``n_est``, ``n_associated``, ``resampled``, ``scale``,
        ``<metric>_<stat>`` for the statistics :data:`STAT_KEYS` of each metric asked for, and
        ``nees_anees``, ``nees_anees_lower`` ... ; numbers that could not be computed are None.

    Raises
    ------
    TypeError
        An option name not in :data:`EVALUATE_OPTIONS` (the caller's mistake, not the log's).
    ValueError
        An unknown metric name.
    """
    names = _metrics(metrics)
    opts = _options(options, EVALUATE_OPTIONS, "evaluate")
    row: dict[str, Any] = {
        "ref": os.fspath(ref),
        "est": os.fspath(est),
        "metrics": ",".join(names),
        **opts,
        "liebridge_version": _version(),
        "status": "ok",
        "error": "",
        "note": "",
    }
    row.update(dict.fromkeys(_ALIGN_KEYS))
    for m in names:
        row.update(dict.fromkeys(f"{m}_{k}" for k in STAT_KEYS))
        if m == "nees":
            row.update(dict.fromkeys(f"nees_{k}" for k in _NEES_KEYS))
    try:
        notes = _evaluate_into(row, names, opts)
    except Exception as exc:  # failure isolation: the row carries the error
        row["status"] = "error"
        row["error"] = _error_text(exc)
        return row
    row["note"] = "; ".join(notes)
    return row


def _read(spec: Any, what: str, **kw: Any) -> Log:
    try:
        return read_log(spec, **kw)
    except Exception as exc:  # one message naming the input, whatever the reader raised
        raise ValueError(f"{what}: {' '.join(str(exc).split())}") from None


def _evaluate_into(row: dict[str, Any], names: tuple[str, ...], o: dict[str, Any]) -> list[str]:
    from .. import traj
    from ..conventions import get

    want_cov = "nees" in names
    ref = _read(row["ref"], "REF", format=o["ref_format"], quat_order=o["quat_order"],
                topic=o["ref_topic"])  # fmt: skip
    est = _read(
        row["est"],
        "EST",
        format=o["est_format"],
        quat_order=o["quat_order"],
        topic=o["est_topic"],
        cov=o["est_cov"] if want_cov else None,
        convention=o["convention"] if want_cov else None,
    )
    notes = [f"REF: {w}" for w in ref.warnings] + [f"EST: {w}" for w in est.warnings]
    cov = est.cov if want_cov else None
    conv = get(est.convention) if cov is not None and est.convention is not None else None
    traj.check_timestamps(ref.stamps, "REF timestamps")
    traj.check_timestamps(est.stamps, "EST timestamps")
    s = traj.synchronize(
        ref.stamps,
        ref.T_world_body,
        est.stamps,
        est.T_world_body,
        max_diff=float(o["max_diff"]),
        offset=float(o["offset"]),
        interpolate=o["interpolate"],
        cov_est=cov,
        convention=conv,
    )
    A = traj.align(s.T_ref, s.T_est, o["align"])
    T_aligned = A.apply(s.T_est)
    row.update(
        n_ref=int(ref.stamps.shape[0]),
        n_est=int(est.stamps.shape[0]),
        n_associated=int(s.T_ref.shape[0]),
        resampled=s.resampled,
        scale=float(A.scale),
    )
    if "ape" in names:
        err = traj.ape(s.T_ref, T_aligned, o["pose_relation"])
        _stats(row, "ape", err)
    if "rpe" in names:
        if o["delta_unit"] == "frames" and not float(o["delta"]).is_integer():
            raise ValueError(f"delta: expected an integer for delta_unit frames, got {o['delta']}")
        err, _ = traj.rpe(
            s.T_ref,
            T_aligned,
            o["delta"],
            o["delta_unit"],
            o["pose_relation"],
            all_pairs=bool(o["all_pairs"]),
        )
        _stats(row, "rpe", err)
    if "nees" in names:
        if s.cov_est is None or conv is None:
            notes.append(
                "nees skipped: EST has no covariances (give est_cov and convention, or a bag "
                "topic with covariances)"
            )
        else:
            C = A.transform_covariance(s.T_est, s.cov_est, conv)
            r = traj.nees(s.T_ref, T_aligned, C, conv, confidence=float(o["confidence"]))
            _stats(row, "nees", r.nees)
            row.update(
                nees_anees=float(r.anees),
                nees_anees_lower=float(r.anees_bounds[0]),
                nees_anees_upper=float(r.anees_bounds[1]),
                nees_pose_lower=float(r.pose_bounds[0]),
                nees_pose_upper=float(r.pose_bounds[1]),
                nees_consistent=bool(r.consistent),
                nees_fraction_inside=float(r.fraction_inside),
            )
            if o["convention"] is None:
                row["convention"] = conv.name
    return notes


def _stats(row: dict[str, Any], metric: str, errors: Any) -> None:
    from ..traj import statistics

    st = statistics(errors)  # the fields read directly: dataclasses.asdict deep-copies
    for k in STAT_KEYS:
        v = getattr(st, k)
        row[f"{metric}_{k}"] = int(v) if k == "n" else float(v)


def output_name(src: str, topic: str | None = None) -> str:
    """Return :func:`convert`'s default output name: the input's stem, plus ``_topic`` (bags)."""
    path, spec_topic = split_topic(src)
    topic = topic or spec_topic
    stem = Path(path).name
    for suffix in (".txt", ".csv", ".tum", ".kitti", ".bag", ".mcap", ".db3"):
        if stem.lower().endswith(suffix):
            stem = stem[: -len(suffix)]
            break
    if topic:
        stem += "_" + topic.strip("/").replace("/", "_")
    return stem


def convert(
    src: str | os.PathLike[str],
    dst_dir: str | os.PathLike[str],
    *,
    to: str = "tum",
    **options: Any,
) -> dict[str, Any]:
    """Convert one log to a trajectory file in ``dst_dir``: one flat row.

    Reads ``src`` (a TUM / KITTI / EuRoC file or a bag topic ``"BAG:/topic"``) and writes
    ``dst_dir/NAME.txt`` (TUM, KITTI) or ``NAME.csv`` (EuRoC) with
    :func:`liebridge.io.trajfile.write_trajectory` (hemisphere-continuous quaternions, ``repr``
    precision). Covariances (a bag topic's, or ``cov``) go to ``dst_dir/NAME.cov.npy``, (N, 6, 6)
    in the tangent of ``convention`` (default: the input's; a bag's is ``ros``,
    ``(x, y, z, rotX, rotY, rotZ)`` — not GTSAM's rotation-first order). The file is written to a
    temporary name and renamed, so a killed job leaves no half-written output.

    Parameters
    ----------
    src : str or os.PathLike
    dst_dir : str or os.PathLike
        An existing directory.
    to : {"tum", "kitti", "euroc"}
    **options
        Keys of :data:`CONVERT_OPTIONS`: ``src_format``, ``src_topic``, ``quat_order`` (of a TUM
        input), ``out_quat_order`` (of a TUM output: ``xyzw`` or ``wxyz``, then written in the
        header), ``cov`` (a ``.npy`` of (N, 6, 6) for a file input), ``convention``, ``name``
        (the output's name without suffix, may contain ``/``; default: the input's stem, plus
        the topic for a bag).

    Returns
    -------
    dict
        ``src``, ``dst_dir``, ``to``, every option, ``liebridge_version``, ``status``,
        ``error``, ``note``, ``dst`` (the written file), ``cov_file`` (or ``""``), ``n_poses``.

    Raises
    ------
    TypeError
        An option name not in :data:`CONVERT_OPTIONS`.
    """
    opts = _options(options, CONVERT_OPTIONS, "convert")
    row: dict[str, Any] = {
        "src": os.fspath(src),
        "dst_dir": os.fspath(dst_dir),
        "to": to,
        **opts,
        "liebridge_version": _version(),
        "status": "ok",
        "error": "",
        "note": "",
        "dst": "",
        "cov_file": "",
        "n_poses": None,
    }
    try:
        _convert_into(row, opts)
    except Exception as exc:
        row["status"] = "error"
        row["error"] = _error_text(exc)
    return row


def _convert_into(row: dict[str, Any], o: dict[str, Any]) -> None:
    from ..io import trajfile

    to = row["to"].strip().lower() if isinstance(row["to"], str) else row["to"]
    if to not in trajfile.FORMATS:
        raise ValueError(f"to: expected one of {', '.join(trajfile.FORMATS)}, got {to!r}")
    dst_dir = Path(row["dst_dir"])
    if not dst_dir.is_dir():
        raise ValueError(f"dst_dir: {dst_dir} is not a directory")
    cov_conv = o["convention"]
    log = _read(
        row["src"],
        "SRC",
        format=o["src_format"],
        quat_order=o["quat_order"],
        topic=o["src_topic"],
        cov=o["cov"],
        convention=cov_conv if o["cov"] is not None else None,
    )
    name = o["name"] or output_name(row["src"], o["src_topic"])
    dst = dst_dir / (name + _SUFFIX[to])
    dst.parent.mkdir(parents=True, exist_ok=True)
    tmp = dst.with_name(f".{dst.name}.{os.getpid()}.{time.monotonic_ns()}.part")
    try:
        trajfile.write_trajectory(
            tmp, log.stamps, log.T_world_body, to, quat_order=o["out_quat_order"]
        )
        os.replace(tmp, dst)
    finally:
        tmp.unlink(missing_ok=True)
    row["dst"] = str(dst)
    row["n_poses"] = int(log.stamps.shape[0])
    notes = list(log.warnings)
    if to == "kitti":
        notes.append("kitti keeps no timestamps")
    if log.cov is not None and log.convention is not None:
        C = log.cov
        if cov_conv is not None and cov_conv != log.convention:
            from ..conventions import convert_covariance

            C = convert_covariance(C, log.T_world_body, log.convention, cov_conv)
        cov_file = dst_dir / (name + ".cov.npy")
        tmp = cov_file.with_name(f".{cov_file.name}.{os.getpid()}.part.npy")
        try:
            np.save(tmp, np.ascontiguousarray(C))
            os.replace(tmp, cov_file)
        finally:
            tmp.unlink(missing_ok=True)
        row["cov_file"] = str(cov_file)
        row["convention"] = cov_conv or log.convention
    row["note"] = "; ".join(notes)
