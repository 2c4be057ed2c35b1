"""A resumable results table: a journal of finished rows, then CSV (and Parquet) in job order.

:func:`run` maps a per-log function over jobs with :func:`~liebridge.batch.engine.map_jobs` and
appends each finished row, as one JSON line, to the journal ``TABLE.jsonl`` next to the table
(flushed per row, so an interrupted batch keeps everything it finished). A rerun reads the
journal and computes only the jobs not in it (``retry_errors=True`` also recomputes the failed
ones). When every job is done, the table is written in job order — the same bytes whatever
the engine — as ``TABLE.csv`` and, where ``pyarrow`` is installed, ``TABLE.parquet``.
A job is identified by ``job``, a hash of its function's name and arguments.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .engine import map_jobs

__all__ = ["BatchResult", "Progress", "job_key", "read_journal", "run", "write_table"]

#: ``progress(done, total, failed, rate_per_s, eta_s)``; ``eta_s`` is None until a rate is known.
Progress = Callable[[int, int, int, float, "float | None"], None]


def job_key(func: Callable[..., Any], job: dict[str, Any]) -> str:
    """Return a stable 16-hex-digit id of one call: the function's name and its arguments."""
    text = json.dumps([func.__name__, job], sort_keys=True, default=str)
    return hashlib.sha1(text.encode("utf-8")).hexdigest()[:16]


def read_journal(path: str | os.PathLike[str]) -> dict[str, dict[str, Any]]:
    """Rows of a journal by job id (a truncated last line, from a killed run, is ignored)."""
    done: dict[str, dict[str, Any]] = {}
    p = Path(path)
    if not p.is_file():
        return done
    with open(p, encoding="utf-8") as fh:
        for line in fh:
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                continue
            if isinstance(row, dict) and isinstance(row.get("job"), str):
                done[row["job"]] = row
    return done


def _cell(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else str(v)
    return str(v)


def write_table(rows: Sequence[dict[str, Any]], out: str | os.PathLike[str]) -> list[Path]:
    """Write ``rows`` as CSV at ``out`` and, with pyarrow, Parquet beside it; return the paths.

    Columns are the union of the rows' keys in first-seen order; missing cells are empty (CSV)
    or null (Parquet). Floats are written with ``repr`` (they read back to the same double).
    Each file is written to a temporary name and renamed.
    """
    out = Path(out)
    columns: dict[str, None] = {}
    for r in rows:
        columns.update(dict.fromkeys(r))
    tmp = out.with_name(f".{out.name}.part")
    with open(tmp, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(columns)
        for r in rows:
            w.writerow([_cell(r.get(c)) for c in columns])
    os.replace(tmp, out)
    written = [out]
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return written
    pq_path = out.with_suffix(".parquet")
    table = pa.Table.from_pylist([{c: r.get(c) for c in columns} for r in rows])
    tmp = pq_path.with_name(f".{pq_path.name}.part")
    pq.write_table(table, tmp)
    os.replace(tmp, pq_path)
    written.append(pq_path)
    return written


@dataclass
class BatchResult:
    """What :func:`run` did.

    Attributes
    ----------
    rows : list of dict
        One row per job, in job order, each with its ``job`` id.
    computed, reused : int
        Jobs computed in this run, and rows taken from the journal of an earlier one.
    seconds : float
        Wall time of this run's computing (engine start included).
    files : list of Path
        The table files written.
    """

    rows: list[dict[str, Any]]
    computed: int
    reused: int
    seconds: float
    files: list[Path] = field(default_factory=list)

    @property
    def failed(self) -> list[dict[str, Any]]:
        """The rows whose status is ``"error"``."""
        return [r for r in self.rows if r.get("status") == "error"]


def run(
    func: Callable[..., dict[str, Any]],
    jobs: Sequence[dict[str, Any]],
    out: str | os.PathLike[str] | None = None,
    *,
    engine: str = "serial",
    workers: int | None = None,
    scheduler: Any = None,
    retry_errors: bool = False,
    progress: Progress | None = None,
) -> BatchResult:
    """Run ``func(**job)`` for every job on ``engine``, resumable through ``out``'s journal.

    Parameters
    ----------
    func : callable
        :func:`liebridge.batch.evaluate`, :func:`liebridge.batch.convert` or any module-level
        function returning a flat ``dict``.
    jobs : sequence of dict
        Keyword arguments per call.
    out : str or os.PathLike, optional
        The table (``.csv``); its journal is ``out`` with suffix ``.jsonl``. Without it nothing
        is written and nothing is resumed.
    engine, workers, scheduler
        As :func:`liebridge.batch.engine.map_jobs`.
    retry_errors : bool
        Recompute jobs whose journal row is an error (default: keep them, they are done).
    progress : callable, optional
        Called after each finished job (see :data:`Progress`).

    Returns
    -------
    BatchResult
    """
    keys = [job_key(func, j) for j in jobs]
    journal = Path(out).with_suffix(".jsonl") if out is not None else None
    done = read_journal(journal) if journal is not None else {}
    if retry_errors:
        done = {k: r for k, r in done.items() if r.get("status") != "error"}
    todo_idx = [i for i, k in enumerate(keys) if k not in done]
    seen: set[str] = set()
    unique = []
    for i in todo_idx:  # the same call listed twice is computed once
        if keys[i] not in seen:
            seen.add(keys[i])
            unique.append(i)
    reused = len(jobs) - len(todo_idx)
    total = len(unique)
    failed = 0
    t0 = time.perf_counter()
    fh = None
    if journal is not None:
        fh = open(journal, "a+b")
        if fh.tell() > 0:  # a line cut short by a kill stays alone on its line
            fh.seek(-1, os.SEEK_END)
            if fh.read(1) != b"\n":
                fh.write(b"\n")
    try:
        for n, (k, row) in enumerate(
            map_jobs(
                func,
                [jobs[i] for i in unique],
                engine=engine,
                workers=workers,
                scheduler=scheduler,
            ),
            start=1,
        ):
            key = keys[unique[k]]
            row = {"job": key, **row}
            done[key] = row
            failed += row.get("status") == "error"
            if fh is not None:
                fh.write((json.dumps(row, allow_nan=True) + "\n").encode("utf-8"))
                fh.flush()
            if progress is not None:
                dt = time.perf_counter() - t0
                rate = n / dt if dt > 0 else 0.0
                eta = (total - n) / rate if rate > 0 else None
                progress(n, total, failed, rate, eta)
    finally:
        if fh is not None:
            fh.close()
    seconds = time.perf_counter() - t0
    rows = [done[k] for k in keys]
    files = write_table(rows, out) if out is not None else []
    return BatchResult(rows, total, reused, seconds, files)
