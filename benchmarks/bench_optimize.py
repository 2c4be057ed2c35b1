"""Custom-convention graphs: ``liebridge.gtsam.optimize`` against GTSAM's native LM.

What a user would otherwise run: GTSAM's ``LevenbergMarquardtOptimizer`` on GTSAM's own
``BetweenFactorPose3``. Against it, in the same process, interleaved and repeated (median):
liebridge custom (exact) factors in the ``barfoot`` convention through ``optimize``. Both start
from the odometry initialisation with GTSAM's default parameters; the row records both iteration
counts and final errors (the optimum must be the same). Wall-clock and process CPU time are both
recorded: on a machine shared with other jobs the CPU-time ratio is the steadier one.
``--convention g2o`` (or ``ros``) measures a convention whose chart is not the SE(3) exponential
(the generic, not the fused, batched path).

``--replicas R`` chains R copies of sphere2500 (each copy's first pose tied to the previous
copy's last one by a between factor, σ = 0.1) — the 10,000-pose question.

Usage: ``python benchmarks/bench_optimize.py [--reps 3] [--replicas 1]
[--out benchmarks/results/optimize.json]``.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import json
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import gtsam
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_factors import load

from liebridge.conventions import convert_covariance
from liebridge.factors import between, optimize, prior

N_SPHERE = 2500


def graphs(conv: str, replicas: int) -> tuple[Any, Any, Any]:
    """GTSAM-native graph, liebridge custom graph (``conv``), initial values."""
    edges, init0 = load()
    prior_cov = np.eye(6) * 1e-8
    link_cov = np.eye(6) * 0.01
    gn = gtsam.NonlinearFactorGraph()
    gc = gtsam.NonlinearFactorGraph()
    init = gtsam.Values()
    gn.add(
        gtsam.PriorFactorPose3(0, gtsam.Pose3(), gtsam.noiseModel.Gaussian.Covariance(prior_cov))
    )
    gc.add(
        prior(
            0,
            np.eye(4),
            convert_covariance(prior_cov, np.eye(4), "gtsam", conv),
            conv,
            native=False,
        )
    )

    def add(i: int, j: int, Z: Any, cov: np.ndarray) -> None:
        gn.add(gtsam.BetweenFactorPose3(i, j, Z, gtsam.noiseModel.Gaussian.Covariance(cov)))
        M = Z.matrix()
        gc.add(between(i, j, M, convert_covariance(cov, M, "gtsam", conv), conv, native=False))

    for r in range(replicas):
        off = r * N_SPHERE
        for k in range(N_SPHERE):
            init.insert(off + k, init0.atPose3(k))
        for f in edges:
            i, j = f.keys()
            add(off + i, off + j, f.measured(), f.noiseModel().covariance())
        if r:
            add(off - 1, off, init0.atPose3(N_SPHERE - 1).between(init0.atPose3(0)), link_cov)
    return gn, gc, init


def main(argv: list[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="benchmarks/results/optimize.json")
    ap.add_argument("--convention", default="barfoot")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--replicas", type=int, default=1)
    args = ap.parse_args(argv)
    gn, gc, init = graphs(args.convention, args.replicas)
    t_gtsam: list[float] = []
    t_lb: list[float] = []
    cpu_gtsam: list[float] = []
    cpu_lb: list[float] = []
    for _ in range(args.reps):
        t, c = time.perf_counter(), time.process_time()
        opt = gtsam.LevenbergMarquardtOptimizer(gn, init, gtsam.LevenbergMarquardtParams())
        r = opt.optimize()
        t_gtsam.append(time.perf_counter() - t)
        cpu_gtsam.append(time.process_time() - c)
        c = time.process_time()
        res = optimize(gc, init, gtsam.LevenbergMarquardtParams(), progress=False)
        cpu_lb.append(time.process_time() - c)
        t_lb.append(res.seconds)
        print(
            f"GTSAM LM {t_gtsam[-1]:.2f} s, CPU {cpu_gtsam[-1]:.2f} s ({opt.iterations()} it, "
            f"error {gn.error(r):.10g}); liebridge {t_lb[-1]:.2f} s, CPU {cpu_lb[-1]:.2f} s "
            f"({res.iterations} it, error {res.final_error:.10g})",
            flush=True,
        )
    ratio = statistics.median(t_lb) / statistics.median(t_gtsam)
    ratio_cpu = statistics.median(cpu_lb) / statistics.median(cpu_gtsam)
    print(f"ratio (median liebridge / median GTSAM): wall {ratio:.2f}, CPU {ratio_cpu:.2f}")
    lscpu = subprocess.run(["lscpu"], capture_output=True, text=True, check=False).stdout
    out = {
        "benchmark": f"sphere2500 x{args.replicas}, custom {args.convention} factors",
        "machine": [ln for ln in lscpu.splitlines() if ln.startswith(("Model name", "CPU(s)"))],
        "python": platform.python_version(),
        "gtsam": importlib.metadata.version("gtsam"),
        "poses": N_SPHERE * args.replicas,
        "gtsam_lm_s": t_gtsam,
        "liebridge_optimize_s": t_lb,
        "gtsam_lm_cpu_s": cpu_gtsam,
        "liebridge_optimize_cpu_s": cpu_lb,
        "gtsam_iterations": opt.iterations(),
        "gtsam_final_error": float(gn.error(r)),
        "liebridge_iterations": res.iterations,
        "liebridge_final_error": res.final_error,
        "ratio_median": ratio,
        "ratio_cpu_median": ratio_cpu,
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
