"""The batched Lie kernels against jaxlie ``jax.jit(jax.vmap(...))`` on CPU, float64.

For ``so3.exp``, ``so3.log``, ``se3.exp``, ``se3.log`` and ``se3.adjoint`` at 10⁴, 10⁵ and 10⁶
elements (``--sizes``), each candidate timed in the same process, interleaved and repeated
(median; the minimum is stored too):

* ``liebridge``: the public function as a user calls it (validated; the compiled pass
  ``liebridge/lie/_lie_ext.c`` where built);
* ``liebridge_numpy``: the same call with the compiled kernels switched off (the numpy kernels,
  the reference), the switch ``benchmarks/bench_speed.py`` uses;
* ``jaxlie_matrix``: jaxlie computing the *same* map, matrix in / matrix out where liebridge's
  is: ``SO3.exp(ω).as_matrix()``, ``SO3.from_matrix(R).log()``, ``SE3.exp(ξ).as_matrix()``,
  ``SE3.from_matrix(T).log()``, ``SE3.from_matrix(T).adjoint()`` — the comparable operation;
* ``jaxlie_native``: jaxlie on its own storage, which does less work: ``SO3.exp(ω).wxyz``
  (quaternion out), ``SO3(wxyz).log()``, ``SE3.exp(ξ).wxyz_xyz``, ``SE3(wxyz_xyz).log()``,
  ``SE3(wxyz_xyz).adjoint()`` (quaternion in);
* ``memory_pass``: a copy of the input and of an output-sized array (each byte read once and
  written once; the floor ``bench_speed.py``'s ``kernels`` rows use). It moves about twice the
  bytes a kernel must, so
* ``one_pass`` is timed too: the input read once and a fresh output-sized array written once,
  the least traffic any implementation of the kernel makes.

jaxlie runs as ``jax.jit(jax.vmap(f))`` on the CPU backend with ``jax_enable_x64`` (float64,
the precision liebridge computes in); its inputs are device arrays made before timing, the
first call (tracing and XLA compilation) is a warm-up outside the timing, and every timed call
ends with ``block_until_ready()``. jaxlie's SE(3) tangent is ``(v, ω)`` (translation first) and
its adjoint is in that order; liebridge's (GTSAM's) is ``(ω, v)``: inputs are permuted before
timing and results compared after permuting back. Each row first checks that liebridge and
jaxlie agree on the same inputs (max abs difference, asserted ≤ 1e-12 on the comparable map).

Ratios: ``x_memory_pass`` = time / memory pass (target: ≤ 3×); ``x_one_pass`` =
time / one pass (the stricter reading of that floor); ``speedup_vs_jaxlie_matrix`` =
jaxlie_matrix / liebridge (target: > 1, ahead of jaxlie-jit). ``cpu_per_wall`` records how many
cores a candidate kept busy (XLA may use a second one; liebridge's kernels use one).

``edge_cases`` (not timed): at rotation angles 0, 1e-12, 1e-6, 1e-3, 1, π − 1e-6 with 30 m
translations, the max abs difference of liebridge and of jaxlie from GTSAM (``Rot3``/``Pose3``
``Expmap``, ``Logmap``, ``AdjointMap``); liebridge's is asserted ≤ 1e-12 × max(1, |value|).

Usage: ``python benchmarks/bench_jaxlie.py [--quick] [--sizes 10000,100000,1000000]
[--repeat R] [--out benchmarks/results/jaxlie.json]``. Needs ``pip install ".[bench]"``
(jax, jaxlie); without them it prints why and exits 0 without writing anything.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.metadata
import json
import os
import platform
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from run import interleaved

from liebridge.lie import se3, so3

#: The compiled Lie kernels' switch (off: the numpy kernels), as in bench_speed.py.
_LIE_COMPILED = importlib.import_module("liebridge.lie._compiled")
#: (ω, v) ↔ (v, ω): liebridge's (GTSAM's) twist order ↔ jaxlie's. Its own inverse.
_SWAP6 = np.r_[3:6, 0:3]


def _numpy_kernels(fn: Callable[[], Any]) -> Callable[[], Any]:
    """``fn`` with the compiled Lie kernels switched off (the numpy kernels)."""

    def run() -> Any:
        ext = getattr(_LIE_COMPILED, "_lie_ext")  # noqa: B009 (a module attribute, switched)
        setattr(_LIE_COMPILED, "_lie_ext", None)  # noqa: B010
        try:
            return fn()
        finally:
            setattr(_LIE_COMPILED, "_lie_ext", ext)  # noqa: B010

    return run


def _inputs(n: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Twists with rotation angles spread over [0, ~5] rad (the log wraps past π), and poses."""
    xi = rng.normal(size=(n, 6))
    xi[:, :3] *= 1.2
    xi[:, 3:] *= 3.0  # metres
    T = se3.exp(xi)
    return {
        "xi": xi,
        "w": np.ascontiguousarray(xi[:, :3]),
        "T": T,
        "R": np.ascontiguousarray(T[:, :3, :3]),
    }


def _jax_fns(jax: Any, jnp: Any, jaxlie: Any) -> dict[str, dict[str, Callable[..., Any]]]:
    """Per op, the jitted vmapped jaxlie functions (per element; vmap adds the batch axis)."""
    SO3, SE3 = jaxlie.SO3, jaxlie.SE3

    def jv(f: Callable[..., Any]) -> Callable[..., Any]:
        return jax.jit(jax.vmap(f))

    return {
        "so3.exp": {
            "matrix": jv(lambda w: SO3.exp(w).as_matrix()),
            "native": jv(lambda w: SO3.exp(w).wxyz),
        },
        "so3.log": {
            "matrix": jv(lambda R: SO3.from_matrix(R).log()),
            "native": jv(lambda q: SO3(wxyz=q).log()),
        },
        "se3.exp": {
            "matrix": jv(lambda t: SE3.exp(t).as_matrix()),
            "native": jv(lambda t: SE3.exp(t).wxyz_xyz),
        },
        "se3.log": {
            "matrix": jv(lambda T: SE3.from_matrix(T).log()),
            "native": jv(lambda p: SE3(wxyz_xyz=p).log()),
        },
        "se3.adjoint": {
            "matrix": jv(lambda T: SE3.from_matrix(T).adjoint()),
            "native": jv(lambda p: SE3(wxyz_xyz=p).adjoint()),
        },
    }


def _blocked(f: Callable[..., Any], *args: Any) -> Callable[[], Any]:
    def run() -> Any:
        return f(*args).block_until_ready()

    return run


def _cpu_per_wall(fn: Callable[[], Any]) -> float:
    """Process CPU seconds per wall second over calls filling ≥ 0.05 s (1 = one core busy)."""
    c0, w0, k = time.process_time(), time.perf_counter(), 0
    while time.perf_counter() - w0 < 0.05 or k < 3:
        fn()
        k += 1
    return (time.process_time() - c0) / (time.perf_counter() - w0)


def _memory_pass(inp: np.ndarray, like: np.ndarray) -> Callable[[], Any]:
    """One pass over the bytes a kernel touches: a copy of its input and of its output's size."""

    def run() -> Any:
        return inp.copy(), like.copy()

    return run


def _one_pass(inp: np.ndarray, out_shape: tuple[int, ...]) -> Callable[[], Any]:
    """Time the least traffic a kernel can make: its input read once, a new output written once.

    The first ``min(in, out)`` numbers are copied from the input into a fresh output-sized
    array; the rest of the output is filled (output larger) or the rest of the input is read by
    a max reduction (input larger).
    """
    src = inp.reshape(-1)
    size = int(np.prod(out_shape))
    k = min(src.size, size)

    def run() -> Any:
        o = np.empty(size)
        o[:k] = src[:k]
        if size > k:
            o[k:] = 1.0
        else:
            o[0] += src[k:].max()
        return o

    return run


def rows_for(
    n: int, repeat: int, jax: Any, jnp: Any, jaxlie: Any, min_time: float
) -> list[dict[str, Any]]:
    """One row per op at ``n`` elements: medians, ratios and the liebridge–jaxlie agreement."""
    rng = np.random.default_rng(23)
    d = _inputs(n, rng)
    jfns = _jax_fns(jax, jnp, jaxlie)
    # jaxlie's own storage of the same elements (computed once, outside the timing)
    to_se3 = jax.jit(jax.vmap(lambda T: jaxlie.SE3.from_matrix(T).wxyz_xyz))
    p = to_se3(jnp.asarray(d["T"])).block_until_ready()
    q = p[:, :4]
    dev = {
        "w": jnp.asarray(d["w"]),
        "R": jnp.asarray(d["R"]),
        "xi_vw": jnp.asarray(np.ascontiguousarray(d["xi"][:, _SWAP6])),
        "T": jnp.asarray(d["T"]),
        "q": q,
        "p": p,
    }
    # per op: liebridge call, its input, jaxlie (matrix, native) inputs, jaxlie → liebridge layout
    cases: list[tuple[str, Callable[[], Any], np.ndarray, Any, Any, Callable[[Any], Any]]] = [
        ("so3.exp", lambda: so3.exp(d["w"]), d["w"], dev["w"], dev["w"], lambda a: a),
        ("so3.log", lambda: so3.log(d["R"]), d["R"], dev["R"], dev["q"], lambda a: a),
        ("se3.exp", lambda: se3.exp(d["xi"]), d["xi"], dev["xi_vw"], dev["xi_vw"], lambda a: a),
        ("se3.log", lambda: se3.log(d["T"]), d["T"], dev["T"], dev["p"], lambda a: a[:, _SWAP6]),
        (
            "se3.adjoint",
            lambda: se3.adjoint(d["T"]),
            d["T"],
            dev["T"],
            dev["p"],
            lambda a: a[:, _SWAP6][:, :, _SWAP6],
        ),
    ]
    rows = []
    for op, ours, inp, jin_m, jin_n, back in cases:
        jm, jn = jfns[op]["matrix"], jfns[op]["native"]
        out = ours()
        ref = _numpy_kernels(ours)()
        theirs = back(np.asarray(jm(jin_m)))
        if op == "so3.exp":  # the quaternion variant, as a matrix (outside the timing)
            native = np.asarray(jax.vmap(lambda v: jaxlie.SO3(wxyz=v).as_matrix())(jn(jin_n)))
        elif op == "se3.exp":
            native = np.asarray(jax.vmap(lambda v: jaxlie.SE3(wxyz_xyz=v).as_matrix())(jn(jin_n)))
        else:
            native = back(np.asarray(jn(jin_n)))
        agree = {
            "max_abs_liebridge_vs_jaxlie_matrix": float(np.abs(out - theirs).max()),
            "max_abs_liebridge_vs_jaxlie_native": float(np.abs(out - native).max()),
            "max_abs_compiled_vs_numpy": float(np.abs(out - ref).max()),
        }
        assert agree["max_abs_liebridge_vs_jaxlie_matrix"] <= 1e-12, (op, n, agree)
        assert agree["max_abs_compiled_vs_numpy"] <= 1e-12, (op, n, agree)
        like = np.empty_like(out)
        like[...] = 1.0
        fns = {
            "liebridge": ours,
            "liebridge_numpy": _numpy_kernels(ours),
            "jaxlie_matrix": _blocked(jm, jin_m),
            "jaxlie_native": _blocked(jn, jin_n),
            "memory_pass": _memory_pass(inp, like),
            "one_pass": _one_pass(inp, like.shape),
        }
        t = interleaved(fns, repeat, min_time=min_time)  # first call of each: warm-up (jit)
        med = {k: v["median_s"] for k, v in t.items()}
        # cores used: process CPU time / wall time over a few calls (XLA may run threads)
        cpu_per_wall = {k: _cpu_per_wall(fns[k]) for k in ("liebridge", "jaxlie_matrix")}
        mp = med["memory_pass"]
        row = {
            "op": op,
            "n": n,
            "compiled": bool(_LIE_COMPILED.COMPILED),
            "median_s": med,
            "min_s": {k: v["min_s"] for k, v in t.items()},
            "x_memory_pass": {k: v / mp for k, v in med.items() if not k.endswith("pass")},
            "x_one_pass": {
                k: v / med["one_pass"] for k, v in med.items() if not k.endswith("pass")
            },
            "speedup_vs_jaxlie_matrix": med["jaxlie_matrix"] / med["liebridge"],
            "speedup_vs_jaxlie_native": med["jaxlie_native"] / med["liebridge"],
            "cpu_per_wall": cpu_per_wall,
            "agreement": agree,
            "within_3x_memory_pass": bool(med["liebridge"] <= 3 * mp),
            "ahead_of_jaxlie_jit": bool(med["liebridge"] < med["jaxlie_matrix"]),
        }
        print(json.dumps(row), flush=True)
        rows.append(row)
        del out, ref, theirs, native, like
    return rows


#: Rotation angles of the fixed edge cases (random axes, 30 m translations on every axis).
EDGE_ANGLES = (0.0, 1e-12, 1e-6, 1e-3, 1.0, np.pi - 1e-6)


def edge_cases(jax: Any, jnp: Any, jaxlie: Any) -> list[dict[str, Any]]:
    """Max abs difference at fixed angles: liebridge vs jaxlie, each vs GTSAM (the referee).

    Not timed. liebridge vs GTSAM is asserted ≤ 1e-12 × max(1, max |value|); jaxlie's differences
    are reported as measured (jaxlie 1.5 replaces ``V(ω)`` by ``R`` below θ² = 1e-10 in float64,
    ``jaxlie/_so3.py`` ``_SO3_jac_left``: an error of about ``½|ω × v|`` in ``SE3.exp``'s
    translation).
    """
    import gtsam

    u = np.random.default_rng(7).normal(size=(len(EDGE_ANGLES), 3))
    w = u / np.linalg.norm(u, axis=1, keepdims=True) * np.asarray(EDGE_ANGLES)[:, None]
    xi = np.concatenate([w, np.full_like(w, 30.0)], axis=1)
    R, T = so3.exp(w), se3.exp(xi)
    jf = _jax_fns(jax, jnp, jaxlie)
    S = _SWAP6
    cases: list[tuple[str, Any, Any, Any, Callable[[Any], Any], Callable[[int], Any]]] = [
        ("so3.exp", so3.exp(w), w, w, lambda a: a, lambda k: gtsam.Rot3.Expmap(w[k]).matrix()),
        (
            "so3.log",
            so3.log(R),
            R,
            R,
            lambda a: a,
            lambda k: gtsam.Rot3.Logmap(gtsam.Rot3(R[k])),
        ),
        (
            "se3.exp",
            se3.exp(xi),
            xi,
            xi[:, S],
            lambda a: a,
            lambda k: gtsam.Pose3.Expmap(xi[k]).matrix(),
        ),
        (
            "se3.log",
            se3.log(T),
            T,
            T,
            lambda a: a[:, S],
            lambda k: gtsam.Pose3.Logmap(gtsam.Pose3(T[k])),
        ),
        (
            "se3.adjoint",
            se3.adjoint(T),
            T,
            T,
            lambda a: a[:, S][:, :, S],
            lambda k: gtsam.Pose3(T[k]).AdjointMap(),
        ),
    ]
    rows = []
    for op, ours, _inp, jin, back, gt in cases:
        theirs = back(np.asarray(jf[op]["matrix"](jnp.asarray(jin))))
        ref = np.stack([np.asarray(gt(k)) for k in range(len(EDGE_ANGLES))])
        n = len(EDGE_ANGLES)
        row = {
            "op": op,
            "angles_rad": list(EDGE_ANGLES),
            "max_abs_liebridge_vs_gtsam": np.abs(ours - ref).reshape(n, -1).max(1).tolist(),
            "max_abs_jaxlie_vs_gtsam": np.abs(theirs - ref).reshape(n, -1).max(1).tolist(),
        }
        scale = max(1.0, float(np.abs(ref).max()))  # se3.log at π − 1e-6 with 30 m: |v| ≈ 50
        assert max(row["max_abs_liebridge_vs_gtsam"]) <= 1e-12 * scale, row
        print(json.dumps(row), flush=True)
        rows.append(row)
    return rows


def table(rows: list[dict[str, Any]]) -> str:
    """Markdown: one line per (op, n), times in ms and the ratios."""
    lines = [
        "| op | n | liebridge ms (× pass) | numpy ms (× pass) | jaxlie jit matrix ms (× pass)"
        " | jaxlie native ms | pass ms (one pass) | liebridge × one pass | vs jaxlie |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        m, x = r["median_s"], r["x_memory_pass"]
        lines.append(
            f"| {r['op']} | {r['n']:,} | {1e3 * m['liebridge']:.2f} ({x['liebridge']:.1f}×)"
            f" | {1e3 * m['liebridge_numpy']:.1f} ({x['liebridge_numpy']:.1f}×)"
            f" | {1e3 * m['jaxlie_matrix']:.2f} ({x['jaxlie_matrix']:.1f}×)"
            f" | {1e3 * m['jaxlie_native']:.2f}"
            f" | {1e3 * m['memory_pass']:.2f} ({1e3 * m['one_pass']:.2f})"
            f" | {r['x_one_pass']['liebridge']:.1f}×"
            f" | {r['speedup_vs_jaxlie_matrix']:.1f}× faster |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> dict[str, Any] | None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--out", default="benchmarks/results/jaxlie.json")
    ap.add_argument("--quick", action="store_true", help="tiny sizes (a smoke run)")
    ap.add_argument("--sizes", default=None, help="comma-separated element counts")
    ap.add_argument("--repeat", type=int, default=None)
    args = ap.parse_args(argv)
    try:
        import jax

        jax.config.update("jax_enable_x64", True)  # before any array is made
        jax.config.update("jax_platforms", "cpu")
        import jax.numpy as jnp
        import jaxlie
    except ImportError as e:
        print(
            f"bench_jaxlie: skipped, jax/jaxlie not installed ({e}); "
            'pip install ".[bench]" in the checkout to run it',
            flush=True,
        )
        return None
    sizes = [
        int(s)
        for s in (args.sizes or ("200,1000" if args.quick else "10000,100000,1000000")).split(",")
    ]
    repeat = args.repeat or (2 if args.quick else 7)
    lscpu = subprocess.run(["lscpu"], capture_output=True, text=True, check=False).stdout
    rows = []
    for n in sizes:
        rows += rows_for(n, repeat, jax, jnp, jaxlie, min_time=0.0 if args.quick else 0.05)
    edges = edge_cases(jax, jnp, jaxlie)
    out = {
        "machine": [ln for ln in lscpu.splitlines() if ln.startswith(("Model name", "CPU(s)"))],
        "loadavg_1min_end": os.getloadavg()[0],
        "python": platform.python_version(),
        "numpy": np.__version__,
        "jax": importlib.metadata.version("jax"),
        "jaxlib": importlib.metadata.version("jaxlib"),
        "jaxlie": importlib.metadata.version("jaxlie"),
        "jax_backend": jax.default_backend(),
        "precision": "float64 everywhere (jax_enable_x64)",
        "quick": bool(args.quick),
        "repeat": repeat,
        "notes": [
            "jaxlie_matrix computes the same map as liebridge (matrix in/out where liebridge's "
            "is): SO3.exp(w).as_matrix(), SO3.from_matrix(R).log(), SE3.exp(xi).as_matrix(), "
            "SE3.from_matrix(T).log(), SE3.from_matrix(T).adjoint(); jaxlie_native stays on "
            "jaxlie's quaternion storage (wxyz, wxyz_xyz) and does less work.",
            "jax.jit(jax.vmap(f)) on CPU, inputs already device arrays, first call (compile) "
            "excluded, block_until_ready() on every call.",
            "jaxlie's SE(3) tangent and adjoint are (v, w); inputs permuted before timing, "
            "results permuted back for the agreement check.",
            "memory_pass: a copy of the input and of an output-sized array, the floor "
            "bench_speed.py's kernels rows use (target: <= 3x); it moves about twice "
            "the bytes a kernel must.",
            "one_pass: the least traffic a kernel can make, its input read once and a fresh "
            "output written once (x_one_pass is the stricter ratio).",
            "cpu_per_wall: process CPU time / wall time of the candidate (1 = one core); "
            "liebridge's kernels are single-threaded.",
        ],
        "rows": rows,
        "edge_cases": edges,
    }
    md = table(rows)
    print(md)
    out["table_markdown"] = md
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
