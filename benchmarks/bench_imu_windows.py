"""Keyframe windows: ``preintegrate_windows`` against GTSAM's loop over the same windows.

Run: ``python benchmarks/bench_imu_windows.py [OUT.json] [--window W] [--repeat R] [--quick]``
(prints a table and writes JSON, default ``benchmarks/results/imu_windows.json``; not a test).
Data: the whole of GTSAM's ``KittiEquivBiasedImu.txt`` (46,966 samples after the first two rows)
cut into W-sample windows (default 100; the last one is shorter), a non-zero bias estimate.
Rows, all timed in the same run, interleaved, R repetitions of wall-clock time:

* gtsam manifold loop    — per window, a new ``PreintegratedImuMeasurementsManifold`` fed with
  ``integrateMeasurement`` per sample (what a front end does at every keyframe; the reference)
* liebridge windows      — ``liebridge.factors.preintegrate_windows`` (validation included), with
  the compiled kernel where it is built (the JSON's ``compiled`` says whether it was)
* liebridge windows numpy — the same with the numpy kernel forced (it loops over windows in Python)
* liebridge per-window    — ``preintegrate`` called once per window (what batching replaces)

The speedup is the median over runs of (GTSAM loop time / method time) of the same run.
The JSON also records the largest difference to GTSAM over all windows (ΔR, Δp, Δv, relative
covariance and bias Jacobians), so that a speed is never reported for a wrong answer.
``--quick`` (the first 2,000 samples, 2 repeats) is the smoke run.
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

from liebridge.imu import inputs as _imu_inputs
from liebridge.imu import kernel as _imu_kernel
from liebridge.imu import preintegrate, preintegrate_windows


def load(n: int | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    data = np.loadtxt(gtsam.findExampleDataFile("KittiEquivBiasedImu.txt"), skiprows=1)[2:]
    data = data if n is None else data[:n]
    return (
        np.ascontiguousarray(data[:, 2:5]),
        np.ascontiguousarray(data[:, 5:8]),
        np.ascontiguousarray(data[:, 1]),
    )


def params() -> gtsam.PreintegrationParams:
    p = gtsam.PreintegrationParams.MakeSharedU(9.8)
    p.setAccelerometerCovariance(0.01**2 * np.eye(3))  # KittiEquivBiasedImu_metadata.txt
    p.setGyroscopeCovariance(1.75e-4**2 * np.eye(3))
    p.setIntegrationCovariance(1e-8 * np.eye(3))
    return p


def gtsam_windows(acc, gyro, dt, starts, p, bias) -> list[object]:
    ends = np.append(starts[1:], len(dt))
    out = []
    for s, e in zip(starts.tolist(), ends.tolist(), strict=True):
        pim = gtsam.PreintegratedImuMeasurementsManifold(p, bias)
        for k in range(s, e):
            pim.integrateMeasurement(acc[k], gyro[k], dt[k])
        out.append(pim)
    return out


def agreement(res, pims, bias) -> dict[str, float]:
    worst = dict.fromkeys(
        ["max_abs_dR", "max_abs_dp_m", "max_abs_dv_mps", "cov_rel", "bias_jacobian_rel"], 0.0
    )
    for k, pim in enumerate(pims):
        H1 = np.zeros((9, 9), order="F")
        H2 = np.zeros((9, 6), order="F")
        pim.predict(gtsam.NavState(), bias, H1, H2)
        R = pim.deltaRij().matrix()
        J = np.vstack([H2[0:3], R @ H2[3:6], R @ H2[6:9]])
        G = pim.preintMeasCov()
        now = {
            "max_abs_dR": np.abs(res.delta_R[k] - R).max(),
            "max_abs_dp_m": np.abs(res.delta_p[k] - pim.deltaPij()).max(),
            "max_abs_dv_mps": np.abs(res.delta_v[k] - pim.deltaVij()).max(),
            "cov_rel": np.abs(res.covariance[k] - G).max() / np.abs(G).max(),
            "bias_jacobian_rel": np.abs(res.bias_jacobian[k] - J).max() / np.abs(J).max(),
        }
        worst = {key: max(worst[key], float(v)) for key, v in now.items()}
    return worst


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", nargs="?", default="benchmarks/results/imu_windows.json")
    ap.add_argument("--window", type=int, default=100)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--quick", action="store_true", help="2,000 samples, 2 repeats (smoke run)")
    args = ap.parse_args(argv)
    acc, gyro, dt = load(2_000 if args.quick else None)
    if args.quick:
        args.repeat = 2
    n = len(dt)
    starts = np.arange(0, n, args.window)
    p = params()
    bias = gtsam.imuBias.ConstantBias(np.array([0.05, -0.03, 0.1]), np.array([2e-3, -1e-3, 3e-3]))
    ends = np.append(starts[1:], n)

    def windows() -> object:
        return preintegrate_windows(acc, gyro, dt, starts, bias=bias, params=p)

    def windows_numpy() -> object:
        ext = _imu_kernel._imu_ext
        _imu_kernel._imu_ext = None  # the numpy kernel, as where no C compiler built the kernel
        try:
            return windows()
        finally:
            _imu_kernel._imu_ext = ext

    def per_window() -> object:
        return [
            preintegrate(acc[s:e], gyro[s:e], dt[s:e], bias=bias, params=p)
            for s, e in zip(starts.tolist(), ends.tolist(), strict=True)
        ]

    rows: dict[str, Callable[[], object]] = {
        "gtsam manifold loop": lambda: gtsam_windows(acc, gyro, dt, starts, p, bias),
        "liebridge windows": windows,
        "liebridge windows numpy": windows_numpy,
        "liebridge per-window": per_window,
    }
    check = agreement(windows(), gtsam_windows(acc, gyro, dt, starts, p, bias), bias)
    times: dict[str, list[float]] = {name: [] for name in rows}
    for _ in range(args.repeat):
        for name, fn in rows.items():
            t0 = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t0)
    compiled = _imu_kernel.compiled_applies(_imu_inputs.read_params(p))
    cpu = platform.processor() or platform.machine()
    print(f"numpy {np.__version__}, {cpu}, {os.cpu_count()} CPUs; compiled kernel: {compiled}")
    print(f"{n} samples in {len(starts)} windows of {args.window}")
    print(f"{'method':<26} {'best [ms]':>10} {'per window [µs]':>16} {'vs GTSAM loop':>14}")
    ref = np.array(times["gtsam manifold loop"])
    results = []
    for name, ts in times.items():
        t = float(np.min(ts))
        paired = float(np.median(ref / np.array(ts)))
        print(f"{name:<26} {1e3 * t:>10.2f} {1e6 * t / len(starts):>16.2f} {paired:>13.2f}x")
        results.append(
            {
                "method": name,
                "best_seconds": t,
                "median_seconds": float(np.median(ts)),
                "speedup_median_of_paired_runs": paired,
                "speedup_of_best_times": float(ref.min() / t),
            }
        )
    by = {r["method"]: r for r in results}
    ratio = by["liebridge windows"]["speedup_median_of_paired_runs"]
    kernel = "compiled kernel" if compiled else "numpy kernel: no compiled kernel built"
    print(
        f"\npreintegrate_windows ({kernel}) is {ratio:.1f}x GTSAM's manifold loop over the same "
        f"windows (median of paired runs; target 10x)"
    )
    print(
        "agreement with GTSAM, worst window: " + ", ".join(f"{k} {v:.1e}" for k, v in check.items())
    )
    out = {
        "benchmark": "IMU preintegration of keyframe windows, KittiEquivBiasedImu.txt",
        "samples": n,
        "window": args.window,
        "windows": len(starts),
        "repeat": args.repeat,
        "quick": args.quick,
        "timing": "wall clock; `repeat` interleaved runs of every method; the speedup is the "
        "median over runs of (GTSAM loop time / liebridge time) of the same run",
        "compiled": compiled,
        "speedup_vs_gtsam_manifold_loop": ratio,
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
