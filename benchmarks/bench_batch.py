"""Fleet evaluation throughput: serial, a process pool and Dask against the hand-written loop.

Run: ``python benchmarks/bench_batch.py [OUT.json] [--pairs N] [--poses P] [--workers W]
[--repeat R] [--quick]`` (prints a table and writes JSON, default
``benchmarks/results/batch.json``; not a test). Data: N synthetic (REF, EST) TUM pairs of P poses
each (default 200 × 10,000: a helix with attitude wiggles, 10 Hz; the estimate perturbed by
``Exp(ξ)``, stamps jittered by ±3 ms), written once at full precision.

Rows, each the median of R interleaved repeats (the machine may be shared: compare ratios):

* **hand loop** — what a user would otherwise write: a Python loop over the pairs calling
  ``io.trajfile.read_trajectory`` twice, ``traj.synchronize``, ``traj.align``, ``traj.ape`` and
  ``traj.rpe`` with ``traj.statistics`` (the same numbers, no rows, no error handling, no table).
* **serial** — ``liebridge.batch.run(evaluate, jobs, TABLE)``: the same work plus the batch layer
  (option filling, error capture, one flat row, the journal line per log, the CSV/Parquet table
  at the end). ``overhead`` = serial / hand loop − 1 (target ≤ 5 %), in CPU time of the calling
  thread (``time.thread_time``: the Dask client's and in-process scheduler's threads are not
  counted), the table files excluded (written once per batch, not per log). Each repeat runs the
  hand loop and the serial batch back to back twice, in the order hand, serial, serial, hand, and
  takes the ratio of each adjacent pair; the overhead reported is the **median of those 2·R
  ratios** (with their range), so one run disturbed by another job on a shared machine does not
  decide it.
* **processes**, **dask** — ``engine="processes"`` / ``"dask"`` (a ``LocalCluster`` of W
  workers, one thread each, dask's ``MALLOC_TRIM_THRESHOLD_`` removed) with W workers. The
  steady-state throughput is measured from the completion times of the jobs after the first
  2·W (pool or cluster started, workers warm); the wall time with start-up is reported too.
  ``dask (default env)`` is the same cluster with dask's default worker environment.
  Target on a 2-core machine, W = 2: ≥ 1.7× the serial throughput.

Every engine's table is checked equal to the serial one before any speed is reported.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from liebridge import batch, traj
from liebridge.io import trajfile
from liebridge.lie import se3

METRICS = "ape,rpe"


def make_pairs(root: Path, pairs: int, n: int) -> list[dict[str, str]]:
    jobs = []
    for k in range(pairs):
        rng = np.random.default_rng(k)
        s = 0.1 * np.arange(n)
        a = rng.uniform(0.03, 0.08)
        w = np.column_stack([0.05 * np.sin(0.7 * s), 0.03 * np.sin(1.3 * s), a * s])
        T = se3.exp(np.column_stack([w, np.zeros((n, 3))]))
        T[:, :3, 3] = np.column_stack([20 * np.cos(a * s), 20 * np.sin(a * s), 0.05 * s])
        t = 1.6e9 + 0.1 * np.arange(n)
        sigma = np.array([0.002] * 3 + [0.02] * 3)
        T_est = T @ se3.exp(rng.normal(size=(n, 6)) * sigma)
        ref, est = root / f"run{k:05d}_ref.txt", root / f"run{k:05d}_est.txt"
        trajfile.write_trajectory(ref, t, T)
        trajfile.write_trajectory(est, t + rng.uniform(-0.003, 0.003, n), T_est)
        jobs.append({"ref": str(ref), "est": str(est), "metrics": METRICS})
    return jobs


def hand_loop(jobs: list[dict[str, str]]) -> list[tuple[float, float]]:
    out = []
    for j in jobs:
        t_r, T_r = trajfile.read_trajectory(j["ref"])
        t_e, T_e = trajfile.read_trajectory(j["est"])
        s = traj.synchronize(t_r, T_r, t_e, T_e)
        T_a = traj.align(s.T_ref, s.T_est, "none").apply(s.T_est)
        ape = traj.statistics(traj.ape(s.T_ref, T_a))
        rpe = traj.statistics(traj.rpe(s.T_ref, T_a)[0])
        out.append((ape.rmse, rpe.rmse))
    return out


def layer_pair(jobs: list[dict[str, Any]], out: Path, serial_first: bool) -> float:
    """Return ``serial / hand loop − 1`` in calling-thread CPU per log, run back to back.

    The serial batch's CPU is read at its last progress call: every log's work and journal line,
    not the table files written once at the end.
    """

    def hand() -> float:
        c = time.thread_time()
        hand_loop(jobs)
        return time.thread_time() - c

    def serial() -> float:
        for p in (out, out.with_suffix(".jsonl"), out.with_suffix(".parquet")):
            p.unlink(missing_ok=True)
        last: list[float] = []
        c = time.thread_time()
        batch.run(batch.evaluate, jobs, out, progress=lambda *a: last.append(time.thread_time()))
        return last[-1] - c

    if serial_first:
        s, h = serial(), hand()
    else:
        h, s = hand(), serial()
    return s / h - 1.0


def timed_evaluate(**job: Any) -> dict[str, Any]:
    """``batch.evaluate`` and the CPU time it took in the worker that ran it."""
    c = time.process_time()
    row = batch.evaluate(**job)
    row["_cpu_s"] = time.process_time() - c
    return row


def timed_run(jobs: list[dict[str, Any]], out: Path, **engine: Any) -> dict[str, Any]:
    for p in (out, out.with_suffix(".jsonl"), out.with_suffix(".parquet")):
        p.unlink(missing_ok=True)
    stamps: list[float] = []
    t0, c0 = time.perf_counter(), time.process_time()
    res = batch.run(
        timed_evaluate, jobs, out, progress=lambda *a: stamps.append(time.perf_counter()), **engine
    )
    wall, cpu_main = time.perf_counter() - t0, time.process_time() - c0
    workers = int(engine.get("workers") or 1)
    k = min(2 * workers, len(stamps) - 2)
    steady = (len(stamps) - k) / (stamps[-1] - stamps[k - 1]) if k >= 1 else len(stamps) / wall
    cpu_job = statistics.mean(r["_cpu_s"] for r in res.rows)
    rows = [{k: v for k, v in r.items() if k != "_cpu_s"} for r in res.rows]
    return {
        "wall_s": wall,
        "steady": steady,
        "cpu_job": cpu_job,
        "cpu_main": cpu_main,
        "rows": rows,
    }


def same(a: list[dict[str, Any]], b: list[dict[str, Any]]) -> bool:
    for x, y in zip(a, b, strict=True):
        for key in x:
            if key == "job":  # the hash of the function's name: timed_evaluate vs evaluate
                continue
            u, v = x[key], y[key]
            if isinstance(u, float) and isinstance(v, float):
                if not math.isclose(u, v, rel_tol=1e-12):
                    return False
            elif u != v:
                return False
    return True


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", nargs="?", default="benchmarks/results/batch.json")
    ap.add_argument("--pairs", type=int, default=200)
    ap.add_argument("--poses", type=int, default=10_000)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="12 pairs of 500 poses, one repeat")
    args = ap.parse_args()
    logging.getLogger("distributed").setLevel(logging.ERROR)  # no INFO lines on cluster close
    if args.quick:
        args.pairs, args.poses, args.repeat = 12, 500, 1
    try:
        import distributed
    except ImportError:
        distributed = None
    W = args.workers
    samples: dict[str, dict[str, list[float]]] = {"hand loop": {}, "serial": {}}

    def record(name: str, **values: float) -> None:
        for key, v in values.items():
            samples.setdefault(name, {}).setdefault(key, []).append(v)

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        t0 = time.perf_counter()
        jobs = make_pairs(root, args.pairs, args.poses)
        print(f"{args.pairs} pairs of {args.poses} poses written in "
              f"{time.perf_counter() - t0:.1f} s", file=sys.stderr)  # fmt: skip
        hand_loop(jobs[:2])  # imports, page cache
        reference = batch.run(batch.evaluate, jobs).rows
        got = [(row["ape_rmse"], row["rpe_rmse"]) for row in reference]
        assert np.allclose(got, hand_loop(jobs), rtol=1e-12), "batch.evaluate != hand loop"
        batch.write_table(reference, root / "warm.csv")  # pyarrow imported outside the timing
        clients: dict[str, Any] = {}
        clusters = []
        if distributed is not None:
            for name, trim in (("warm", False), ("default env", True)):
                clusters.append(batch.local_cluster(W, trim_env=trim))
                clients[name] = distributed.Client(clusters[-1])
        try:
            for rep in range(args.repeat):
                # the batch layer's overhead: hand, serial | serial, hand (two adjacent pairs)
                record("serial", overhead=layer_pair(jobs, root / "pair.csv", serial_first=False))
                t, c = time.perf_counter(), time.process_time()
                hand_loop(jobs)
                dt, dc = time.perf_counter() - t, time.process_time() - c
                record("hand loop", steady=len(jobs) / dt, wall_s=dt, cpu_job=dc / len(jobs),
                       load=os.getloadavg()[0])  # fmt: skip
                runs: list[tuple[str, dict[str, Any]]] = [
                    ("serial", {"engine": "serial"}),
                    ("processes", {"engine": "processes", "workers": W}),
                ]
                if distributed is not None:
                    runs += [
                        ("dask (new LocalCluster)", {"engine": "dask", "workers": W}),
                        ("dask (warm LocalCluster)",
                         {"engine": "dask", "scheduler": clients["warm"]}),
                        ("dask (default worker env)",
                         {"engine": "dask", "scheduler": clients["default env"]}),
                    ]  # fmt: skip
                for name, eng in runs:
                    r = timed_run(jobs, root / "table.csv", **eng)
                    assert same(reference, r["rows"]), f"{name}: table differs from serial"
                    record(name, steady=r["steady"], wall_s=r["wall_s"], cpu_job=r["cpu_job"],
                           load=os.getloadavg()[0])  # fmt: skip
                record("serial", overhead=layer_pair(jobs, root / "pair.csv", serial_first=True))
                print(f"repeat {rep + 1}/{args.repeat} done", file=sys.stderr)
        finally:
            batch.engine.close_quietly(*clients.values(), *clusters)
    med = {name: {k: statistics.median(v) for k, v in d.items()} for name, d in samples.items()}
    serial = med["serial"]
    rows = []
    for name, m in med.items():
        workers = 1 if name in ("hand loop", "serial") else W
        rows.append({
            "engine": name,
            "logs_per_s": m["steady"],
            "wall_s": m["wall_s"],
            "vs_serial": m["steady"] / serial["steady"],
            "cpu_ms_per_log": 1e3 * m["cpu_job"],
            "capacity_vs_serial": workers * serial["cpu_job"] / m["cpu_job"],
            "load": m["load"],
        })  # fmt: skip
    ratios = samples["serial"]["overhead"]
    overhead = statistics.median(ratios)
    result = {
        "config": {"pairs": args.pairs, "poses": args.poses, "workers": W, "repeat": args.repeat,
                   "quick": args.quick, "metrics": METRICS},
        "machine": {"platform": platform.platform(), "cpus": os.cpu_count(),
                    "python": platform.python_version()},
        "rows": rows,
        "batch_overhead_per_log_cpu": overhead,
        "batch_overhead_samples": ratios,
        "samples": samples,
    }  # fmt: skip
    print(f"{'engine':<27}{'logs/s':>8}{'wall s':>8}{'× serial':>9}{'CPU ms/log':>11}"
          f"{'capacity ×':>11}{'load':>6}")  # fmt: skip
    for r in rows:
        print(f"{r['engine']:<27}{r['logs_per_s']:>8.2f}{r['wall_s']:>8.1f}"
              f"{r['vs_serial']:>9.2f}{r['cpu_ms_per_log']:>11.1f}"
              f"{r['capacity_vs_serial']:>11.2f}{r['load']:>6.1f}")  # fmt: skip
    print(f"batch layer per-log overhead (calling-thread CPU, serial batch without its table "
          f"files / hand loop − 1), median of {len(ratios)} adjacent pairs: "
          f"{100 * overhead:+.1f} % (range {100 * min(ratios):+.1f} to "
          f"{100 * max(ratios):+.1f} %)")  # fmt: skip
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
