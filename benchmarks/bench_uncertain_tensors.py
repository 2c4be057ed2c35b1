"""Uncertain composition on torch and JAX arrays against the same propagation hand-written there.

``liebridge.uncertain.compose(A, B)`` (``method="linear"``, independent inputs) in the ``ros``
convention (left, translation first, split world chart: two tangent maps per call) and in
``gtsam`` (its own tangent: the maps are identities), against what a user writes in the same
framework for GTSAM's tangent: ``Σ_C = Ad_{B⁻¹} Σ_A Ad_{B⁻¹}ᵀ + Σ_B`` with ``Ad`` assembled by
hand (``torch.cat``/``jnp.concatenate`` of ``R``, ``hat(t) R``). The ``ros`` rows are what the
convention costs on top (a user in ROS's tangent would also have to write the maps, and usually
gets them wrong). Each row first checks that both sides agree on GTSAM (≤ 1e-9 relative).
float64, CPU, eager torch and eager JAX (liebridge's validation included: one reduction on the
device per argument), interleaved and repeated (median). ``x_hand`` = liebridge / hand-written.

Usage: ``python benchmarks/bench_uncertain_tensors.py [--sizes 10000,100000] [--repeat 5]``
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from liebridge import uncertain as u
from liebridge.lie import se3


def _hand(xp: Any, cat: Callable[..., Any]) -> Callable[..., Any]:
    def hat(t: Any) -> Any:
        z = 0.0 * t[..., 0]
        rows = [
            xp.stack([z, -t[..., 2], t[..., 1]], -1),
            xp.stack([t[..., 2], z, -t[..., 0]], -1),
            xp.stack([-t[..., 1], t[..., 0], z], -1),
        ]
        return xp.stack(rows, -2)

    def compose(TA: Any, SA: Any, TB: Any, SB: Any) -> Any:
        Rt = xp.swapaxes(TB[..., :3, :3], -1, -2)
        ti = -(Rt @ TB[..., :3, 3:4])[..., 0]
        Ad = cat([cat([Rt, 0.0 * Rt], -1), cat([hat(ti) @ Rt, Rt], -1)], -2)
        return TA @ TB, Ad @ SA @ xp.swapaxes(Ad, -1, -2) + SB

    return compose


def _time(f: Callable[[], Any], sync: Callable[[Any], Any], repeat: int) -> float:
    sync(f())  # warm-up
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        sync(f())
        out.append(time.perf_counter() - t0)
    return statistics.median(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="10000,100000")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    backends: list[tuple[str, Any, Any, Callable[[Any], Any]]] = []
    try:
        import torch

        backends.append(("torch", torch, torch.tensor, lambda x: x))
    except ImportError:
        pass
    try:
        import jax

        jax.config.update("jax_enable_x64", True)
        backends.append(("jax", jax.numpy, jax.numpy.asarray, lambda x: x.block_until_ready()))
    except ImportError:
        pass
    head = ("backend", "n", "convention", "liebridge s", "hand s", "x_hand")
    print("{:7} {:>8} {:10} {:>12} {:>9} {:>7}".format(*head))
    for n in (int(s) for s in args.sizes.split(",")):
        TA = se3.exp(rng.normal(size=(n, 6)))
        TB = se3.exp(rng.normal(size=(n, 6)))
        L = rng.normal(size=(n, 6, 6))
        S = 1e-3 * (L @ np.swapaxes(L, -1, -2))
        for name, xp, arr, sync in backends:
            cat = xp.cat if name == "torch" else xp.concatenate
            hand = _hand(xp, cat)
            tA, tB, tS = arr(TA), arr(TB), arr(S)
            ref = hand(tA, tS, tB, tS)[1]
            for conv in ("gtsam", "ros"):
                A = u.UncertainPose(tA, tS, conv)
                B = u.UncertainPose(tB, tS, conv)
                if conv == "gtsam":
                    got = u.compose(A, B).cov
                    err = float(np.abs(np.asarray(got) - np.asarray(ref)).max())
                    assert err <= 1e-9 * float(np.abs(np.asarray(ref)).max()), err
                t_lb = _time(lambda A=A, B=B: u.compose(A, B).cov, sync, args.repeat)
                t_h = _time(lambda h=hand, a=tA, b=tB, c=tS: h(a, c, b, c)[1], sync, args.repeat)
                print(f"{name:7} {n:8d} {conv:10} {t_lb:12.4f} {t_h:9.4f} {t_lb / t_h:7.2f}")


if __name__ == "__main__":
    main()
