"""Issue 23 rows: where users spend time — files, huge batches, batched and single conversions.

Each row is a ratio against what a user would otherwise run, timed in the same process,
interleaved and repeated (median); memory rows report the peak traced by ``tracemalloc``
(Python and numpy allocations) while one call runs.

* ``files``: ``read_tum``/``read_kitti`` vs ``numpy.loadtxt`` on the same file (``--lines``,
  default 10⁶), time and peak memory against the arrays returned;
* ``unscented``: ``convert_covariance(method="unscented")`` chunked (default) vs one pass, at
  ``--uns-n`` (default 20,000) covariances, time and traced peak; then 10⁶ chunked;
* ``batched``: ``convert_covariance`` gtsam→barfoot at 10⁵ poses vs the vectorised numpy a user
  would write (``M @ Σ @ Mᵀ``, ``M = P·Ad``), and one memory pass (copy of input + output);
* ``single``: the same for one pose vs ``P @ gtsam.Pose3(T).AdjointMap()`` (``run.single``).

Usage: ``python benchmarks/bench_speed.py [--quick] [--out benchmarks/results/speed.json]``.
"""

from __future__ import annotations

import argparse
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


def _peak(fn: Any) -> tuple[int, int]:
    """Traced peak bytes (Python and numpy allocations) while ``fn`` runs, bytes returned."""
    tracemalloc.start()
    out = fn()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    arrays = out if isinstance(out, tuple) else (out,)
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
            ("read_tum", tum, tio.read_tum),
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


def batched(n: int, repeat: int) -> dict[str, Any]:
    rng = np.random.default_rng(2)
    _, T = poses(n, rng)
    C = covariances(n, rng)

    def hand() -> np.ndarray:  # what a user writes: M = P·Ad(T), M Σ Mᵀ, vectorised
        R, t = T[:, :3, :3], T[:, :3, 3]
        th = np.zeros((n, 3, 3))
        th[:, 0, 1], th[:, 0, 2], th[:, 1, 2] = -t[:, 2], t[:, 1], -t[:, 0]
        th[:, 1, 0], th[:, 2, 0], th[:, 2, 1] = t[:, 2], -t[:, 1], t[:, 0]
        Ad = np.zeros((n, 6, 6))
        Ad[:, :3, :3] = Ad[:, 3:, 3:] = R
        Ad[:, 3:, :3] = th @ R
        M = P_SWAP @ Ad
        return np.asarray(M @ C @ M.swapaxes(-1, -2))

    def ours() -> np.ndarray:
        return lb.convert_covariance(C, T, "gtsam", "barfoot")

    np.testing.assert_allclose(ours(), hand(), rtol=1e-10, atol=1e-9)
    src = np.concatenate([C.reshape(n, -1), T.reshape(n, -1)], axis=1)
    t = interleaved(
        {"liebridge": ours, "hand_numpy": hand, "memory_pass": lambda: (src.copy(), C.copy())},
        repeat,
        min_time=0.0,
    )
    med = {k: v["median_s"] for k, v in t.items()}
    row = {
        "op": "convert_covariance gtsam→barfoot (batched)",
        "n": n,
        "s": med,
        "speedup_vs_hand_numpy": med["hand_numpy"] / med["liebridge"],
        "x_memory_pass": med["liebridge"] / med["memory_pass"],
        "hand_numpy_x_memory_pass": med["hand_numpy"] / med["memory_pass"],
        "target": ">= 1.5x faster than hand numpy",
        "met": bool(med["hand_numpy"] / med["liebridge"] >= 1.5),
    }
    print(json.dumps(row), flush=True)
    return row


def main(argv: list[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="benchmarks/results/speed.json")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--lines", type=int, default=None)
    ap.add_argument("--repeat", type=int, default=None)
    ap.add_argument(
        "--parts",
        default="files,unscented,batched,single",
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
        out["batched"] = batched(2000 if q else 100_000, repeat)
    if "single" in parts:
        out["single"] = single(repeat)
        for r in out["single"]:  # run.py's own target is 2x; issue 23 asks for 1.3x
            r["target"] = "<= 1.3x hand_gtsam (issue 23)"
            r["met"] = bool(r["ratio_vs_hand_gtsam"] <= 1.3)
            print(json.dumps(r), flush=True)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
