"""Deskew and spline evaluation: liebridge.continuous against hand-written numpy, same formula.

Run: ``python benchmarks/bench_continuous.py [OUT.json] [--repeat R] [--quick]`` (prints a table
and writes JSON, default ``benchmarks/results/continuous.json``; not a test).

Rows, each timed for both candidates in the same process, interleaved, best of R:

* **deskew** — 10 scans × 100,000 points (10⁶ points), KISS-ICP's formula
  ``p' = Exp((α − 1)·Log(ΔT))·p`` with ``α`` normalised per scan (float seconds, unsorted).
  liebridge: ``continuous.deskew(..., model="kiss_icp")`` (validation included). Hand-written:
  what a user writes in numpy — per-point twist, Rodrigues ``R`` and ``V`` matrices with a
  small-angle guard, ``R p + V u``. Target: liebridge ≤ 1.5× the hand-written time.
* **spline** — 10⁶ evaluation times of a cubic coupled (kontiki-style) SE(3) spline with 200 knots.
  liebridge: ``Spline.evaluate``. Hand-written: segment and ``u`` per time, the cumulative basis,
  the three per-time ``Exp(b̃_j·d_j)`` as 4×4 matrices (Rodrigues and ``V``, increments ``d_j``
  precomputed once, as a user would), and their product. Target: ≤ 2×.

Both candidates' outputs are compared (max abs difference stored) before timing, so that speed
is never reported for different answers. ``--quick`` (10× fewer points and times) is the smoke
run of the tests.
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
from typing import Any

import numpy as np

from liebridge.continuous import Spline, deskew
from liebridge.lie import se3


def _hat(w: np.ndarray) -> np.ndarray:
    W = np.zeros((*w.shape[:-1], 3, 3))
    W[..., 0, 1], W[..., 0, 2] = -w[..., 2], w[..., 1]
    W[..., 1, 0], W[..., 1, 2] = w[..., 2], -w[..., 0]
    W[..., 2, 0], W[..., 2, 1] = -w[..., 1], w[..., 0]
    return W


def hand_exp(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return Rodrigues R and V·u as a user writes them (Taylor guard below 1e-4 rad)."""
    w, u = xi[..., :3], xi[..., 3:]
    th = np.linalg.norm(w, axis=-1)
    small = th < 1e-4
    ths = np.where(small, 1.0, th)
    A = np.where(small, 1 - th**2 / 6, np.sin(ths) / ths)
    B = np.where(small, 0.5 - th**2 / 24, (1 - np.cos(ths)) / ths**2)
    C = np.where(small, 1 / 6 - th**2 / 120, (ths - np.sin(ths)) / ths**3)
    W = _hat(w)
    W2 = W @ W
    eye = np.eye(3)
    R = eye + A[..., None, None] * W + B[..., None, None] * W2
    V = eye + B[..., None, None] * W + C[..., None, None] * W2
    return R, (V @ u[..., None])[..., 0]


def hand_deskew(P: np.ndarray, stamps: np.ndarray, delta: np.ndarray) -> np.ndarray:
    xi = se3.log(delta)
    a = (stamps - stamps.min()) / (stamps.max() - stamps.min()) - 1.0
    R, t = hand_exp(a[:, None] * xi)
    return np.einsum("nij,nj->ni", R, P) + t


def hand_spline(K: np.ndarray, d: np.ndarray, t0: float, dt: float, t: np.ndarray) -> np.ndarray:
    sig = (t - t0) / dt
    s = np.clip(np.floor(sig).astype(int), 0, K.shape[0] - 4)
    u = sig - s
    b = [
        (5 + 3 * u - 3 * u**2 + u**3) / 6,
        (1 + 3 * u + 3 * u**2 - 2 * u**3) / 6,
        u**3 / 6,
    ]
    T = K[s]
    for j in range(3):
        R, p = hand_exp(b[j][:, None] * d[s + j])
        A = np.zeros((t.size, 4, 4))
        A[:, :3, :3], A[:, :3, 3], A[:, 3, 3] = R, p, 1.0
        T = T @ A
    return T


def best(fns: dict[str, Callable[[], Any]], repeat: int) -> dict[str, float]:
    times: dict[str, list[float]] = {k: [] for k in fns}
    for _ in range(repeat):
        for k, f in fns.items():
            t = time.perf_counter()
            f()
            times[k].append(time.perf_counter() - t)
    return {k: min(v) for k, v in times.items()}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "out", nargs="?", default=str(Path(__file__).parent / "results" / "continuous.json")
    )
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args(argv)
    rng = np.random.default_rng(0)
    n_pts = 10_000 if a.quick else 100_000
    n_t = 100_000 if a.quick else 1_000_000
    rows = []

    # ----- deskew: 10 scans
    scans = []
    for k in range(10):
        P = rng.normal(size=(n_pts, 3)) * 20.0
        st = 0.1 * k + rng.uniform(0.0, 0.1, size=n_pts)
        Tb = se3.exp(rng.normal(size=6))
        Te = Tb @ se3.exp(np.array([0.01, -0.02, 0.15, 1.0, 0.05, 0.0]))
        scans.append((P, st, Tb, Te))
    ours = [deskew(P, st, Tb, Te, "kiss_icp").points for P, st, Tb, Te in scans]
    theirs = [hand_deskew(P, st, np.linalg.inv(Tb) @ Te) for P, st, Tb, Te in scans]
    diff = max(float(np.abs(x - y).max()) for x, y in zip(ours, theirs, strict=False))
    tm = best(
        {
            "liebridge": lambda: [deskew(P, st, Tb, Te, "kiss_icp") for P, st, Tb, Te in scans],
            "hand_numpy": lambda: [
                hand_deskew(P, st, np.linalg.inv(Tb) @ Te) for P, st, Tb, Te in scans
            ],
        },
        a.repeat,
    )
    rows.append(("deskew", 10 * n_pts, tm, diff, 1.5))

    # ----- spline evaluation
    K = se3.exp(rng.normal(size=(200, 6)) * 0.3)
    sp = Spline(K, 0.0, 0.1, 4, "coupled")
    d = se3.log(np.linalg.inv(K[:-1]) @ K[1:])
    t = rng.uniform(0.0, float(sp.t_max), size=n_t)
    diff = float(np.abs(sp.evaluate(t) - hand_spline(K, d, 0.0, 0.1, t)).max())
    tm = best(
        {"liebridge": lambda: sp.evaluate(t), "hand_numpy": lambda: hand_spline(K, d, 0.0, 0.1, t)},
        a.repeat,
    )
    rows.append(("spline_evaluate", n_t, tm, diff, 2.0))

    head = ("row", "n", "liebridge s", "numpy s", "ratio", "target", "max|Δ|")
    print("{:<16}{:>10}{:>14}{:>12}{:>8}{:>8}{:>10}".format(*head))
    out_rows = []
    for name, n, tm, diff, target in rows:
        ratio = tm["liebridge"] / tm["hand_numpy"]
        print(
            f"{name:<16}{n:>10}{tm['liebridge']:>14.3f}{tm['hand_numpy']:>12.3f}"
            f"{ratio:>8.2f}{'≤' + str(target):>8}{diff:>10.1e}"
        )
        out_rows.append(
            {
                "row": name,
                "n": n,
                "seconds": tm,
                "ratio_liebridge_over_numpy": ratio,
                "target_ratio": target,
                "max_abs_difference": diff,
            }
        )
    res = {
        "config": {"quick": a.quick, "repeat": a.repeat},
        "machine": {
            "platform": platform.platform(),
            "cpus": os.cpu_count(),
            "python": sys.version.split()[0],
        },
        "rows": out_rows,
    }
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(res, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
