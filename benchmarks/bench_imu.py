"""Vectorized IMU preintegration against GTSAM's ``integrateMeasurement`` in a Python loop.

Run: ``python benchmarks/bench_imu.py [OUT.json] [--samples N] [--repeat R] [--quick]`` (prints a
table and writes JSON, default ``benchmarks/results/imu.json``; not a test). Data: the first N
samples (default 40,000) of GTSAM's ``KittiEquivBiasedImu.txt`` with a non-zero bias estimate.
Rows, all timed in the same run, best of R repetitions of wall-clock time:

* gtsam manifold loop  — ``PreintegratedImuMeasurementsManifold.integrateMeasurement`` per sample
  (the on-manifold preintegration liebridge reproduces; the reference of the ratio)
* gtsam tangent loop   — the same with the default ``PreintegratedImuMeasurements``
* liebridge preintegrate — ``liebridge.factors.preintegrate`` (validation included), with the
  compiled kernel where it is built (the JSON's ``compiled`` says whether it was)
* liebridge numpy kernel — the same validation and numbers with the numpy kernel forced (what
  ``preintegrate`` does where no C compiler built the optional kernel)
* liebridge incremental  — ``ImuPreintegrator.integrate`` per sample, then ``result()``
* window sizes          — the same comparison on 100- and 1,000-sample windows (keyframe sizes)

``--quick`` (2,000 samples, 2 repeats) is the smoke run ``benchmarks/run.py --quick`` makes.

The speedup column is the median, over the interleaved runs, of (GTSAM loop time / method time)
within the same run: on a shared machine the load drifts, and pairing runs cancels most of it.

The JSON also records the agreement with GTSAM (max |ΔR|, |Δp|, |Δv|, relative covariance and
bias-Jacobian differences) so that speed is never reported for a wrong answer.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from collections.abc import Callable
from pathlib import Path

import gtsam
import numpy as np

from liebridge.imu import ImuPreintegrator, preintegrate
from liebridge.imu import inputs as _imu_inputs
from liebridge.imu import kernel as _imu_kernel


def best_of(fn: Callable[[], object], repeat: int) -> float:
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return float(best)


def load(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    data = np.loadtxt(gtsam.findExampleDataFile("KittiEquivBiasedImu.txt"), skiprows=1)[2:]
    if n > len(data):
        raise SystemExit(f"--samples {n}: the file has only {len(data)} usable samples")
    return (
        np.ascontiguousarray(data[:n, 2:5]),
        np.ascontiguousarray(data[:n, 5:8]),
        np.ascontiguousarray(data[:n, 1]),
    )


def params() -> gtsam.PreintegrationParams:
    p = gtsam.PreintegrationParams.MakeSharedU(9.8)
    p.setAccelerometerCovariance(0.01**2 * np.eye(3))  # KittiEquivBiasedImu_metadata.txt
    p.setGyroscopeCovariance(1.75e-4**2 * np.eye(3))
    p.setIntegrationCovariance(1e-8 * np.eye(3))
    return p


def agreement(acc, gyro, dt, p, bias) -> dict[str, float]:
    pim = gtsam.PreintegratedImuMeasurementsManifold(p, bias)
    for a, w, d in zip(acc, gyro, dt, strict=True):
        pim.integrateMeasurement(a, w, d)
    r = preintegrate(acc, gyro, dt, bias=bias, params=p)
    H1 = np.zeros((9, 9), order="F")
    H2 = np.zeros((9, 6), order="F")
    pim.predict(gtsam.NavState(), bias, H1, H2)
    R = pim.deltaRij().matrix()
    J = np.vstack([H2[0:3], R @ H2[3:6], R @ H2[6:9]])
    G = pim.preintMeasCov()
    return {
        "max_abs_dR": float(np.abs(r.delta_R - R).max()),
        "max_abs_dp_m": float(np.abs(r.delta_p - pim.deltaPij()).max()),
        "max_abs_dv_mps": float(np.abs(r.delta_v - pim.deltaVij()).max()),
        "cov_rel": float(np.abs(r.covariance - G).max() / np.abs(G).max()),
        "bias_jacobian_rel": float(np.abs(r.bias_jacobian - J).max() / np.abs(J).max()),
    }


def bench(n: int, repeat: int, acc, gyro, dt, p, bias) -> dict[str, list[float]]:
    acc, gyro, dt = acc[:n], gyro[:n], dt[:n]

    def gtsam_loop(cls: type) -> Callable[[], object]:
        def run() -> object:
            pim = cls(p, bias)
            for k in range(n):
                pim.integrateMeasurement(acc[k], gyro[k], dt[k])
            return pim

        return run

    def incremental() -> object:
        inc = ImuPreintegrator(p, bias)
        for k in range(n):
            inc.integrate(acc[k], gyro[k], dt[k])
        return inc.result()

    def numpy_kernel() -> object:
        a, g, d = _imu_inputs.read_samples(acc, gyro, dt)
        b = _imu_inputs.read_bias(bias)
        return _imu_kernel.integrate_blocks(a, g, d, b, _imu_inputs.read_params(p), compiled=False)

    rows = {
        "gtsam manifold loop": gtsam_loop(gtsam.PreintegratedImuMeasurementsManifold),
        "gtsam tangent loop": gtsam_loop(gtsam.PreintegratedImuMeasurements),
        "liebridge preintegrate": lambda: preintegrate(acc, gyro, dt, bias=bias, params=p),
        "liebridge numpy kernel": numpy_kernel,
        "liebridge incremental": incremental,
    }
    # interleave the rows so that machine load hits all of them alike; keep every run so that the
    # speedup can be taken run by run (paired), which is robust to load drifting during the run
    times: dict[str, list[float]] = {name: [] for name in rows}
    for _ in range(repeat):
        for name, fn in rows.items():
            times[name].append(best_of(fn, 1))
    return times


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", nargs="?", default="benchmarks/results/imu.json")
    ap.add_argument("--samples", type=int, default=40_000)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--quick", action="store_true", help="2,000 samples, 2 repeats (smoke run)")
    args = ap.parse_args(argv)
    if args.quick:
        args.samples, args.repeat = 2_000, 2

    acc, gyro, dt = load(args.samples)
    p = params()
    bias = gtsam.imuBias.ConstantBias(np.array([0.05, -0.03, 0.1]), np.array([2e-3, -1e-3, 3e-3]))
    check = agreement(acc, gyro, dt, p, bias)

    sizes = sorted({100, 1_000, args.samples})
    results = []
    cpu = platform.processor() or platform.machine()
    compiled = _imu_kernel.compiled_applies(_imu_inputs.read_params(p))
    print(f"numpy {np.__version__}, {cpu}, {os.cpu_count()} CPUs; compiled kernel: {compiled}")
    header = f"{'N':>7} {'method':<24} {'best [ms]':>11} {'per sample [µs]':>16}"
    print(f"{header} {'vs manifold loop':>17}")
    ref_name = "gtsam manifold loop"
    for n in sizes:
        runs = bench(n, args.repeat, acc, gyro, dt, p, bias)
        ref = np.array(runs[ref_name])
        for name, ts in runs.items():
            t = float(np.min(ts))
            paired = float(np.median(ref / np.array(ts)))  # speedup, run by run
            print(f"{n:>7} {name:<24} {1e3 * t:>11.2f} {1e6 * t / n:>16.3f} {paired:>16.2f}x")
            results.append(
                {
                    "samples": n,
                    "method": name,
                    "best_seconds": t,
                    "median_seconds": float(np.median(ts)),
                    "speedup_median_of_paired_runs": paired,
                    "speedup_of_best_times": float(ref.min() / t),
                }
            )
    final = {r["method"]: r for r in results if r["samples"] == args.samples}
    ratio = final["liebridge preintegrate"]["speedup_median_of_paired_runs"]
    ratio_best = final["liebridge preintegrate"]["speedup_of_best_times"]
    ratio_numpy = final["liebridge numpy kernel"]["speedup_median_of_paired_runs"]
    kernel = "compiled kernel" if compiled else "numpy kernel: no compiled kernel built"
    print(
        f"\n{args.samples} samples: liebridge preintegrate ({kernel}) is {ratio:.1f}x faster than "
        f"the GTSAM manifold loop (median of paired runs; {ratio_best:.1f}x from best times; "
        f"target 10x); numpy kernel {ratio_numpy:.1f}x"
    )
    agree = ", ".join(f"{k} {v:.1e}" for k, v in check.items())
    print(f"agreement with GTSAM on the same samples: {agree}")
    out = {
        "benchmark": "IMU preintegration, KittiEquivBiasedImu.txt",
        "samples": args.samples,
        "repeat": args.repeat,
        "timing": "wall clock; `repeat` interleaved runs of every method; the speedup is the "
        "median over runs of (GTSAM loop time / liebridge time) of the same run",
        "compiled": compiled,
        "speedup_vs_gtsam_manifold_loop": ratio,
        "speedup_vs_gtsam_manifold_loop_best_times": ratio_best,
        "numpy_kernel_speedup_vs_gtsam_manifold_loop": ratio_numpy,
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
