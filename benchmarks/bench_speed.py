"""Where users spend time — files, huge batches, batched and single conversions.

Each row is a ratio against what a user would otherwise run, timed in the same process,
interleaved and repeated (median); memory rows report the peak traced by ``tracemalloc``
(Python and numpy allocations) while one call runs.

* ``files``: ``read_tum``/``read_kitti`` vs ``numpy.loadtxt`` on the same file (``--lines``,
  default 10⁶), time and peak memory against the arrays returned;
* ``unscented``: ``convert_covariance(method="unscented")`` chunked (default) vs one pass, at
  ``--uns-n`` (default 20,000) covariances, time and traced peak; then 10⁶ chunked;
* ``batched`` (``batched_all``; ``batched`` keeps the headline gtsam→barfoot covariance row):
  every batched conversion at 10⁵ poses — ``convert_covariance`` gtsam→barfoot and gtsam→ros,
  ``convert_information``, ``tangent_map``, ``convert_jacobian`` on either side — as liebridge
  runs it (the compiled pass where built), its numpy fallback, the vectorised numpy a user would
  write (``_hand_maps``: the map block by block, then batched matmuls) and one memory pass (a
  copy of every input and of an output-sized array); targets ≥ 1.5× faster than the hand numpy
  and ≤ 3× a memory pass;
* ``single`` (and ``single_more``): one pose vs the same expression with GTSAM's ``Pose3``
  (``run.single``: ``P @ gtsam.Pose3(T).AdjointMap()``), target ≤ 1.3×;
* ``kernels``: ``se3.exp/log/adjoint``, ``so3.exp/log`` at 10⁶, compiled and numpy, against one
  memory pass (target ≤ 3×). jaxlie is not installed here: not compared.

Usage: ``python benchmarks/bench_speed.py [--quick] [--parts batched,single,kernels]
[--out benchmarks/results/speed.json]`` (rows of parts not run are kept from ``--out``).
"""

from __future__ import annotations

import argparse
import importlib
import json
import platform
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from run import P_SWAP, covariances, interleaved, poses, single

import liebridge as lb
from liebridge.io import trajectory as tio
from liebridge.lie import se3, so3

#: The conversion module (its compiled pass is switched off to time the numpy fallback).
_CONVERT = importlib.import_module("liebridge.conventions.convert")
#: The compiled Lie kernels' switch (off: the numpy kernels).
_LIE_COMPILED = importlib.import_module("liebridge.lie._compiled")


def _peak(fn: Any) -> tuple[int, int]:
    """Traced peak bytes (Python and numpy allocations) while ``fn`` runs, bytes returned."""
    tracemalloc.start()
    out = fn()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    arrays = tuple(out) if isinstance(out, tuple | lb.io.Trajectory) else (out,)
    return peak, sum(a.nbytes for a in arrays)


def files(lines: int, repeat: int) -> list[dict[str, Any]]:
    rng = np.random.default_rng(0)
    _, T = poses(lines, rng)
    rows = []
    with tempfile.TemporaryDirectory() as d:
        tum, kitti = Path(d) / "t.txt", Path(d) / "k.txt"
        tio.write_tum(tum, np.arange(lines) * 0.01, T)
        tio.write_kitti(kitti, T)
        for name, path, fn in (
            ("read_tum", tum, lambda p: tio.read_tum(p, check=False)),
            ("read_kitti", kitti, tio.read_kitti),
        ):
            t = interleaved(
                {"liebridge": lambda f=fn, p=path: f(p), "loadtxt": lambda p=path: np.loadtxt(p)},
                repeat,
                min_time=0.0,
            )
            mem, returned = _peak(lambda f=fn, p=path: f(p))
            mem_np, _ = _peak(lambda p=path: np.loadtxt(p))
            med = {k: v["median_s"] for k, v in t.items()}
            rows.append(
                {
                    "op": name,
                    "lines": lines,
                    "file_mib": path.stat().st_size / 2**20,
                    "s": med,
                    "ratio_vs_loadtxt": med["liebridge"] / med["loadtxt"],
                    "peak_mib": mem / 2**20,
                    "loadtxt_peak_mib": mem_np / 2**20,
                    "returned_mib": returned / 2**20,
                    "peak_over_returned": mem / returned,
                    "met": bool(med["liebridge"] <= 2 * med["loadtxt"] and mem <= 3 * returned),
                }
            )
            print(json.dumps(rows[-1]), flush=True)
    return rows


def _traced(fn: Any) -> tuple[float, int]:
    tracemalloc.start()
    t = time.perf_counter()
    fn()
    dt = time.perf_counter() - t
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return dt, peak


def unscented(n: int, big: int, repeat: int) -> list[dict[str, Any]]:
    rng = np.random.default_rng(1)
    _, T = poses(n, rng)
    C = covariances(n, rng) * 1e-2

    def run(chunk: int | None) -> Any:
        return lb.convert_covariance(C, T, "gtsam", "ros", method="unscented", chunk_size=chunk)

    np.testing.assert_allclose(run(None), run(n), rtol=1e-12, atol=1e-15)
    samples: dict[str, list[tuple[float, int]]] = {"chunked": [], "one_pass": []}
    for _ in range(repeat):
        samples["chunked"].append(_traced(lambda: run(None)))
        samples["one_pass"].append(_traced(lambda: run(n)))
    med = {k: float(np.median([s[0] for s in v])) for k, v in samples.items()}
    peak = {k: max(s[1] for s in v) / 2**20 for k, v in samples.items()}
    rows = [
        {
            "op": "convert_covariance unscented gtsam→ros",
            "n": n,
            "s": med,
            "ratio_chunked_vs_one_pass": med["chunked"] / med["one_pass"],
            "traced_peak_mib": peak,
            "met": bool(med["chunked"] <= 1.1 * med["one_pass"]),
        }
    ]
    print(json.dumps(rows[-1]), flush=True)
    if big:
        _, Tb = poses(big, rng)
        Cb = covariances(big, rng) * 1e-2
        dt, pk = _traced(lambda: lb.convert_covariance(Cb, Tb, "gtsam", "ros", method="unscented"))
        io_mib = (Cb.nbytes * 2) / 2**20  # input covariances and the output
        rows.append(
            {
                "op": "convert_covariance unscented gtsam→ros (chunked)",
                "n": big,
                "s": dt,
                "s_per_element_vs_small": (dt / big) / (med["chunked"] / n),
                "traced_peak_mib": pk / 2**20,
                "input_output_mib": io_mib,
            }
        )
        print(json.dumps(rows[-1]), flush=True)
    return rows


def _ad_blocks(T: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """R, hat(t) and hat(t)·R of a batch of poses, as a user writes them."""
    n = T.shape[0]
    R, t = T[:, :3, :3], T[:, :3, 3]
    th = np.zeros((n, 3, 3))
    th[:, 0, 1], th[:, 0, 2], th[:, 1, 2] = -t[:, 2], t[:, 1], -t[:, 0]
    th[:, 1, 0], th[:, 2, 0], th[:, 2, 1] = t[:, 2], -t[:, 1], t[:, 0]
    return R, th, th @ R


def _hand_maps(T: np.ndarray) -> dict[str, Any]:
    """Return the vectorised numpy a user writes for each map (GTSAM's ξ = (ω, v), on the right).

    barfoot (left, (ρ, φ)): ``M = P·Ad_X``, ``M⁻¹ = Ad_{X⁻¹}·P``; ros (left, (ρ, φ), rotation
    and translation perturbed separately in the world frame): ``M = P·diag(R, R)``.
    """
    n = T.shape[0]

    def barfoot() -> np.ndarray:
        R, _, tR = _ad_blocks(T)
        Ad = np.zeros((n, 6, 6))
        Ad[:, :3, :3] = Ad[:, 3:, 3:] = R
        Ad[:, 3:, :3] = tR
        return np.asarray(P_SWAP @ Ad)

    def barfoot_inv() -> np.ndarray:
        R, th, _ = _ad_blocks(T)
        Rt = R.swapaxes(-1, -2)
        Ai = np.zeros((n, 6, 6))
        Ai[:, :3, :3] = Ai[:, 3:, 3:] = Rt
        Ai[:, 3:, :3] = -Rt @ th
        return np.asarray(Ai @ P_SWAP)

    def ros() -> np.ndarray:
        M = np.zeros((n, 6, 6))
        M[:, :3, 3:] = M[:, 3:, :3] = T[:, :3, :3]
        return M

    return {"barfoot": barfoot, "barfoot_inv": barfoot_inv, "ros": ros}


def _numpy_only(fn: Any) -> Any:
    """``fn`` with liebridge's compiled conversion pass switched off (its numpy fallback)."""

    def run() -> Any:
        ext = _CONVERT._convert_ext
        _CONVERT._convert_ext = None
        try:
            return fn()
        finally:
            _CONVERT._convert_ext = ext

    return run


def _row(
    op: str, n: int, fns: dict[str, Any], inputs: tuple[np.ndarray, ...], repeat: int
) -> dict[str, Any]:
    """Time liebridge (compiled where built), its numpy fallback, hand numpy and a memory pass.

    The memory pass copies every input and one output-sized array (each read once, written once).
    """
    ours, hand = fns["liebridge"](), fns["hand_numpy"]()
    np.testing.assert_allclose(ours, hand, rtol=1e-10, atol=1e-9 * np.abs(hand).max())
    np.testing.assert_allclose(
        fns["liebridge_numpy"](), hand, rtol=1e-10, atol=1e-9 * np.abs(hand).max()
    )
    src = np.concatenate([a.reshape(n, -1) for a in inputs], axis=1)
    like = np.empty_like(ours)
    like[...] = 1.0
    fns = {**fns, "memory_pass": lambda: (src.copy(), like.copy())}
    t = interleaved(fns, repeat, min_time=0.0)
    med = {k: v["median_s"] for k, v in t.items()}
    row = {
        "op": op,
        "n": n,
        "compiled": _CONVERT.COMPILED,
        "s": med,
        "speedup_vs_hand_numpy": med["hand_numpy"] / med["liebridge"],
        "x_memory_pass": med["liebridge"] / med["memory_pass"],
        "numpy_fallback_x_memory_pass": med["liebridge_numpy"] / med["memory_pass"],
        "hand_numpy_x_memory_pass": med["hand_numpy"] / med["memory_pass"],
        "target": ">= 1.5x faster than hand numpy, <= 3x a memory pass",
        "met": bool(
            med["hand_numpy"] / med["liebridge"] >= 1.5
            and med["liebridge"] <= 3 * med["memory_pass"]
        ),
    }
    print(json.dumps(row), flush=True)
    return row


def batched(n: int, repeat: int) -> list[dict[str, Any]]:
    """Every batched conversion at ``n`` poses against the vectorised numpy a user would write."""
    rng = np.random.default_rng(2)
    _, T = poses(n, rng)
    C = covariances(n, rng)
    J = rng.normal(size=(n, 6, 6))
    h = _hand_maps(T)
    rows = []

    def congruence(M: np.ndarray, S: np.ndarray) -> np.ndarray:
        return np.asarray(M @ S @ M.swapaxes(-1, -2))

    def cases() -> Any:
        yield (
            "convert_covariance gtsam→barfoot (batched)",
            lambda: lb.convert_covariance(C, T, "gtsam", "barfoot"),
            lambda: congruence(h["barfoot"](), C),
            (C, T),
        )
        yield (
            "convert_covariance gtsam→ros (batched)",
            lambda: lb.convert_covariance(C, T, "gtsam", "ros"),
            lambda: congruence(h["ros"](), C),
            (C, T),
        )
        yield (
            "convert_information gtsam→barfoot (batched)",
            lambda: lb.convert_information(C, T, "gtsam", "barfoot"),
            lambda: congruence(h["barfoot_inv"]().swapaxes(-1, -2), C),
            (C, T),
        )
        yield (
            "tangent_map gtsam→barfoot (batched)",
            lambda: lb.tangent_map(T, "gtsam", "barfoot"),
            h["barfoot"],
            (T,),
        )
        yield (
            "convert_jacobian gtsam→barfoot at_input (batched)",
            lambda: lb.convert_jacobian(J, T, "gtsam", "barfoot"),
            lambda: J @ h["barfoot_inv"](),
            (J, T),
        )
        yield (
            "convert_jacobian gtsam→barfoot at_output (batched)",
            lambda: lb.convert_jacobian(J, None, "gtsam", "barfoot", at_output=T),
            lambda: h["barfoot"]() @ J,
            (J, T),
        )

    for op, ours, hand, inputs in cases():
        fns = {"liebridge": ours, "liebridge_numpy": _numpy_only(ours), "hand_numpy": hand}
        rows.append(_row(op, n, fns, inputs, repeat))
    return rows


def single_more(repeat: int) -> list[dict[str, Any]]:
    """One pose: the other conversions against the same expression written with GTSAM."""
    import gtsam

    rng = np.random.default_rng(2)
    _, T = poses(1, rng)
    T = np.ascontiguousarray(T[0])
    C = covariances(1, rng)[0]
    J = rng.normal(size=(6, 6))
    P = P_SWAP

    def hand_ros_cov() -> np.ndarray:  # M = P·diag(R, R), R from GTSAM's Pose3
        R = gtsam.Pose3(T).rotation().matrix()
        M = np.zeros((6, 6))
        M[:3, 3:] = M[3:, :3] = R
        return np.asarray(M @ C @ M.T)

    def hand_info() -> np.ndarray:
        Mi = gtsam.Pose3(T).inverse().AdjointMap() @ P
        return np.asarray(Mi.T @ C @ Mi)

    def hand_jac() -> np.ndarray:
        p = gtsam.Pose3(T)
        return np.asarray(P @ p.AdjointMap() @ J @ p.inverse().AdjointMap() @ P)

    rows = []
    cases = {
        "convert_covariance gtsam→ros": (
            lambda: lb.convert_covariance(C, T, "gtsam", "ros"),
            hand_ros_cov,
        ),
        "convert_information gtsam→barfoot": (
            lambda: lb.convert_information(C, T, "gtsam", "barfoot"),
            hand_info,
        ),
        "convert_jacobian gtsam→barfoot (input and output)": (
            lambda: lb.convert_jacobian(J, T, "gtsam", "barfoot", at_output=T),
            hand_jac,
        ),
    }
    for op, (ours, hand) in cases.items():
        np.testing.assert_allclose(ours(), hand(), rtol=1e-10, atol=1e-12)
        fns = {"liebridge": ours, "hand_gtsam": hand, "liebridge_numpy": _numpy_only(ours)}
        t = interleaved(fns, repeat, min_time=0.02)
        med = {k: 1e6 * v["median_s"] for k, v in t.items()}
        row = {
            "op": op,
            "us": med,
            "ratio_vs_hand_gtsam": med["liebridge"] / med["hand_gtsam"],
            "numpy_fallback_ratio_vs_hand_gtsam": med["liebridge_numpy"] / med["hand_gtsam"],
            "target": "<= 1.3x hand_gtsam",
            "met": bool(med["liebridge"] <= 1.3 * med["hand_gtsam"]),
        }
        print(json.dumps(row), flush=True)
        rows.append(row)
    return rows


def _numpy_kernels(fn: Any) -> Any:
    """``fn`` with the compiled Lie kernels switched off (the numpy kernels)."""

    def run() -> Any:
        ext = _LIE_COMPILED._lie_ext
        _LIE_COMPILED._lie_ext = None
        try:
            return fn()
        finally:
            _LIE_COMPILED._lie_ext = ext

    return run


def kernels(n: int, repeat: int) -> list[dict[str, Any]]:
    """Batched Lie kernels at ``n`` elements against one memory pass (input and output copied).

    jaxlie is not installed here: no comparison with it.
    """
    rng = np.random.default_rng(3)
    xi, T = poses(n, rng)
    w = np.ascontiguousarray(xi[:, :3])
    Rm = np.ascontiguousarray(T[:, :3, :3])
    rows = []
    for op, fn, inp in (
        ("se3.exp", lambda: se3.exp(xi), xi),
        ("se3.log", lambda: se3.log(T), T),
        ("se3.adjoint", lambda: se3.adjoint(T), T),
        ("so3.exp", lambda: so3.exp(w), w),
        ("so3.log", lambda: so3.log(Rm), Rm),
    ):
        out = fn()
        like = np.empty_like(out)
        like[...] = 1.0
        np.testing.assert_allclose(
            out, _numpy_kernels(fn)(), rtol=0, atol=1e-13 * np.abs(out).max()
        )
        fns = {
            "liebridge": fn,
            "liebridge_numpy": _numpy_kernels(fn),
            "memory_pass": lambda i=inp, o=like: (i.copy(), o.copy()),
        }
        t = interleaved(fns, repeat, min_time=0.0)
        med = {k: v["median_s"] for k, v in t.items()}
        row = {
            "op": op,
            "n": n,
            "compiled": _LIE_COMPILED.COMPILED,
            "s": med,
            "x_memory_pass": med["liebridge"] / med["memory_pass"],
            "numpy_x_memory_pass": med["liebridge_numpy"] / med["memory_pass"],
            "target": "<= 3x a memory pass",
            "met": bool(med["liebridge"] <= 3 * med["memory_pass"]),
        }
        print(json.dumps(row), flush=True)
        rows.append(row)
        del out, like
    return rows


def main(argv: list[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="benchmarks/results/speed.json")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--lines", type=int, default=None)
    ap.add_argument("--repeat", type=int, default=None)
    ap.add_argument(
        "--parts",
        default="files,unscented,batched,single,kernels",
        help="comma-separated; rows of other parts are kept from an existing --out file",
    )
    args = ap.parse_args(argv)
    parts = set(args.parts.split(","))
    q = args.quick
    repeat = args.repeat or (2 if q else 5)
    lines = args.lines or (2000 if q else 1_000_000)
    lscpu = subprocess.run(["lscpu"], capture_output=True, text=True, check=False).stdout
    old = json.loads(Path(args.out).read_text()) if Path(args.out).is_file() else {}
    out = {
        **old,
        "machine": [ln for ln in lscpu.splitlines() if ln.startswith(("Model name", "CPU(s)"))],
        "python": platform.python_version(),
        "numpy": np.__version__,
    }
    if "files" in parts:
        out["files"] = files(lines, repeat)
    if "unscented" in parts:
        out["unscented"] = unscented(500 if q else 20_000, 0 if q else 1_000_000, repeat)
    if "batched" in parts:
        out["batched_all"] = batched(2000 if q else 100_000, repeat)
        out["batched"] = out["batched_all"][0]  # the headline row (gtsam→barfoot covariance)
    if "kernels" in parts:
        out["kernels"] = kernels(2000 if q else 1_000_000, max(repeat - 2, 2))
    if "single" in parts:
        out["single"] = single(repeat)
        for r in out["single"]:  # run.py's own target is 2x; this row's is 1.3x
            r["target"] = "<= 1.3x hand_gtsam"
            r["met"] = bool(r["ratio_vs_hand_gtsam"] <= 1.3)
            print(json.dumps(r), flush=True)
        out["single_more"] = single_more(repeat)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
