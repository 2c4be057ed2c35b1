"""Autodiff factors: batched (one vmap call per pass) against one callback per factor.

What a user would otherwise write is a ``gtsam.CustomFactor`` whose callback runs ``jacfwd`` on its
own factor: that is ``lb.gtsam.optimize(graph, batch=False)`` on the same factors (each callback
runs the same kernel on a batch of one), timed in the same run; GTSAM's native
``BetweenFactorPose3`` graph is the floor. Graph: the first ``--poses`` poses of sphere2500.
JAX compiles each kernel once per batch size: the first (cold) run includes it, the second (warm)
does not.

Run: ``python benchmarks/bench_autodiff.py [--poses 200] [--backends torch jax] [--quick]
[--out results/autodiff.json]``.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import platform
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]


def _example() -> Any:
    spec = importlib.util.spec_from_file_location(
        "autodiff_example", ROOT / "examples" / "autodiff_factor.py"
    )
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _timed(graph: Any, values: Any, batch: bool = True) -> tuple[float, Any]:
    import liebridge as lb

    t = time.perf_counter()
    out = lb.gtsam.optimize(graph, values, batch=batch, progress=False)
    return time.perf_counter() - t, out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--poses", type=int, default=200)
    p.add_argument("--backends", nargs="+", default=["torch", "jax"])
    p.add_argument("--quick", action="store_true", help="60 poses (a smoke run)")
    p.add_argument("--out", type=Path, default=None)
    a = p.parse_args(argv)
    n = 60 if a.quick else a.poses
    ex = _example()
    g = ex.load(n)
    rows = []
    for backend in a.backends:
        native, auto, values = ex.graphs(g, backend, "pypose")
        t_native, r_native = _timed(native, values)
        t_cold, r_cold = _timed(auto, values)
        t_warm, r_warm = _timed(auto, values)
        t_cb, r_cb = _timed(auto, values, batch=False)
        row = {
            "backend": backend,
            "poses": len(g.vertex_ids),
            "factors": len(g.edges),
            "iterations": [r_native.iterations, r_warm.iterations, r_cb.iterations],
            "final_error": [r_native.final_error, r_warm.final_error, r_cb.final_error],
            "native_s": t_native,
            "batched_cold_s": t_cold,
            "batched_warm_s": t_warm,
            "callbacks_s": t_cb,
            "speedup_batched_vs_callbacks": t_cb / t_warm,
            "ratio_batched_vs_native": t_warm / t_native,
        }
        assert abs(r_cold.final_error - r_native.final_error) <= 1e-9 * r_native.final_error + 1e-12
        rows.append(row)
        print(
            f"{backend}: {row['factors']} factors, native {t_native:.3f} s, batched "
            f"{t_warm:.3f} s (cold {t_cold:.3f} s), callbacks {t_cb:.3f} s: batched "
            f"{row['speedup_batched_vs_callbacks']:.1f}x faster than callbacks, "
            f"{row['ratio_batched_vs_native']:.1f}x native"
        )
    result = {"machine": f"{platform.machine()} {platform.processor()}".strip(), "rows": rows}
    if a.out is not None:
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
