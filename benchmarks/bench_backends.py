"""liebridge on torch and JAX arrays against the same maps hand-written in the same framework.

For each backend (``torch`` eager, ``jax`` under ``jax.jit``; ``numpy`` for reference) and device
(the CPU; a CUDA device where torch or JAX sees one), float64, at 10⁴, 10⁵ and 10⁶ elements
(``--sizes``), interleaved and repeated (median):

* ``se3.exp``, ``se3.log``: liebridge's ``lie.se3.exp``/``log`` against the textbook code a user
  writes (``θ = ‖ω‖``, Rodrigues with ``where`` for small angles, ``V = I + B K + C K²`` by
  batched 3×3 products; the logarithm by ``acos`` of the trace, the axis from ``R − Rᵀ`` and
  ``V⁻¹`` by ``linalg.solve``);
* ``tangent_map``, ``convert_covariance``: GTSAM's tangent to Barfoot's (left, translation first),
  ``M = P·Ad_X``, against the hand-written adjoint, permutation and ``M Σ Mᵀ``;
* ``grad``: one forward and backward pass of ``convert_covariance(Σ, exp(ξ)).sum()`` with respect
  to ξ (``torch.autograd`` / ``jax.grad``), both sides.

Every row first checks that both sides agree (max abs difference, asserted ≤ 1e-9 relative). The
ratio ``x_hand`` = liebridge / hand-written (target at 10⁶: ≤ 1.5). JAX's first call (tracing and
compilation) is outside the timing; each timed JAX call ends with ``block_until_ready()``, each
CUDA torch call with ``torch.cuda.synchronize()``.

Usage: ``python benchmarks/bench_backends.py [--quick] [--sizes 10000,100000,1000000]
[--repeat 5] [--out benchmarks/results/backends.json]``
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

import liebridge as lb  # noqa: E402
from liebridge.lie import se3  # noqa: E402

OPS = ("se3.exp", "se3.log", "tangent_map", "convert_covariance", "grad")


# ----------------------------------------------------------------------------- hand-written
def hand(xp: Any, eye3: Any) -> dict[str, Callable[..., Any]]:
    """The maps as a user writes them in the framework ``xp`` (torch or jax.numpy)."""

    def hat(w: Any) -> Any:
        z = w[..., 0] * 0.0
        return xp.stack(
            [
                xp.stack([z, -w[..., 2], w[..., 1]], -1),
                xp.stack([w[..., 2], z, -w[..., 0]], -1),
                xp.stack([-w[..., 1], w[..., 0], z], -1),
            ],
            -2,
        )

    def exp(xi: Any) -> Any:
        w, v = xi[..., :3], xi[..., 3:]
        th2 = (w * w).sum(-1)
        small = th2 < 1e-8
        ts = xp.sqrt(xp.where(small, 1.0, th2))
        A = xp.where(small, 1.0 - th2 / 6.0, xp.sin(ts) / ts)
        B = xp.where(small, 0.5 - th2 / 24.0, (1.0 - xp.cos(ts)) / (ts * ts))
        C = xp.where(small, 1.0 / 6.0 - th2 / 120.0, (ts - xp.sin(ts)) / (ts**3))
        K = hat(w)
        K2 = K @ K
        R = eye3 + A[..., None, None] * K + B[..., None, None] * K2
        V = eye3 + B[..., None, None] * K + C[..., None, None] * K2
        t = (V @ v[..., None])[..., 0]
        top = xp.concatenate([R, t[..., None]], -1)
        bottom = xp.zeros_like(top[..., :1, :]) + xp.asarray([0.0, 0.0, 0.0, 1.0], dtype=top.dtype)
        return xp.concatenate([top, bottom], -2)

    def log(T: Any) -> Any:
        R, t = T[..., :3, :3], T[..., :3, 3]
        c = xp.clip((R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2] - 1.0) / 2.0, -1.0, 1.0)
        th = xp.arccos(c)
        s = xp.stack(
            [R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]],
            -1,
        )
        small = th < 1e-4
        ts = xp.where(small, 1.0, th)
        k = xp.where(small, 0.5 + th * th / 12.0, ts / (2.0 * xp.sin(ts)))
        w = k[..., None] * s
        th2 = th * th
        B = xp.where(small, 0.5 - th2 / 24.0, (1.0 - xp.cos(ts)) / (ts * ts))
        C = xp.where(small, 1.0 / 6.0 - th2 / 120.0, (ts - xp.sin(ts)) / (ts**3))
        K = hat(w)
        V = eye3 + B[..., None, None] * K + C[..., None, None] * (K @ K)
        v = xp.linalg.solve(V, t[..., None])[..., 0]
        return xp.concatenate([w, v], -1)

    def tmap(T: Any) -> Any:  # barfoot (v, ω) left = P · Ad_T (ω, v)
        R, t = T[..., :3, :3], T[..., :3, 3]
        Z = R * 0.0
        return xp.concatenate(
            [xp.concatenate([hat(t) @ R, R], -1), xp.concatenate([R, Z], -1)], -2
        )

    def cov(C: Any, T: Any) -> Any:
        M = tmap(T)
        return M @ C @ xp.swapaxes(M, -1, -2)

    return {"se3.exp": exp, "se3.log": log, "tangent_map": tmap, "convert_covariance": cov}


def ours() -> dict[str, Callable[..., Any]]:
    return {
        "se3.exp": se3.exp,
        "se3.log": se3.log,
        "tangent_map": lambda T: lb.tangent_map(T, "gtsam", "barfoot"),
        "convert_covariance": lambda C, T: lb.convert_covariance(C, T, "gtsam", "barfoot"),
    }


# ----------------------------------------------------------------------------- backends
class Torch:
    name = "torch"

    def __init__(self, device: str) -> None:
        import torch

        self.torch, self.device = torch, device
        self.eye3 = torch.eye(3, dtype=torch.float64, device=device)

    def put(self, a: np.ndarray) -> Any:
        return self.torch.tensor(a, dtype=self.torch.float64, device=self.device)

    def sync(self, out: Any) -> Any:
        if self.device != "cpu":
            self.torch.cuda.synchronize()
        return out

    def back(self, a: Any) -> np.ndarray:
        return a.detach().cpu().numpy()

    def fns(self) -> tuple[dict[str, Callable[..., Any]], dict[str, Callable[..., Any]]]:
        h, o = hand(self.torch, self.eye3), ours()
        h = {k: (lambda f: lambda *a: f(*a))(f) for k, f in h.items()}
        torch = self.torch

        def grad_of(exp: Callable[..., Any], cov: Callable[..., Any]) -> Callable[..., Any]:
            def g(C: Any, xi: Any) -> Any:
                x = xi.detach().requires_grad_(True)
                (gx,) = torch.autograd.grad(cov(C, exp(x)).sum(), x)
                return gx

            return g

        h["grad"] = grad_of(h["se3.exp"], h["convert_covariance"])
        o["grad"] = grad_of(o["se3.exp"], o["convert_covariance"])
        return h, o


class Jax:
    name = "jax"

    def __init__(self, device: str) -> None:
        import jax

        jax.config.update("jax_enable_x64", True)
        self.jax, self.jnp, self.device = jax, jax.numpy, device
        self.dev = jax.devices(device)[0]
        self.eye3 = jax.device_put(self.jnp.eye(3), self.dev)

    def put(self, a: np.ndarray) -> Any:
        return self.jax.device_put(self.jnp.asarray(a), self.dev)

    def sync(self, out: Any) -> Any:
        return self.jax.block_until_ready(out)

    def back(self, a: Any) -> np.ndarray:
        return np.asarray(a)

    def fns(self) -> tuple[dict[str, Callable[..., Any]], dict[str, Callable[..., Any]]]:
        jax = self.jax
        h, o = hand(self.jnp, self.eye3), ours()

        def grad_of(exp: Callable[..., Any], cov: Callable[..., Any]) -> Callable[..., Any]:
            return jax.grad(lambda xi, C: cov(C, exp(xi)).sum())

        hg = grad_of(h["se3.exp"], h["convert_covariance"])
        og = grad_of(o["se3.exp"], o["convert_covariance"])
        h["grad"] = lambda C, xi: hg(xi, C)
        o["grad"] = lambda C, xi: og(xi, C)
        return (
            {k: jax.jit(f) for k, f in h.items()},
            {k: jax.jit(f) for k, f in o.items()},
        )


def _inputs(n: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    xi = np.concatenate([rng.uniform(-1, 1, (n, 3)) * 1.2, rng.normal(size=(n, 3))], axis=1)
    T = se3.exp(xi)
    A = rng.normal(size=(6, 6)) * 0.1
    return {"xi": xi, "T": T, "C": A @ A.T + 1e-3 * np.eye(6)}


def _args(op: str, x: dict[str, Any]) -> tuple[Any, ...]:
    return {
        "se3.exp": (x["xi"],),
        "se3.log": (x["T"],),
        "tangent_map": (x["T"],),
        "convert_covariance": (x["C"], x["T"]),
        "grad": (x["C"], x["xi"]),
    }[op]


def _time(f: Callable[[], Any]) -> float:
    t0 = time.perf_counter()
    f()
    return time.perf_counter() - t0


def run(sizes: list[int], repeat: int, quick: bool) -> dict[str, Any]:
    backends: list[Any] = []
    if importlib.util.find_spec("torch"):
        import torch

        backends.append(Torch("cpu"))
        if torch.cuda.is_available():
            backends.append(Torch("cuda"))
    if importlib.util.find_spec("jax"):
        import jax

        backends.append(Jax("cpu"))
        if any(d.platform == "gpu" for d in jax.devices()):
            backends.append(Jax("gpu"))
    if not backends:
        print("bench_backends: neither torch nor jax is installed (pip install '.[torch,jax]')")
        return {"rows": []}
    rng = np.random.default_rng(0)
    rows = []
    for n in sizes:
        x_np = _inputs(n, rng)
        for be in backends:
            hf, of = be.fns()
            x = {k: be.put(v) for k, v in x_np.items()}
            for op in OPS:
                args = _args(op, x)
                a = be.back(be.sync(of[op](*args)))  # warm-up (JAX: compilation)
                b = be.back(be.sync(hf[op](*args)))
                scale = max(1.0, float(np.abs(b).max()))
                diff = float(np.abs(a - b).max()) / scale
                assert diff <= 1e-9, (be.name, op, n, diff)
                t_o, t_h = [], []
                for _ in range(repeat):
                    t_o.append(_time(lambda: be.sync(of[op](*args))))
                    t_h.append(_time(lambda: be.sync(hf[op](*args))))
                mo, mh = statistics.median(t_o), statistics.median(t_h)
                row = {
                    "backend": be.name,
                    "device": be.device,
                    "op": op,
                    "n": n,
                    "liebridge_s": mo,
                    "hand_s": mh,
                    "x_hand": mo / mh,
                    "max_rel_diff": diff,
                }
                rows.append(row)
                print(
                    f"{be.name:5s} {be.device:4s} {op:18s} n={n:>8d}  liebridge {mo * 1e3:9.2f} ms"
                    f"  hand {mh * 1e3:9.2f} ms  x_hand {mo / mh:5.2f}",
                    flush=True,
                )
    return {"rows": rows}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="10³ elements, 2 repeats (a smoke run)")
    ap.add_argument("--sizes", default="10000,100000,1000000")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "backends.json"))
    a = ap.parse_args()
    sizes = [1000] if a.quick else [int(s) for s in a.sizes.split(",")]
    res = run(sizes, 2 if a.quick else a.repeat, a.quick)
    versions = {}
    for mod in ("numpy", "torch", "jax"):
        if importlib.util.find_spec(mod):
            versions[mod] = __import__(mod).__version__
    res.update(
        {
            "machine": f"{platform.processor() or platform.machine()}, {platform.system()}",
            "python": platform.python_version(),
            "versions": versions,
            "command": "python " + " ".join(sys.argv),
            "dtype": "float64",
        }
    )
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(res, indent=2) + "\n")
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
