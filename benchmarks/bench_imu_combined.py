"""Combined preintegration: ``preintegrate_combined`` against GTSAM's loop, same run.

Run from the repository root: ``PYTHONPATH=. python benchmarks/bench_imu_combined.py [OUT.json]
[--samples N] [--repeat R] [--quick]`` (default ``benchmarks/results/imu_combined.json``; not a
test). Without ``PYTHONPATH=.`` Python imports whichever ``liebridge`` is installed: the JSON
records which one ran and whether its compiled kernel was built. Data: the first N samples
(default 40,000) of GTSAM's ``KittiEquivBiasedImu.txt``, a non-zero bias estimate, the file's noise
densities. Rows, interleaved, R repetitions: ``gtsam combined loop`` (a
``PreintegratedCombinedMeasurements`` fed with ``integrateMeasurement`` per sample) and
``liebridge combined`` (``preintegrate_combined``, compiled kernel where built). The speedup is the
median over runs of (GTSAM time / liebridge time) of the same run; the JSON records the agreement
with GTSAM (ΔR, Δp, Δv, relative 15×15 covariance). ``--quick``: 2,000 samples, 2 repeats.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import gtsam
import numpy as np

import liebridge
from liebridge.imu import kernel as _imu_kernel
from liebridge.imu import preintegrate_combined


def _where(path: Path) -> str:
    """``path`` relative to the working directory when inside it (the worktree's own copy)."""
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", nargs="?", default="benchmarks/results/imu_combined.json")
    ap.add_argument("--samples", type=int, default=40_000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--quick", action="store_true")
    argv = sys.argv[1:] if argv is None else argv
    args = ap.parse_args(argv)
    if args.quick:
        args.samples, args.repeat = 2_000, 2
    data = np.loadtxt(gtsam.findExampleDataFile("KittiEquivBiasedImu.txt"), skiprows=1)[2:]
    n = args.samples
    acc, gyro, dt = (np.ascontiguousarray(x) for x in (data[:n, 2:5], data[:n, 5:8], data[:n, 1]))
    p = gtsam.PreintegrationCombinedParams.MakeSharedU(9.8)
    p.setAccelerometerCovariance(0.01**2 * np.eye(3))  # KittiEquivBiasedImu_metadata.txt
    p.setGyroscopeCovariance(1.75e-4**2 * np.eye(3))
    p.setIntegrationCovariance(1e-8 * np.eye(3))
    p.setBiasAccCovariance(1.67e-4**2 * np.eye(3))
    p.setBiasOmegaCovariance(2.91e-6**2 * np.eye(3))
    bias = gtsam.imuBias.ConstantBias(np.array([0.05, -0.03, 0.1]), np.array([2e-3, -1e-3, 3e-3]))

    def loop() -> gtsam.PreintegratedCombinedMeasurements:
        pim = gtsam.PreintegratedCombinedMeasurements(p, bias)
        for k in range(n):
            pim.integrateMeasurement(acc[k], gyro[k], dt[k])
        return pim

    def ours() -> object:
        return preintegrate_combined(acc, gyro, dt, bias=bias, params=p)

    pim, r = loop(), preintegrate_combined(acc, gyro, dt, bias=bias, params=p)
    G = pim.preintMeasCov()
    check = {
        "max_abs_dR": float(np.abs(r.delta_R - pim.deltaRij().matrix()).max()),
        "max_abs_dp_m": float(np.abs(r.delta_p - pim.deltaPij()).max()),
        "max_abs_dv_mps": float(np.abs(r.delta_v - pim.deltaVij()).max()),
        "max_abs_dp_relative": float(
            np.abs(r.delta_p - pim.deltaPij()).max() / np.abs(pim.deltaPij()).max()
        ),
        "cov_rel": float(np.abs(r.covariance - G).max() / np.abs(G).max()),
    }
    times: dict[str, list[float]] = {"gtsam combined loop": [], "liebridge combined": []}
    for _ in range(args.repeat):
        for name, fn in (("gtsam combined loop", loop), ("liebridge combined", ours)):
            t0 = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t0)
    ref = np.array(times["gtsam combined loop"])
    compiled = _imu_kernel.COMPILED
    where = _where(Path(liebridge.__file__).parent)
    print(f"{n} samples; liebridge from {where}; compiled kernel: {compiled}")
    results = []
    for name, ts in times.items():
        t = float(np.min(ts))
        paired = float(np.median(ref / np.array(ts)))
        print(f"{name:<22} {1e3 * t:>9.2f} ms {1e6 * t / n:>8.3f} µs/sample {paired:>7.2f}x")
        results.append({"method": name, "best_seconds": t, "speedup_median_of_paired_runs": paired})
    ratio = results[1]["speedup_median_of_paired_runs"]
    print(f"preintegrate_combined is {ratio:.2f}x GTSAM's loop (target 10x)")
    print("agreement with GTSAM: " + ", ".join(f"{k} {v:.1e}" for k, v in check.items()))
    out = {
        "benchmark": "combined IMU preintegration, KittiEquivBiasedImu.txt",
        "samples": n,
        "repeat": args.repeat,
        "quick": args.quick,
        "compiled": compiled,
        "command": "PYTHONPATH=. python benchmarks/bench_imu_combined.py " + " ".join(argv or []),
        "liebridge_imported_from": where,
        "speedup_vs_gtsam_combined_loop": ratio,
        "target_speedup": 10.0,
        "agreement_with_gtsam": check,
        "results": results,
        "environment": {
            "python": sys.version.split()[0],
            "numpy": np.__version__,
            "platform": platform.platform(),
            "cpus": os.cpu_count(),
            "loadavg_1min": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
        },
    }
    path = Path(args.out)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(out, indent=2) + "\n")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
