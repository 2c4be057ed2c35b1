"""liebridge's quaternion functions on torch and JAX against the same maps hand-written there.

For each backend (``torch`` eager, ``jax`` under ``jax.jit``), float64, at ``--sizes`` elements,
interleaved and repeated (median):

* ``to_matrix`` (``xyzw``): liebridge's ``lie.quaternion.to_matrix`` (validated: the norm of each
  quaternion certified on the device) against the polynomial form a user writes with ``stack``;
* ``from_matrix`` (``xyzw``): liebridge's (rotation certified on the device, a polar Newton
  step, Shepperd/Markley selection with ``where``) against the same selection hand-written
  without validation or projection (what a careful user writes; the naive ``w = ½√(1 + tr R)``
  is wrong near π and not timed).

Every row first checks that both sides agree (≤ 1e-9). ``x_hand`` = liebridge / hand-written.
JAX's first call (tracing, compilation) is outside the timing; each timed call ends with
``block_until_ready()``.

Usage: ``python benchmarks/bench_quaternion_tensors.py [--sizes 100000,1000000] [--repeat 5]
[--out benchmarks/results/quaternion_tensors.json]``
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import platform
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from liebridge.lie import quaternion as Q  # noqa: E402
from liebridge.lie import so3  # noqa: E402


def hand(xp: Any) -> dict[str, Callable[..., Any]]:
    """Return the maps as a user writes them in the framework ``xp`` (torch or jax.numpy)."""

    def to_matrix(q: Any) -> Any:
        x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
        rows = [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
        return xp.stack([xp.stack(r, -1) for r in rows], -2)

    def from_matrix(R: Any) -> Any:
        r = [[R[..., i, j] for j in range(3)] for i in range(3)]
        tr = r[0][0] + r[1][1] + r[2][2]
        k0 = (r[0][0] >= r[1][1]) & (r[0][0] >= r[2][2]) & (r[0][0] >= tr)
        k1 = ~k0 & (r[1][1] >= r[2][2]) & (r[1][1] >= tr)
        k2 = ~k0 & ~k1 & (r[2][2] >= tr)
        s01, s02, s12 = r[1][0] + r[0][1], r[2][0] + r[0][2], r[2][1] + r[1][2]
        d0, d1, d2 = r[2][1] - r[1][2], r[0][2] - r[2][0], r[1][0] - r[0][1]
        c = [
            xp.stack([1 - tr + 2 * r[0][0], s01, s02, d0], -1),
            xp.stack([s01, 1 - tr + 2 * r[1][1], s12, d1], -1),
            xp.stack([s02, s12, 1 - tr + 2 * r[2][2], d2], -1),
            xp.stack([d0, d1, d2, 1 + tr], -1),
        ]
        q = xp.where(
            k0[..., None], c[0], xp.where(k1[..., None], c[1], xp.where(k2[..., None], c[2], c[3]))
        )
        q = q / xp.sqrt(xp.sum(q * q, -1, keepdims=True))
        return xp.where(q[..., 3:] < 0, -q, q)

    return {"to_matrix": to_matrix, "from_matrix": from_matrix}


def mine() -> dict[str, Callable[..., Any]]:
    return {
        "to_matrix": lambda q: Q.to_matrix(q, order="xyzw"),
        "from_matrix": lambda R: Q.from_matrix(R, order="xyzw"),
    }


def _timed(f: Callable[[], Any], sync: Callable[[Any], Any]) -> float:
    t0 = time.perf_counter()
    sync(f())
    return time.perf_counter() - t0


def run(sizes: list[int], repeat: int) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    rng = np.random.default_rng(0)
    for n in sizes:
        R = so3.exp(rng.normal(size=(n, 3)))
        q = Q.from_matrix(R, order="xyzw")
        inputs = {"to_matrix": q, "from_matrix": R}
        for backend in ("torch", "jax"):
            if importlib.util.find_spec(backend) is None:
                continue
            if backend == "torch":
                import torch

                xp, make, sync = torch, torch.tensor, (lambda x: x)
                fns_h, fns_m = hand(torch), mine()
            else:
                import jax

                jax.config.update("jax_enable_x64", True)
                xp, make = jax.numpy, jax.numpy.asarray
                sync = lambda x: x.block_until_ready()  # noqa: E731
                fns_h = {k: jax.jit(f) for k, f in hand(jax.numpy).items()}
                fns_m = {k: jax.jit(f) for k, f in mine().items()}
            del xp
            for op, x in inputs.items():
                a = make(x)
                out_m, out_h = fns_m[op](a), fns_h[op](a)  # warm-up (JAX: compile)
                diff = float(np.abs(np.asarray(out_m) - np.asarray(out_h)).max())
                assert diff <= 1e-9, (op, backend, diff)
                tm, th = [], []
                fm, fh = fns_m[op], fns_h[op]
                for _ in range(repeat):
                    tm.append(_timed(lambda fm=fm, a=a: fm(a), sync))
                    th.append(_timed(lambda fh=fh, a=a: fh(a), sync))
                row = {
                    "op": op,
                    "backend": backend,
                    "n": n,
                    "liebridge_ms": 1e3 * statistics.median(tm),
                    "hand_ms": 1e3 * statistics.median(th),
                    "max_abs_diff": diff,
                }
                row["x_hand"] = row["liebridge_ms"] / row["hand_ms"]
                rows.append(row)
                print(
                    f"{op:12s} {backend:6s} n={n:>8d}  liebridge {row['liebridge_ms']:9.2f} ms"
                    f"  hand {row['hand_ms']:9.2f} ms  x_hand {row['x_hand']:.2f}",
                    flush=True,
                )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="100000,1000000")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    rows = run([int(s) for s in args.sizes.split(",")], args.repeat)
    if args.out:
        meta = {"machine": platform.platform(), "processor": platform.processor()}
        Path(args.out).write_text(json.dumps({"meta": meta, "rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
