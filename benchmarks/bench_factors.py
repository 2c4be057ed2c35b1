"""sphere2500 with factors in the ``barfoot`` convention: who pays what.

Rows (one run, same machine, odometry initialisation, GTSAM's default LM parameters):

1. GTSAM's native ``BetweenFactorPose3`` in GTSAM's own ``LevenbergMarquardtOptimizer``;
2. liebridge native factors (``between(..., native=True)``: GTSAM factors, converted noise) in
   ``liebridge.gtsam.optimize``;
3. liebridge custom factors (``native=False``) in ``liebridge.gtsam.optimize`` (batched);
4. the same, ``batch=False`` (every factor through its Python callback, no ``Values`` copy);
5. the same custom factors inside GTSAM's own LM (the per-callback ``Values`` copy), limited to
   ``--gtsam-custom-iterations`` iterations (default 2) and reported per iteration, since a full
   run takes minutes.

Usage: ``python benchmarks/bench_factors.py [--out benchmarks/results/factors.json]``.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import json
import platform
import time
from pathlib import Path
from typing import Any

import gtsam
import numpy as np

from liebridge.conventions import convert_covariance
from liebridge.factors import between, optimize, prior


def load() -> tuple[list[Any], Any]:
    graph, _ = gtsam.readG2o(gtsam.findExampleDataFile("sphere2500.txt"), True)
    edges = [graph.at(k) for k in range(graph.size())]
    init = gtsam.Values()
    init.insert(0, gtsam.Pose3())
    for f in edges:
        i, j = f.keys()
        if j == i + 1 and not init.exists(j):
            init.insert(j, init.atPose3(i).compose(f.measured()))
    return edges, init


def build(edges: list[Any], conv: str, native: bool | None) -> Any:
    prior_cov = np.eye(6) * 1e-8
    g = gtsam.NonlinearFactorGraph()
    if native is None:  # GTSAM's own factors
        g.add(
            gtsam.PriorFactorPose3(
                0, gtsam.Pose3(), gtsam.noiseModel.Gaussian.Covariance(prior_cov)
            )
        )
        for f in edges:
            g.add(f)
        return g
    g.add(
        prior(
            0,
            np.eye(4),
            convert_covariance(prior_cov, np.eye(4), "gtsam", conv),
            conv,
            native=native,
        )
    )
    for f in edges:
        i, j = f.keys()
        Z = f.measured().matrix()
        g.add(
            between(
                i,
                j,
                Z,
                convert_covariance(f.noiseModel().covariance(), Z, "gtsam", conv),
                conv,
                native=native,
            )
        )
    return g


def main(argv: list[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="benchmarks/results/factors.json")
    ap.add_argument("--convention", default="barfoot")
    ap.add_argument("--gtsam-custom-iterations", type=int, default=2)
    args = ap.parse_args(argv)
    edges, init = load()
    rows: list[dict[str, Any]] = []

    def row(name: str, seconds: float, iterations: int, error: float) -> None:
        rows.append(
            {
                "name": name,
                "seconds": seconds,
                "iterations": iterations,
                "final_error": error,
                "per_iteration_s": seconds / max(iterations, 1),
            }
        )
        print(
            f"{name:58s} {seconds:8.2f} s  {iterations:4d} it  "
            f"{seconds / max(iterations, 1) * 1e3:8.1f} ms/it  error {error:.10g}",
            flush=True,
        )

    g = build(edges, args.convention, None)
    t = time.perf_counter()
    opt = gtsam.LevenbergMarquardtOptimizer(g, init, gtsam.LevenbergMarquardtParams())
    r = opt.optimize()
    row(
        "GTSAM native BetweenFactorPose3, GTSAM LM",
        time.perf_counter() - t,
        opt.iterations(),
        g.error(r),
    )
    for native, batch, name in [
        (True, True, f"liebridge native ({args.convention}), liebridge.optimize"),
        (False, True, f"liebridge custom ({args.convention}), liebridge.optimize (batched)"),
        (False, False, f"liebridge custom ({args.convention}), liebridge.optimize (callbacks)"),
    ]:
        g = build(edges, args.convention, native)
        res = optimize(g, init, progress=False, batch=batch)
        row(name, res.seconds, res.iterations, res.final_error)
    g = build(edges, args.convention, False)
    p = gtsam.LevenbergMarquardtParams()
    p.setMaxIterations(args.gtsam_custom_iterations)
    t = time.perf_counter()
    opt = gtsam.LevenbergMarquardtOptimizer(g, init, p)
    r = opt.optimize()
    row(
        f"liebridge custom ({args.convention}), GTSAM LM (limited iterations)",
        time.perf_counter() - t,
        opt.iterations(),
        g.error(r),
    )
    out = {
        "benchmark": "sphere2500",
        "machine": platform.processor() or platform.machine(),
        "python": platform.python_version(),
        "gtsam": importlib.metadata.version("gtsam"),
        "rows": rows,
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
