"""``liebridge batch evaluate|convert SOURCE --out TABLE``: many logs, one table, any engine.

SOURCE is a manifest (a CSV file whose header names ``ref,est`` — or ``src`` for ``convert`` —
and optionally per-row options, relative paths taken from the manifest's directory) or a
directory with a pairing rule (``--ref-glob``/``--est-glob``, one ``*`` each: files whose ``*``
parts agree form a pair; ``--glob`` for ``convert``). Jobs run on ``--engine serial``,
``processes`` (``--jobs N``) or ``dask`` (``--scheduler ADDRESS``, else a local cluster of
``--jobs`` workers). Each finished log is journalled (``TABLE.jsonl``): a rerun computes only
what is missing. A failed log is an error row, never the end of the batch; the exit status is
1 when any log failed, 2 for usage errors. Progress with an ETA goes to stderr, the summary
(worst runs first, failed logs) to stdout, its plot to ``--summary`` (default ``TABLE.png``).
"""

from __future__ import annotations

import argparse
import csv
import os
import re
import time
from pathlib import Path
from typing import Any

from ._common import (
    CLIError,
    check_output_path,
    deprecated_alias,
    one_line,
    option_value,
    positive_int,
    say,
)

__all__ = ["add_parser"]

_PATH_COLUMNS = {"ref", "est", "est_cov", "src", "cov"}
_TRUE = {"1", "true", "yes", "y", "on"}
_FALSE = {"0", "false", "no", "n", "off"}


def _glob_regex(pattern: str, option: str) -> re.Pattern[str]:
    if pattern.count("*") != 1:
        raise CLIError(f"{option}: expected exactly one '*' in the pattern, got {pattern!r}")
    head, tail = pattern.split("*")
    return re.compile(re.escape(head) + "(.+)" + re.escape(tail) + r"\Z")


def _files_by_key(root: Path, pattern: str, option: str) -> dict[str, Path]:
    rx = _glob_regex(pattern, option)
    out: dict[str, Path] = {}
    for p in sorted(root.absolute().rglob("*")):
        if p.is_file() or (p.is_dir() and (p / "metadata.yaml").is_file()):  # ROS 2 bag dirs
            m = rx.match(p.relative_to(root.absolute()).as_posix())
            if m:
                out[m.group(1)] = p
    return out


def _value(text: str, default: Any, where: str, column: str) -> Any:
    text = text.strip()
    if isinstance(default, bool):
        low = text.lower()
        if low in _TRUE | _FALSE:
            return low in _TRUE
        raise CLIError(f"{where}: {column}: expected true or false, got {text!r}")
    if isinstance(default, float):
        try:
            return float(text)
        except ValueError:
            raise CLIError(f"{where}: {column}: not a number: {text!r}") from None
    return text


def _read_manifest(
    path: Path, required: tuple[str, ...], options: dict[str, Any]
) -> list[dict[str, Any]]:
    """Rows of a manifest as job keyword arguments (empty cells: the command-line value)."""
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            lines = [ln for ln in fh if ln.strip() and not ln.lstrip().startswith("#")]
    except (OSError, UnicodeDecodeError) as exc:
        raise CLIError(f"SOURCE: cannot read {path}: {one_line(str(exc))}") from None
    reader = csv.reader(lines)
    header = [h.strip() for h in next(reader, [])]
    missing = [c for c in required if c not in header]
    if missing:
        raise CLIError(
            f"{path}: the manifest needs the column(s) {', '.join(missing)} "
            f"(its header: {','.join(header) or '(empty)'})"
        )
    allowed = set(required) | set(options) | {"metrics"}
    unknown = [c for c in header if c not in allowed]
    if unknown:
        raise CLIError(
            f"{path}: unknown column(s) {', '.join(unknown)} "
            f"(allowed: {', '.join(sorted(allowed))})"
        )
    jobs = []
    base = path.parent
    for k, cells in enumerate(reader, start=2):
        if len(cells) != len(header):
            raise CLIError(f"{path}: data line {k}: {len(cells)} cells for {len(header)} columns")
        job: dict[str, Any] = {}
        for col, cell in zip(header, cells, strict=True):
            if not cell.strip():
                continue
            if col in _PATH_COLUMNS:
                p = Path(cell.strip())
                job[col] = os.path.abspath(p if p.is_absolute() else base / p)
            elif col == "metrics":
                job[col] = cell.strip().replace(";", ",")
            else:
                job[col] = _value(cell, options[col], f"{path}: data line {k}", col)
        for col in required:
            if col not in job:
                raise CLIError(f"{path}: data line {k}: empty {col}")
        jobs.append(job)
    if not jobs:
        raise CLIError(f"{path}: the manifest has no rows")
    return jobs


def _exists(spec: str) -> bool:
    from ..batch import split_topic

    return Path(split_topic(spec)[0]).exists()


def _warn_missing(jobs: list[dict[str, Any]], columns: tuple[str, ...], prog: str) -> None:
    bad = [
        (i, c, j[c]) for i, j in enumerate(jobs) for c in columns if c in j and not _exists(j[c])
    ]
    if not bad:
        return
    rows = sorted({i for i, _, _ in bad})
    say(f"{prog}: warning: {len(rows)} of {len(jobs)} jobs name missing files; they are "
        f"error rows, the rest runs:")  # fmt: skip
    for i, c, p in bad[:10]:
        say(f"  job {i + 1}: {c} {p}: no such file")
    if len(bad) > 10:
        say(f"  ... and {len(bad) - 10} more")


class _Reporter:
    """Progress on stderr at most once a second, with the rate and an ETA."""

    def __init__(self, prog: str, quiet: bool) -> None:
        self.prog = prog
        self.quiet = quiet
        self.last = 0.0

    def __call__(self, done: int, total: int, failed: int, rate: float, eta: float | None) -> None:
        now = time.monotonic()
        if self.quiet or (done < total and now - self.last < 1.0):
            return
        self.last = now
        eta_text = "" if eta is None else f", ETA {_duration(eta)}"
        say(f"{self.prog}: {done}/{total} logs, {failed} failed, {rate:.3g} logs/s{eta_text}")


def _duration(s: float) -> str:
    if s < 90:
        return f"{s:.0f} s"
    if s < 5400:
        return f"{s / 60:.1f} min"
    return f"{s / 3600:.1f} h"


def _run(args: argparse.Namespace, func: Any, jobs: list[dict[str, Any]], prog: str) -> int:
    from ..batch import plot_summary, run, summary_lines

    summary = _check_args(args)
    reporter = _Reporter(prog, args.quiet)
    try:
        result = run(
            func,
            jobs,
            args.out,
            engine=args.engine,
            workers=args.jobs,
            scheduler=args.scheduler,
            retry_errors=args.retry_errors,
            progress=reporter,
        )
    except ImportError as exc:
        raise CLIError(f"--engine {args.engine}: {one_line(str(exc))}") from None
    except ConnectionError as exc:
        raise CLIError(f"--{one_line(str(exc))}") from None
    if result.reused:
        say(f"{prog}: {result.reused} of {len(jobs)} logs already in {args.out}'s journal "
            f"(skipped), {result.computed} computed")  # fmt: skip
    for line in summary_lines(result.rows):
        print(line)
    say(f"{prog}: wrote {', '.join(str(p) for p in result.files)}")
    if summary is not None:
        try:
            wrote = plot_summary(result.rows, summary, title=f"{prog}:")
        except ImportError:
            say(f"{prog}: no summary plot: matplotlib is not installed "
                '(pip install ".[plot]" from the checkout)')  # fmt: skip
        else:
            if wrote:
                say(f"{prog}: wrote {summary}")
    return 1 if result.failed else 0


def _check_args(args: argparse.Namespace) -> str | None:
    """Usage errors before any file is read; return the summary plot's path (None: no plot)."""
    check_output_path(args.out, "--out", (".csv",))
    if args.engine != "dask" and args.scheduler:
        raise CLIError(f"--scheduler: only the dask engine has one (--engine is {args.engine})")
    if args.no_summary:
        return None
    summary = str(args.summary or Path(args.out).with_suffix(".png"))
    check_output_path(summary, "--summary", (".png", ".pdf", ".svg"))
    return summary


def _options_from_args(args: argparse.Namespace, defaults: dict[str, Any]) -> dict[str, Any]:
    return {k: getattr(args, k) for k in defaults if getattr(args, k, None) is not None}


def _evaluate(args: argparse.Namespace) -> int:
    from ..batch import EVALUATE_OPTIONS, evaluate

    prog = "liebridge batch evaluate"
    _check_args(args)
    try:
        metrics = _parse_metrics(args.metrics)
    except ValueError as exc:
        raise CLIError(f"--metrics: {exc}") from None
    defaults = _options_from_args(args, EVALUATE_OPTIONS)
    src = Path(args.source)
    if src.is_dir():
        refs = _files_by_key(src, args.ref_glob, "--ref-glob")
        ests = _files_by_key(src, args.est_glob, "--est-glob")
        keys = sorted(set(refs) & set(ests))
        if not keys:
            raise CLIError(
                f"{src}: no pairs: {len(refs)} files match --ref-glob {args.ref_glob!r}, "
                f"{len(ests)} match --est-glob {args.est_glob!r}, none share the '*' part"
            )
        alone = sorted(set(refs) ^ set(ests))
        if alone:
            say(f"{prog}: warning: {len(alone)} files without a partner are left out "
                f"(e.g. {(refs.get(alone[0]) or ests[alone[0]])})")  # fmt: skip
        covs = _files_by_key(src, args.cov_glob, "--cov-glob") if args.cov_glob else {}
        jobs: list[dict[str, Any]] = []
        for k in keys:
            job: dict[str, Any] = {"ref": str(refs[k]), "est": str(ests[k])}
            if k in covs:
                job["est_cov"] = str(covs[k])
            jobs.append(job)
    elif src.is_file():
        jobs = _read_manifest(src, ("ref", "est"), EVALUATE_OPTIONS)
    else:
        raise CLIError(f"SOURCE: no such file or directory: {args.source}")
    _warn_missing(jobs, ("ref", "est", "est_cov"), prog)
    full = [{"metrics": metrics, **defaults, **j} for j in jobs]
    return _run(args, evaluate, full, prog)


def _parse_metrics(text: str) -> str:
    from ..batch import METRICS

    names = [m.strip().lower() for m in text.replace(";", ",").split(",") if m.strip()]
    bad = [m for m in names if m not in METRICS]
    if bad or not names:
        raise ValueError(f"expected a comma-separated subset of {','.join(METRICS)}, got {text!r}")
    return ",".join(dict.fromkeys(names))


def _convert(args: argparse.Namespace) -> int:
    from ..batch import CONVERT_OPTIONS, convert
    from ..batch.jobs import output_name

    prog = "liebridge batch convert"
    _check_args(args)
    dst = Path(args.dst_dir)
    if not dst.is_dir():
        raise CLIError(f"--dst-dir: {args.dst_dir} is not a directory")
    defaults = _options_from_args(args, CONVERT_OPTIONS)
    src = Path(args.source)
    if src.is_dir():
        files = _files_by_key(src, args.glob, "--glob")
        files = {k: p for k, p in files.items() if dst.resolve() not in p.resolve().parents}
        if not files:
            raise CLIError(f"{src}: no files match --glob {args.glob!r}")
        jobs: list[dict[str, Any]] = []
        for p in files.values():  # sub-directories kept under --dst-dir
            rel = p.relative_to(src.absolute()).parent / output_name(str(p), args.src_topic)
            jobs.append({"src": str(p), "name": rel.as_posix()})
    elif src.is_file():
        jobs = _read_manifest(src, ("src",), CONVERT_OPTIONS)
    else:
        raise CLIError(f"SOURCE: no such file or directory: {args.source}")
    _warn_missing(jobs, ("src", "cov"), prog)
    full = [{"dst_dir": str(dst.absolute()), "to": args.to, **defaults, **j} for j in jobs]
    seen: dict[str, int] = {}
    for i, j in enumerate(full):
        name = j.get("name") or output_name(j["src"], j.get("src_topic"))
        if name in seen:
            raise CLIError(
                f"jobs {seen[name] + 1} and {i + 1} would both write {name!r} in --dst-dir "
                f"(give a 'name' column)"
            )
        seen[name] = i
    return _run(args, convert, full, prog)


def _engine_args(q: argparse.ArgumentParser) -> None:
    from ..batch import ENGINES

    q.add_argument("source", metavar="SOURCE", help="a manifest (.csv) or a directory")
    q.add_argument("--out", required=True, metavar="TABLE.csv", help="the results table")
    q.add_argument(
        "--engine", type=option_value, choices=ENGINES, default="serial", help="(default serial)"
    )
    q.add_argument(
        "--jobs",
        type=positive_int,
        default=None,
        metavar="N",
        help="workers: processes in the pool, or the local Dask cluster's (default: CPU count "
        "for processes, 2 for dask)",
    )
    q.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="dask: an existing cluster's scheduler (tcp://host:8786); without it a local "
        "cluster is started",
    )
    q.add_argument(
        "--retry-errors", action="store_true", help="recompute logs that failed in an earlier run"
    )
    q.add_argument("--summary", metavar="OUT.png", help="summary plot (default TABLE.png)")
    q.add_argument("--no-summary", action="store_true", help="no summary plot")
    q.add_argument("--quiet", action="store_true", help="no progress lines")


def add_parser(sub: Any) -> None:
    """Register ``liebridge batch`` and its subcommands."""
    from ..traj import ALIGNMENTS, POSE_RELATIONS

    p = sub.add_parser(
        "batch",
        help="fleet scale: evaluate or convert many logs into one table (serial, processes, dask)",
        description="Evaluate or convert many logs into one resumable table, on a process pool "
        "or a Dask cluster.",
    )
    bsub = p.add_subparsers(dest="batch_command", metavar="SUBCOMMAND")

    def _help(_: argparse.Namespace) -> int:
        p.print_help()
        return 0

    p.set_defaults(func=_help)
    e = bsub.add_parser(
        "evaluate",
        help="APE/RPE/NEES of many (REF, EST) pairs",
        description="liebridge traj's APE, RPE and NEES for every pair of a manifest (columns "
        "ref,est and optional per-row options) or of a directory (--ref-glob/--est-glob).",
    )
    _engine_args(e)
    e.add_argument("--metrics", default="ape,rpe,nees", help="(default ape,rpe,nees)")
    e.add_argument("--ref-glob", default="*_ref.txt", help="directory pairing: REF files")
    e.add_argument("--est-glob", default="*_est.txt", help="directory pairing: EST files")
    e.add_argument(
        "--cov-glob", default=None, help="directory pairing: EST's covariances (.npy, N×6×6)"
    )
    e.add_argument(
        "--align",
        type=option_value,
        choices=ALIGNMENTS,
        default=None,
        help="(default none, as evo)",
    )
    e.add_argument("--max-diff", dest="max_diff", type=float, default=None, help="[s] (0.01)")
    e.add_argument("--offset", type=float, default=None, help="added to EST's stamps [s] (0)")
    e.add_argument(
        "--interpolate", type=option_value, choices=("lerp_slerp", "geodesic"), default=None
    )
    e.add_argument(
        "--pose-relation",
        "-r",
        dest="pose_relation",
        type=option_value,
        choices=POSE_RELATIONS,
        default=None,
        help="APE and RPE (default trans_part)",
    )
    e.add_argument("--delta", type=float, default=None, help="RPE pair distance (1)")
    e.add_argument(
        "--delta-unit", dest="delta_unit", type=option_value, choices=("frames", "m"), default=None
    )
    e.add_argument("--all-pairs", dest="all_pairs", action="store_true", default=None)
    e.add_argument(
        "--ref-format",
        dest="ref_format",
        type=option_value,
        choices=("auto", "tum", "kitti", "euroc"),
    )
    e.add_argument(
        "--est-format",
        dest="est_format",
        type=option_value,
        choices=("auto", "tum", "kitti", "euroc"),
    )
    e.add_argument("--quat-order", dest="quat_order", type=option_value, choices=("xyzw", "wxyz"))
    e.add_argument("--ref-topic", dest="ref_topic", metavar="TOPIC", help="REF files are bags")
    e.add_argument("--est-topic", dest="est_topic", metavar="TOPIC", help="EST files are bags")
    e.add_argument("--convention", help="the covariances' convention (a preset)")
    e.add_argument("--confidence", type=float, default=None, help="of NEES's χ² bounds (0.95)")
    e.set_defaults(func=_evaluate)
    c = bsub.add_parser(
        "convert",
        help="many logs (files, bag topics) to TUM / KITTI / EuRoC files",
        description="Convert every log of a manifest (column src and optional per-row options) "
        "or of a directory (--glob) into --dst-dir.",
    )
    _engine_args(c)
    c.add_argument("--dst-dir", dest="dst_dir", required=True, metavar="DIR")
    fmt = c.add_argument(
        "--format",
        dest="to",
        type=option_value,
        choices=("tum", "kitti", "euroc"),
        default="tum",
        help="the format of the files written (default tum)",
    )
    deprecated_alias(c, fmt, "--to")
    c.add_argument("--glob", default="*.txt", help="directory: the files to convert (*.txt)")
    c.add_argument(
        "--src-format",
        dest="src_format",
        type=option_value,
        choices=("auto", "tum", "kitti", "euroc"),
    )
    c.add_argument("--src-topic", dest="src_topic", metavar="TOPIC", help="the files are bags")
    c.add_argument("--quat-order", dest="quat_order", type=option_value, choices=("xyzw", "wxyz"))
    c.add_argument(
        "--out-quat-order", dest="out_quat_order", type=option_value, choices=("xyzw", "wxyz")
    )
    c.add_argument("--convention", help="write covariances in this convention (a preset)")
    c.set_defaults(func=_convert)
