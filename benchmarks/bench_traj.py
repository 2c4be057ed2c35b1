"""Reading and evaluating a 10⁶-pose TUM trajectory: liebridge against evo on the same machine.

Run: ``python benchmarks/bench_traj.py [OUT.json] [--poses N] [--repeat R] [--quick]`` (prints a
table and writes JSON, default ``benchmarks/results/traj.json``; not a test). Data: a synthetic
smooth trajectory of N poses (default 1,000,000, 100 Hz: a helix with heading, pitch and roll
oscillations) as the reference, and as the estimate the same poses perturbed (``Exp(ξ)``,
ξ ~ N(0, diag(0.01² ×3, 0.05² ×3))), moved to another world frame, scaled by 1.05, with
timestamps jittered by ±4 ms; both written as TUM files at full precision (17 digits).

Stages, each timed for both tools, best of R wall-clock runs:

* read      — both files (evo: ``file_interface.read_tum_trajectory_file``; liebridge:
  ``io.trajfile.read_trajectory``, validation and the quaternion sanity check included)
* associate — evo: ``sync.associate_trajectories``; liebridge: ``traj.associate`` + indexing
* align     — Sim(3) Umeyama (evo: ``PoseTrajectory3D.align(correct_scale=True)``)
* ape       — APE, translation part, all statistics
* rpe       — RPE, translation part, delta 1 frame, all statistics

The JSON records both tools' statistics and their largest relative difference, so that speed is
never reported for different answers. ``--quick`` (20,000 poses) is the smoke run of the tests.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from liebridge import traj
from liebridge.io import trajfile
from liebridge.lie import quaternion as quat
from liebridge.lie import se3, so3


def make_files(n: int, d: Path) -> tuple[Path, Path]:
    rng = np.random.default_rng(0)
    t = 1.6e9 + 0.01 * np.arange(n)
    s = 0.01 * np.arange(n)
    p = np.column_stack([20 * np.cos(0.05 * s), 20 * np.sin(0.05 * s), 0.1 * s])
    yaw = 0.05 * s + np.pi / 2
    rpy = np.column_stack([0.1 * np.sin(0.7 * s), 0.05 * np.sin(1.3 * s), yaw])
    R = (
        so3.exp(rpy[:, 2:3] * [0, 0, 1])
        @ so3.exp(rpy[:, 1:2] * [0, 1, 0])
        @ so3.exp(rpy[:, 0:1] * [1, 0, 0])
    )
    T_ref = np.zeros((n, 4, 4))
    T_ref[:, :3, :3] = R
    T_ref[:, :3, 3] = p
    T_ref[:, 3, 3] = 1
    xi = rng.normal(scale=[0.01] * 3 + [0.05] * 3, size=(n, 6))
    T_est = se3.exp([0.1, -0.2, 0.5, 3.0, -2.0, 1.0]) @ T_ref @ se3.exp(xi)
    T_est[:, :3, 3] *= 1.05
    t_est = t + rng.uniform(-0.004, 0.004, n)
    paths = []
    for name, tt, T in (("ref.txt", t, T_ref), ("est.txt", t_est, T_est)):
        q = quat.from_matrix(T[:, :3, :3], order="xyzw")
        with open(d / name, "w") as fh:
            fh.write("# timestamp tx ty tz qx qy qz qw\n")
            np.savetxt(fh, np.column_stack([tt, T[:, :3, 3], q]), fmt="%.17g")
        paths.append(d / name)
    return paths[0], paths[1]


def timed(fn: Callable[[], Any], repeat: int) -> tuple[float, Any]:
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return float(best), out


def run_liebridge(ref: Path, est: Path, repeat: int) -> tuple[dict[str, float], dict[str, Any]]:
    times: dict[str, float] = {}
    times["read"], (a, b) = timed(
        lambda: (trajfile.read_trajectory(ref), trajfile.read_trajectory(est)), repeat
    )
    (t_ref, T_ref), (t_est, T_est) = a, b

    def assoc() -> tuple[np.ndarray, np.ndarray]:
        i, j = traj.associate(t_ref, t_est)
        return T_ref[i], T_est[j]

    times["associate"], (Tr, Te) = timed(assoc, repeat)
    times["align"], Ta = timed(lambda: traj.align(Tr, Te, "sim3").apply(Te), repeat)
    times["ape"], s_ape = timed(lambda: traj.statistics(traj.ape(Tr, Ta)).as_dict(), repeat)
    times["rpe"], s_rpe = timed(lambda: traj.statistics(traj.rpe(Tr, Ta)[0]).as_dict(), repeat)
    return times, {"ape": s_ape, "rpe": s_rpe}


def run_evo(ref: Path, est: Path, repeat: int) -> tuple[dict[str, float], dict[str, Any]]:
    import copy

    from evo.core import metrics, sync
    from evo.tools import file_interface

    times: dict[str, float] = {}
    times["read"], (r0, e0) = timed(
        lambda: (
            file_interface.read_tum_trajectory_file(str(ref)),
            file_interface.read_tum_trajectory_file(str(est)),
        ),
        repeat,
    )
    times["associate"], (r, e) = timed(lambda: sync.associate_trajectories(r0, e0), repeat)

    def align() -> Any:
        ee = copy.deepcopy(e)
        ee.align(r, correct_scale=True)
        return ee

    times["align"], ea = timed(align, repeat)

    def ape() -> dict[str, float]:
        m = metrics.APE(metrics.PoseRelation.translation_part)
        m.process_data((r, ea))
        return {k: float(v) for k, v in m.get_all_statistics().items()}

    def rpe() -> dict[str, float]:
        m = metrics.RPE(metrics.PoseRelation.translation_part, 1, metrics.Unit.frames)
        m.process_data((r, ea))
        return {k: float(v) for k, v in m.get_all_statistics().items()}

    times["ape"], s_ape = timed(ape, repeat)
    times["rpe"], s_rpe = timed(rpe, repeat)
    return times, {"ape": s_ape, "rpe": s_rpe}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument(
        "out", nargs="?", type=Path, default=Path(__file__).parent / "results" / "traj.json"
    )
    p.add_argument("--poses", type=int, default=1_000_000)
    p.add_argument("--repeat", type=int, default=1)
    p.add_argument("--quick", action="store_true", help="20,000 poses, 2 repeats")
    args = p.parse_args()
    n, repeat = (20_000, 2) if args.quick else (args.poses, args.repeat)
    import warnings

    import evo

    from liebridge.io.sanity import QuaternionOrderWarning

    # the estimate's per-pose noise (0.01 rad) over jittered stamps (≥ 2 ms apart) can exceed
    # the sanity check's 30 rad/s: the check still runs (and is timed), its warning is not shown
    warnings.simplefilter("ignore", QuaternionOrderWarning)

    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        ref, est = make_files(n, Path(tmp))
        print(f"wrote 2 TUM files of {n} poses in {time.perf_counter() - t0:.1f} s", flush=True)
        lb_t, lb_s = run_liebridge(ref, est, repeat)
        evo_t, evo_s = run_evo(ref, est, repeat)
    diff = max(
        abs(lb_s[m][k] - evo_s[m][k]) / max(1.0, abs(evo_s[m][k]))
        for m in ("ape", "rpe")
        for k in ("rmse", "mean", "median", "std", "min", "max")
    )
    lb_t["total"] = sum(lb_t.values())
    evo_t["total"] = sum(evo_t.values())
    print(f"{'stage':<10} {'liebridge [s]':>14} {'evo [s]':>10} {'evo / liebridge':>16}")
    rows = []
    for k in ("read", "associate", "align", "ape", "rpe", "total"):
        ratio = evo_t[k] / lb_t[k] if lb_t[k] > 0 else float("inf")
        rows.append({"stage": k, "liebridge_s": lb_t[k], "evo_s": evo_t[k], "ratio": ratio})
        print(f"{k:<10} {lb_t[k]:14.3f} {evo_t[k]:10.3f} {ratio:16.1f}")
    print(
        f"APE rmse {lb_s['ape']['rmse']:.6g} m, RPE rmse {lb_s['rpe']['rmse']:.6g} m; "
        f"largest relative difference to evo {diff:.2e}"
    )
    res = {
        "command": " ".join([os.path.basename(sys.argv[0]), *sys.argv[1:]]),
        "machine": {
            "cpu": platform.processor() or platform.machine(),
            "cores": os.cpu_count(),
            "python": platform.python_version(),
            "numpy": np.__version__,
            "evo": getattr(evo, "__version__", "?"),
        },
        "config": {"poses": n, "repeat": repeat, "quick": bool(args.quick)},
        "stages": rows,
        "statistics": {"liebridge": lb_s, "evo": evo_s},
        "max_relative_difference": diff,
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(res, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
