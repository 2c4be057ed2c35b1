"""liebridge against what a user would otherwise write: one run, ratios, a table and a JSON file.

Run: ``python benchmarks/run.py [--quick] [--out benchmarks/results/run.json] [--repeat R]``
(not a test; ``tests/test_benchmarks_smoke.py`` only smoke-runs ``--quick``).

Sections, all measured in the same process and run:

* **batched** (N = 100,000 poses/twists): ``se3.exp``, ``se3.log``, ``tangent_map`` and
  ``convert_covariance`` (GTSAM → Barfoot) against a Python loop of the GTSAM calls that compute
  the same (and of Pinocchio's where it has them), and a plain numpy copy of an array the size of
  the output (the floor: writing the result at memory speed). Target: ≥ 10× the GTSAM loop. The
  loops cost the same per element at any N, so they are timed on the first ``--loop-n`` (10,000)
  elements, which leaves time for more interleaved repeats; every result is first checked
  against GTSAM's on all N.
* **single call**: ``tangent_map`` and ``convert_covariance`` for one pose against the hand-written
  GTSAM code (``P @ Pose3(T).AdjointMap()``, ``M @ C @ M.T``), with validation and without it
  (the conversion table alone), so that the price of validation is visible. Target: ≤ 2×.
* **accuracy**: max abs error of ``log(exp(ξ))`` (against the principal logarithm), of
  ``exp(log(T))`` and of ``jr(ξ)`` at fixed rotation angles, for liebridge, GTSAM and scipy,
  against 50-digit mpmath references computed from power series (independent of every closed form).
* **external**: ``benchmarks/bench_imu.py`` and ``benchmarks/bench_factors.py`` (sphere2500), run as
  subprocesses when present; their JSON is included. With ``--quick`` they run only if they accept
  ``--quick`` themselves.

Timing: the candidates of a row are interleaved, ``--repeat`` times; each figure is the median of
the repeats (the minimum is stored too). The machine may be shared: compare ratios, not times.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gtsam
import mpmath as mp
import numpy as np
import scipy
from scipy.spatial.transform import RigidTransform

import liebridge as lb
from liebridge.conventions import get
from liebridge.conventions.unchecked import tangent_map as _map
from liebridge.lie import SMALL_ANGLE, se3

try:
    import pinocchio as pin
except ImportError:  # pragma: no cover - optional oracle
    pin = None

HERE = Path(__file__).resolve().parent
#: (ω, v) ↔ (v, ω) block swap: Barfoot's tangent is (ρ, φ) = (v, ω)
P_SWAP = np.block([[np.zeros((3, 3)), np.eye(3)], [np.eye(3), np.zeros((3, 3))]])


# ----------------------------------------------------------------------------- machine
def _version(dist: str) -> str | None:
    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return None


def machine() -> dict[str, Any]:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    affinity = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "cores_available": affinity,
        "platform": platform.platform(),
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "gtsam": _version("gtsam"),
        "pinocchio": _version("pin"),
        "liebridge": lb.__version__,
        "blas_threads_env": {
            k: os.environ.get(k) for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")
        },
        "loadavg_1min_start": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
    }


# ----------------------------------------------------------------------------- timing
def _time_once(fn: Callable[[], object], number: int) -> float:
    t0 = time.perf_counter()
    for _ in range(number):
        fn()
    return (time.perf_counter() - t0) / number


MIN_TIME = {"batched": 0.02, "single": 0.02}


def interleaved(
    fns: dict[str, Callable[[], object]], repeat: int, min_time: float
) -> dict[str, dict[str, float]]:
    """Median and minimum seconds per call of each function, the candidates interleaved."""
    numbers = {}
    for name, fn in fns.items():
        fn()  # warm up (imports, caches)
        number = 1
        while _time_once(fn, number) * number < min_time and number < 1 << 20:
            number *= 2
        numbers[name] = number
    samples: dict[str, list[float]] = {name: [] for name in fns}
    for _ in range(repeat):
        for name, fn in fns.items():
            samples[name].append(_time_once(fn, numbers[name]))
    return {
        name: {"median_s": float(np.median(s)), "min_s": float(np.min(s))}
        for name, s in samples.items()
    }


# ----------------------------------------------------------------------------- data
def poses(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    xi = rng.normal(size=(n, 6))
    xi[:, :3] *= 1.2
    return xi, se3.exp(xi)


def covariances(n: int, rng: np.random.Generator) -> np.ndarray:
    A = rng.normal(size=(n, 6, 6))
    return np.asarray(A @ np.swapaxes(A, -1, -2) + 0.1 * np.eye(6))


# ----------------------------------------------------------------------------- batched
def batched(n: int, loop_n: int, repeat: int) -> list[dict[str, Any]]:
    """Per-element cost of each batched op and of the loops a user would write instead.

    liebridge runs on all ``n`` elements; the loops (per-element cost independent of the batch)
    run on the first ``loop_n`` of them, so that more interleaved repeats fit in the same time.
    Every result is first compared with GTSAM's on all ``n`` elements.
    """
    rng = np.random.default_rng(1)
    xi, T = poses(n, rng)
    C = covariances(n, rng)
    xi_pin = np.ascontiguousarray(np.concatenate([xi[:, 3:], xi[:, :3]], axis=1))  # (v, ω)

    def gtsam_exp(m: int) -> np.ndarray:
        return np.stack([gtsam.Pose3.Expmap(x).matrix() for x in xi[:m]])

    def gtsam_log(m: int) -> np.ndarray:
        return np.stack([gtsam.Pose3.Logmap(gtsam.Pose3(Tk)) for Tk in T[:m]])

    def gtsam_tm(m: int) -> np.ndarray:
        return np.stack([P_SWAP @ gtsam.Pose3(Tk).AdjointMap() for Tk in T[:m]])

    def gtsam_cc(m: int) -> np.ndarray:
        out = np.empty((m, 6, 6))
        for k in range(m):
            M = P_SWAP @ gtsam.Pose3(T[k]).AdjointMap()
            out[k] = M @ C[k] @ M.T
        return out

    # Pinocchio's tangent is (v, ω); SE3.action is Ad in (v, ω), so Barfoot's map from GTSAM's
    # (ω, v) is action @ P_SWAP
    def pin_exp(m: int) -> np.ndarray:
        return np.stack([pin.exp6(x).homogeneous for x in xi_pin[:m]])

    def pin_log(m: int) -> np.ndarray:
        return np.stack([pin.log6(pin.SE3(Tk)).vector for Tk in T[:m]])

    def pin_tm(m: int) -> np.ndarray:
        return np.stack([pin.SE3(Tk).action @ P_SWAP for Tk in T[:m]])

    def pin_cc(m: int) -> np.ndarray:
        out = np.empty((m, 6, 6))
        for k in range(m):
            M = pin.SE3(T[k]).action @ P_SWAP
            out[k] = M @ C[k] @ M.T
        return out

    rows: list[tuple[str, Callable[[], np.ndarray], Any, Any, tuple[int, ...], bool]] = [
        ("se3.exp", lambda: se3.exp(xi), gtsam_exp, pin_exp, (n, 4, 4), False),
        ("se3.log", lambda: se3.log(T), gtsam_log, pin_log, (n, 6), True),
        (
            "tangent_map gtsam→barfoot",
            lambda: lb.tangent_map(T, "gtsam", "barfoot"),
            gtsam_tm,
            pin_tm,
            (n, 6, 6),
            False,
        ),
        (
            "convert_covariance gtsam→barfoot",
            lambda: lb.convert_covariance(C, T, "gtsam", "barfoot"),
            gtsam_cc,
            pin_cc,
            (n, 6, 6),
            False,
        ),
    ]
    m = min(n, loop_n)
    results = []
    for name, ours, g_loop, p_loop, out_shape, absolute in rows:
        # the same answer first: speed is never reported for a wrong result
        mine, ref = np.asarray(ours()), g_loop(n)
        diff = float(np.abs(mine - ref).max())
        agree = diff if absolute else diff / max(1.0, float(np.abs(ref).max()))
        floor_src = np.ones(out_shape)
        fns: dict[str, Callable[[], object]] = {
            "liebridge": ours,
            "gtsam_loop": lambda g=g_loop: g(m),
            "numpy_copy_floor": floor_src.copy,
        }
        counts = {"liebridge": n, "gtsam_loop": m, "numpy_copy_floor": n}
        if pin is not None:
            fns["pinocchio_loop"] = lambda p=p_loop: p(m)
            counts["pinocchio_loop"] = m
        t = interleaved(fns, repeat, min_time=MIN_TIME["batched"])
        us = {k: 1e6 * v["median_s"] / counts[k] for k, v in t.items()}
        row: dict[str, Any] = {
            "op": name,
            "n": n,
            "loop_n": m,
            "us_per_element": us,
            "min_us_per_element": {k: 1e6 * v["min_s"] / counts[k] for k, v in t.items()},
            "speedup_vs_gtsam_loop": us["gtsam_loop"] / us["liebridge"],
            "x_numpy_copy_floor": us["liebridge"] / us["numpy_copy_floor"],
            "max_diff_vs_gtsam": agree,
            "target": ">= 10x gtsam_loop",
        }
        if "pinocchio_loop" in us:
            row["speedup_vs_pinocchio_loop"] = us["pinocchio_loop"] / us["liebridge"]
        row["met"] = bool(row["speedup_vs_gtsam_loop"] >= 10.0)
        results.append(row)
    return results


# ----------------------------------------------------------------------------- single call
def single(repeat: int) -> list[dict[str, Any]]:
    rng = np.random.default_rng(2)
    _, T = poses(1, rng)
    T = np.ascontiguousarray(T[0])
    C = covariances(1, rng)[0]
    a, b = get("gtsam"), get("barfoot")
    P = P_SWAP

    def hand_tm() -> np.ndarray:
        return np.asarray(P @ gtsam.Pose3(T).AdjointMap())

    def hand_cc() -> np.ndarray:
        M = P @ gtsam.Pose3(T).AdjointMap()
        return np.asarray(M @ C @ M.T)

    def lb_tm() -> np.ndarray:
        return lb.tangent_map(T, "gtsam", "barfoot")

    def lb_cc() -> np.ndarray:
        return lb.convert_covariance(C, T, "gtsam", "barfoot")

    def raw_tm() -> np.ndarray:  # the conversion table alone: no lookup, no validation
        return _map(T, a, b)

    def raw_cc() -> np.ndarray:
        M = _map(T, a, b)
        return np.asarray(M @ C @ M.swapaxes(-1, -2))

    assert np.allclose(lb_tm(), hand_tm()) and np.allclose(lb_cc(), hand_cc())
    rows = []
    for name, fns in (
        (
            "tangent_map",
            {"liebridge": lb_tm, "hand_gtsam": hand_tm, "liebridge_no_validation": raw_tm},
        ),
        (
            "convert_covariance",
            {"liebridge": lb_cc, "hand_gtsam": hand_cc, "liebridge_no_validation": raw_cc},
        ),
    ):
        t = interleaved(fns, repeat, min_time=MIN_TIME["single"])
        med = {k: 1e6 * v["median_s"] for k, v in t.items()}
        ratio = med["liebridge"] / med["hand_gtsam"]
        rows.append(
            {
                "op": name,
                "us": med,
                "min_us": {k: 1e6 * v["min_s"] for k, v in t.items()},
                "ratio_vs_hand_gtsam": ratio,
                "ratio_min_vs_hand_gtsam": t["liebridge"]["min_s"] / t["hand_gtsam"]["min_s"],
                "validation_us": med["liebridge"] - med["liebridge_no_validation"],
                "target": "<= 2x hand_gtsam",
                "met": bool(ratio <= 2.0),
            }
        )
    return rows


# ----------------------------------------------------------------------------- accuracy
mp.mp.dps = 50


def _mp_hat4(xi: list[Any]) -> Any:
    w1, w2, w3, v1, v2, v3 = xi
    return mp.matrix([[0, -w3, w2, v1], [w3, 0, -w1, v2], [-w2, w1, 0, v3], [0, 0, 0, 0]])


def _mp_ad(xi: list[Any]) -> Any:
    w1, w2, w3, v1, v2, v3 = xi
    W = mp.matrix([[0, -w3, w2], [w3, 0, -w1], [-w2, w1, 0]])
    V = mp.matrix([[0, -v3, v2], [v3, 0, -v1], [-v2, v1, 0]])
    A = mp.zeros(6, 6)
    for i in range(3):
        for j in range(3):
            A[i, j] = W[i, j]
            A[3 + i, 3 + j] = W[i, j]
            A[3 + i, j] = V[i, j]
    return A


def _mp_series(A: Any, first: int) -> Any:
    """``Σ_k A^k / (k + first)!`` to 50 digits (first = 0: exp; first = 1: (exp(A) − I)/A)."""
    n = A.rows
    out = mp.zeros(n, n)
    term = mp.eye(n)
    k = 0
    while True:
        contrib = term / mp.factorial(k + first)
        out += contrib
        if k > 8 and mp.mnorm(contrib, 1) < mp.mpf(10) ** (-mp.mp.dps - 5):
            return out
        term = term * A
        k += 1


def _mp_exp(xi: list[Any]) -> Any:
    return _mp_series(_mp_hat4(xi), 0)


def _mp_jr(xi: list[Any]) -> Any:
    """``jr(ξ) = Σ (−ad_ξ)^k / (k+1)!`` (GTSAM's ExpmapDerivative)."""
    return _mp_series(-_mp_ad(xi), 1)


def _mp_log_principal(xi: list[Any], flip: bool = False) -> list[Any]:
    """Principal logarithm of ``Exp(ξ)``: ``ω`` with ``‖ω‖ ≤ π``, ``v = V(ω)⁻¹ t``.

    ``flip``: the other logarithm of a rotation by π (``−ω``, same pose, so another ``v``).
    """
    w = mp.matrix(xi[:3])
    th = mp.norm(w)
    T = _mp_exp(xi)
    t = mp.matrix([T[0, 3], T[1, 3], T[2, 3]])
    if th > mp.pi:  # the same rotation by 2π − θ about −axis
        w = w * (1 - 2 * mp.pi / th)
    if flip:
        w = -w
    Wh = _mp_hat4([w[0], w[1], w[2], 0, 0, 0])
    Vm = _mp_series(mp.matrix([[Wh[i, j] for j in range(3)] for i in range(3)]), 1)
    v = mp.lu_solve(Vm, t)
    return [w[0], w[1], w[2], v[0], v[1], v[2]]


def _to_np(A: Any) -> np.ndarray:
    return np.array([[float(A[i, j]) for j in range(A.cols)] for i in range(A.rows)])


def accuracy(n_axes: int) -> dict[str, Any]:
    angles = [
        ("0", 0.0),
        ("1e-15", 1e-15),
        ("1e-12", 1e-12),
        ("1e-8", 1e-8),
        ("SMALL_ANGLE⁻", float(np.nextafter(SMALL_ANGLE, 0.0))),
        ("SMALL_ANGLE⁺", float(np.nextafter(SMALL_ANGLE, 1.0))),
        ("1", 1.0),
        ("3", 3.0),
        ("π−1e-3", np.pi - 1e-3),
        ("π−1e-9", np.pi - 1e-9),
        ("π−1e-12", np.pi - 1e-12),
        ("π", np.pi),
    ]
    axes = np.array([[1.0, 2.0, 3.0], [-0.3, 0.8, 0.5], [0.0, 0.0, 1.0]])[:n_axes]
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    v = np.array([0.4, -0.7, 1.1])
    rows = []
    for label, theta in angles:
        err: dict[str, dict[str, float]] = {
            "log(exp(xi))": {"liebridge": 0.0, "gtsam": 0.0, "scipy": 0.0},
            "exp(log(T))": {"liebridge": 0.0, "gtsam": 0.0, "scipy": 0.0},
            "jr": {"liebridge": 0.0, "gtsam": 0.0},
        }
        for axis in axes:
            xi = np.concatenate([theta * axis, v])
            xi_mp = [mp.mpf(float(x)) for x in xi]  # the float64 input, exactly
            L_ref = np.array([float(x) for x in _mp_log_principal(xi_mp)])
            alts = [L_ref]
            th_mp = mp.norm(mp.matrix(xi_mp[:3]))
            if abs(th_mp - mp.pi) < 1e-13:  # π to rounding: the axis sign is set by rounding
                alts.append(np.array([float(x) for x in _mp_log_principal(xi_mp, flip=True)]))
            T = _to_np(_mp_exp(xi_mp))  # exp(ξ) correctly rounded
            J_ref = _to_np(_mp_jr(xi_mp))

            def log_err(L: np.ndarray, alts: list[np.ndarray] = alts) -> float:
                return float(min(np.abs(np.asarray(L) - a).max() for a in alts))

            e = err["log(exp(xi))"]
            e["liebridge"] = max(e["liebridge"], log_err(se3.log(se3.exp(xi))))
            e["gtsam"] = max(e["gtsam"], log_err(gtsam.Pose3.Logmap(gtsam.Pose3.Expmap(xi))))
            rt = RigidTransform.from_exp_coords(xi)
            e["scipy"] = max(e["scipy"], log_err(rt.as_exp_coords()))
            e = err["exp(log(T))"]
            e["liebridge"] = max(e["liebridge"], float(np.abs(se3.exp(se3.log(T)) - T).max()))
            g = gtsam.Pose3.Expmap(gtsam.Pose3.Logmap(gtsam.Pose3(T))).matrix()
            e["gtsam"] = max(e["gtsam"], float(np.abs(g - T).max()))
            s = RigidTransform.from_exp_coords(RigidTransform.from_matrix(T).as_exp_coords())
            e["scipy"] = max(e["scipy"], float(np.abs(s.as_matrix() - T).max()))
            e = err["jr"]
            e["liebridge"] = max(e["liebridge"], float(np.abs(se3.jr(xi) - J_ref).max()))
            gj = gtsam.Pose3.ExpmapDerivative(xi)
            e["gtsam"] = max(e["gtsam"], float(np.abs(gj - J_ref).max()))
        rows.append({"angle": label, "theta": theta, "max_abs_error": err})
    return {
        "reference": (
            "mpmath, 50 digits: power series of exp(hat ξ), (exp(A) − I)/A and "
            "jr = Σ (−ad_ξ)^k/(k+1)!"
        ),
        "inputs": f"ω = θ·axis for {len(axes)} fixed unit axes, v = {v.tolist()}; max over axes",
        "note": (
            "log(exp(ξ)) is compared with the principal logarithm of the exact Exp(ξ); at θ = π "
            "(to rounding) both ±π·axis are logarithms of the rotation and either is accepted, "
            "with its own v = V(ω)⁻¹t. exp(log(T)) starts from the correctly rounded Exp(ξ)."
        ),
        "rows": rows,
    }


# ----------------------------------------------------------------------------- external
def external(quick: bool, outdir: Path) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, script in (("imu", "bench_imu.py"), ("sphere2500_factors", "bench_factors.py")):
        path = HERE / script
        if not path.exists():
            out[key] = {"status": "absent", "script": script}
            continue
        help_text = subprocess.run(
            [sys.executable, str(path), "--help"], capture_output=True, text=True, timeout=120
        ).stdout
        if quick and "--quick" not in help_text:
            out[key] = {"status": "skipped", "reason": f"--quick: {script} has no --quick flag"}
            continue
        json_path = outdir / f"{path.stem}.json"
        cmd = [sys.executable, str(path)]
        cmd += ["--out", str(json_path)] if "--out" in help_text else [str(json_path)]
        if quick:
            cmd.append("--quick")
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=3600)
        entry: dict[str, Any] = {
            "script": script,
            "command": " ".join(["python", f"benchmarks/{script}", *cmd[2:]]),
            "returncode": proc.returncode,
            "wall_s": time.perf_counter() - t0,
        }
        if proc.returncode == 0 and json_path.exists():
            entry["status"] = "ok"
            entry["result"] = json.loads(json_path.read_text())
        else:
            entry["status"] = "failed"
            entry["stderr_tail"] = proc.stderr[-2000:]
        out[key] = entry
    return out


# ----------------------------------------------------------------------------- report
def _fmt_ratio(x: float | None) -> str:
    return "—" if x is None else f"{x:.1f}x"


def print_report(res: dict[str, Any]) -> None:
    m = res["machine"]
    print(
        f"machine: {m['cpu']}, {m['cores']} cores ({m['cores_available']} available), "
        f"load {m['loadavg_1min_start']}; python {m['python']}, numpy {m['numpy']}, "
        f"scipy {m['scipy']}, gtsam {m['gtsam']}, pinocchio {m['pinocchio']}"
    )
    c = res["config"]
    print(
        f"\nbatched, N = {c['n_batch']:,} (loops timed on {c['loop_n']:,}; µs per element, "
        f"median of {c['repeat']} interleaved runs)"
    )
    hdr = (
        f"{'op':<34}{'liebridge':>10}{'gtsam loop':>11}{'pin loop':>10}{'np copy':>9}"
        f"{'vs gtsam':>10}{'vs pin':>8}{'/floor':>8}  target ≥10x"
    )
    print(hdr)
    for r in res["batched"]:
        u = r["us_per_element"]
        pin_us = u.get("pinocchio_loop")
        print(
            f"{r['op']:<34}{u['liebridge']:>10.3f}{u['gtsam_loop']:>11.3f}"
            f"{(f'{pin_us:.3f}' if pin_us else '—'):>10}{u['numpy_copy_floor']:>9.4f}"
            f"{_fmt_ratio(r['speedup_vs_gtsam_loop']):>10}"
            f"{_fmt_ratio(r.get('speedup_vs_pinocchio_loop')):>8}"
            f"{_fmt_ratio(r['x_numpy_copy_floor']):>8}  {'met' if r['met'] else 'MISSED'}"
        )
    print(f"\nsingle call, one pose (µs, median of {res['config']['repeat_single']} runs)")
    print(
        f"{'op':<20}{'liebridge':>10}{'hand gtsam':>11}{'no valid.':>10}{'validation':>11}"
        f"{'ratio':>7}  target ≤2x"
    )
    for r in res["single"]:
        u = r["us"]
        print(
            f"{r['op']:<20}{u['liebridge']:>10.2f}{u['hand_gtsam']:>11.2f}"
            f"{u['liebridge_no_validation']:>10.2f}{r['validation_us']:>11.2f}"
            f"{r['ratio_vs_hand_gtsam']:>6.2f}x  {'met' if r['met'] else 'MISSED'}"
        )
    acc = res["accuracy"]
    print(f"\naccuracy: max abs error ({acc['inputs']})")
    print(
        f"{'θ':<14}{'log∘exp lb':>11}{'gtsam':>9}{'scipy':>9}{'exp∘log lb':>12}{'gtsam':>9}"
        f"{'scipy':>9}{'jr lb':>9}{'gtsam':>9}"
    )
    for r in acc["rows"]:
        e = r["max_abs_error"]
        a, b, c = e["log(exp(xi))"], e["exp(log(T))"], e["jr"]
        print(
            f"{r['angle']:<14}{a['liebridge']:>11.1e}{a['gtsam']:>9.1e}{a['scipy']:>9.1e}"
            f"{b['liebridge']:>12.1e}{b['gtsam']:>9.1e}{b['scipy']:>9.1e}"
            f"{c['liebridge']:>9.1e}{c['gtsam']:>9.1e}"
        )
    print("\nexternal benchmarks:")
    for key, e in res["external"].items():
        print(f"  {key}: {e['status']}" + (f" ({e.get('reason', '')})" if "reason" in e else ""))
    imu = res["external"].get("imu", {}).get("result")
    if imu:
        print(
            f"  imu: {imu['samples']:,} samples, preintegrate "
            f"{imu['speedup_vs_gtsam_manifold_loop']:.1f}x GTSAM's manifold loop "
            f"(compiled kernel: {imu.get('compiled')}; numpy kernel "
            f"{imu.get('numpy_kernel_speedup_vs_gtsam_manifold_loop', float('nan')):.1f}x)"
        )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small N and few repeats (smoke run)")
    ap.add_argument("--out", default=str(HERE / "results" / "run.json"))
    ap.add_argument("--n", type=int, default=None, help="batch size (default 100000; quick 2000)")
    ap.add_argument("--loop-n", type=int, default=10_000, help="elements in the timed loops")
    ap.add_argument("--repeat", type=int, default=None, help="repeats (default 9; quick 2)")
    ap.add_argument("--no-external", action="store_true", help="skip bench_imu / bench_factors")
    args = ap.parse_args(argv)
    n = args.n or (500 if args.quick else 100_000)
    repeat = args.repeat or (1 if args.quick else 9)
    repeat_single = 2 if args.quick else 21
    if args.quick:
        MIN_TIME.update(batched=0.002, single=0.002)
    out_path = Path(args.out)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    res: dict[str, Any] = {
        "command": " ".join(["python", "benchmarks/run.py", *(argv or sys.argv[1:])]),
        "machine": machine(),
        "config": {
            "quick": args.quick,
            "n_batch": n,
            "loop_n": min(n, args.loop_n),
            "repeat": repeat,
            "repeat_single": repeat_single,
            "timing": "median of interleaved repeats (min also stored)",
        },
    }
    res["batched"] = batched(n, args.loop_n, repeat)
    res["single"] = single(repeat_single)
    res["accuracy"] = accuracy(1 if args.quick else 3)
    if args.no_external:
        res["external"] = {}
    else:
        with tempfile.TemporaryDirectory() as tmp:  # their JSON is embedded, not left behind
            res["external"] = external(args.quick, Path(tmp))
    res["machine"]["loadavg_1min_end"] = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    print_report(res)
    out_path.write_text(json.dumps(res, indent=2, ensure_ascii=False) + "\n")
    print(f"\nwrote {out_path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
