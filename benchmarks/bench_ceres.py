"""pyceres with liebridge's costs against GTSAM's LM on the same pose graph: time and final cost.

Rows (same machine, same run, odometry initialisation, a prior on the first pose in both):

1. GTSAM ``BetweenFactorPose3`` in GTSAM's ``LevenbergMarquardtOptimizer`` (run to convergence:
   relative and absolute error tolerances 0, at most ``--iterations``);
2. ``liebridge.ceres.problem_from_values(graph, values, convention="gtsam")`` solved by pyceres's
   LM (sparse normal Cholesky, tolerances 1e-16, at most ``--iterations``): every cost is a Python
   callback, which is what a pyceres user pays;
3. the same with costs in the ``barfoot`` convention.

A measurement, not a target. sphere2500 (``gtsam.readG2o``'s reading) takes minutes through
Python callbacks; ``--max-poses`` keeps the first N poses and the edges among them.

Usage: ``python benchmarks/bench_ceres.py [--dataset sphere2500.txt] [--max-poses N]
[--out benchmarks/results/ceres.json]``.
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
import pyceres

from liebridge import ceres as lbc


def load(dataset: str, max_poses: int | None) -> tuple[Any, Any]:
    graph_in, _ = gtsam.readG2o(gtsam.findExampleDataFile(dataset), True)
    edges = [graph_in.at(k) for k in range(graph_in.size())]
    init = gtsam.Values()
    init.insert(0, gtsam.Pose3())
    graph = gtsam.NonlinearFactorGraph()
    graph.add(gtsam.PriorFactorPose3(0, gtsam.Pose3(), gtsam.noiseModel.Isotropic.Sigma(6, 1e-3)))
    for f in edges:
        i, j = f.keys()
        if max_poses is not None and max(i, j) >= max_poses:
            continue
        if j == i + 1 and not init.exists(j):
            init.insert(j, init.atPose3(i).compose(f.measured()))
        noise = gtsam.noiseModel.Gaussian.Covariance(f.noiseModel().covariance())
        graph.add(gtsam.BetweenFactorPose3(i, j, f.measured(), noise))
    return graph, init


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", default="sphere2500.txt")
    ap.add_argument("--max-poses", type=int, default=None)
    ap.add_argument("--iterations", type=int, default=100)
    ap.add_argument("--conventions", default="gtsam,barfoot", help="comma-separated")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    graph, init = load(args.dataset, args.max_poses)
    rows: list[dict[str, Any]] = []

    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(0.0)
    params.setAbsoluteErrorTol(0.0)
    params.setMaxIterations(args.iterations)
    t0 = time.perf_counter()
    opt = gtsam.LevenbergMarquardtOptimizer(graph, init, params)
    result = opt.optimize()
    t_gtsam = time.perf_counter() - t0
    f_gtsam = graph.error(result)
    rows.append(
        {
            "run": "GTSAM BetweenFactorPose3, GTSAM LM",
            "time_s": t_gtsam,
            "iterations": opt.iterations(),
            "final_cost": f_gtsam,
        }
    )
    for convention in args.conventions.split(","):
        t0 = time.perf_counter()
        cp = lbc.problem_from_values(graph, init, convention=convention)
        t_build = time.perf_counter() - t0
        options = pyceres.SolverOptions()
        options.linear_solver_type = pyceres.LinearSolverType.SPARSE_NORMAL_CHOLESKY
        options.max_num_iterations = args.iterations
        options.function_tolerance = options.gradient_tolerance = 1e-16
        options.parameter_tolerance = 1e-16
        t0 = time.perf_counter()
        summary = cp.solve(options)
        t_solve = time.perf_counter() - t0
        rows.append(
            {
                "run": f"pyceres LM, liebridge {convention} costs",
                "time_s": t_solve,
                "build_s": t_build,
                "iterations": summary.num_successful_steps + summary.num_unsuccessful_steps,
                "final_cost": cp.cost(),
            }
        )
    machine = platform.processor() or platform.machine()
    print(f"{args.dataset} ({init.size()} poses, {graph.size()} factors), {machine}")
    print("| run | time | iterations | final cost | cost / GTSAM's − 1 |")
    print("|---|---|---|---|---|")
    for r in rows:
        extra = f" (+{r['build_s']:.2f} s building)" if "build_s" in r else ""
        print(
            f"| {r['run']} | {r['time_s']:.2f} s{extra} | {r['iterations']} | "
            f"{r['final_cost']:.10g} | {r['final_cost'] / f_gtsam - 1:.1e} |"
        )
    print(f"ratio pyceres(gtsam costs) / GTSAM: {rows[1]['time_s'] / t_gtsam:.1f}×")
    if args.out:
        meta = {
            "pyceres": importlib.metadata.version("pyceres"),
            "gtsam": importlib.metadata.version("gtsam"),
            "numpy": np.__version__,
            "machine": platform.machine(),
        }
        Path(args.out).write_text(json.dumps({"meta": meta, "rows": rows}, indent=2))


if __name__ == "__main__":
    main()
