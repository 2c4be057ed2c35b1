"""liebridge's readers against ``numpy.loadtxt`` and evo's readers, same run.

Rows (each file generated here, in a temporary directory):

* ``read_tum``: ``liebridge.io.trajectory.read_tum`` on a ``--lines`` (default 10⁶) TUM file,
  against ``numpy.loadtxt(path)`` and ``evo.tools.file_interface.read_tum_trajectory_file``;
* ``read_kitti``: ``read_kitti`` on the same poses as KITTI, against ``numpy.loadtxt(path)`` and
  ``evo.tools.file_interface.read_kitti_poses_file``;
* ``read_g2o_3d``: ``liebridge.io.g2o.read`` on a ``--g2o-mib`` (default 254) MiB file —
  sphere2500 (GTSAM's example data) read, written as ``VERTEX_SE3:QUAT``/``EDGE_SE3:QUAT`` with
  ``repr`` numbers and replicated with renumbered ids. The ``loadtxt`` baseline reads the **same
  lines pre-split into one file per line type** (``grep``-like, not timed), with
  ``usecols`` dropping the tag: ``loadtxt(vertices, usecols=range(1, 9))`` +
  ``loadtxt(edges, usecols=range(1, 31))`` (ids as float64 — exact only below 2**53 — no
  quaternion or information checks). evo has no g2o reader (evo 1.38: ``file_interface`` reads
  TUM, KITTI, EuRoC and bags only), so this row has no evo column;
* ``read_g2o_2d``: ``liebridge.io.g2o2d.read`` on ``--g2o2d-mib`` (default 64) MiB of GTSAM's
  ``w10000.graph`` read, written as ``VERTEX_SE2``/``EDGE_SE2`` and replicated; baseline the
  same way (``usecols=range(1, 5)`` and ``range(1, 12)``);
* ``read_g2o_edge3``: ``g2o.read EDGE3 (TORO layout)``, ``liebridge.io.g2o.read`` on
  ``--edge3-mib`` (default 254) MiB of GTSAM's ``sphere2500.txt`` **as it is** (``EDGE3`` lines
  only, no vertex lines, 6 significant digits) replicated with renumbered ids and one odometry
  edge joining each copy to the previous one, so that the initial values chain over the whole
  file (the issue's 254 MiB file). Baseline: ``numpy.loadtxt(path, usecols=range(1, 30))`` on
  the same file (the tag dropped: ids as float64, no conversion, no chaining).

``--only edge3`` (or ``tum,kitti,g2o3d,g2o2d,edge3``) runs only those rows and replaces them in
an existing ``--out`` file, keeping its other rows.

Times: the candidates interleaved, ``--repeat`` times, median (``run.interleaved``). Memory: each
reader once in a fresh subprocess: peak traced by ``tracemalloc`` (numpy and Python allocations),
the process's peak resident set (``VmHWM``; ``rss_baseline_mib`` is that of the same process
reading nothing); ``returned_mib`` is the ``nbytes`` of the arrays the reader
returns (for evo: its trajectory's arrays). Targets: time ≤ 2× ``loadtxt`` and ≤ 2×
evo, traced peak ≤ 3× the arrays returned. The evo columns are skipped, and say so, when evo is
not installed.

Usage: ``python benchmarks/bench_files.py [--quick] [--out benchmarks/results/files.json]``.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's liebridge
sys.path.insert(0, str(Path(__file__).resolve().parent))
from run import interleaved, poses

from liebridge.io import g2o, g2o2d
from liebridge.io import trajectory as tio

ROOT = Path(__file__).resolve().parents[1]

HAVE_EVO = importlib.util.find_spec("evo") is not None

#: Run in a fresh interpreter: one reader call, its traced peak, returned bytes and ru_maxrss.
_MEMORY_PROBE = """
import json, sys, tracemalloc
import numpy as np
kind, path, extra = sys.argv[1], sys.argv[2], sys.argv[3:]

def nbytes(out):
    if isinstance(out, np.ndarray):
        return out.nbytes
    if isinstance(out, (tuple, list)):
        return sum(nbytes(o) for o in out)
    if type(out).__module__.startswith("evo"):  # PosePath3D / PoseTrajectory3D and its cache
        held = [*vars(out).values(), *vars(out._cache).values()]
        return sum(nbytes(v) for v in held if isinstance(v, (np.ndarray, list)))
    fields = [f for f in ("stamps", "T", "vertex_ids", "vertex_xyz_qxyzw", "vertex_xytheta",
              "edges", "measured_xyz_qxyzw", "measured_xytheta", "information")
              if hasattr(out, f)]
    return sum(getattr(out, f).nbytes for f in fields)

if kind == "read_tum":
    from liebridge.io.trajectory import read_tum
    def fn(path):  # the poses are random rotations: the order check would only warn
        return read_tum(path, check=False)
elif kind == "read_kitti":
    from liebridge.io.trajectory import read_kitti as fn
elif kind in ("read_g2o_3d", "read_g2o_edge3"):
    from liebridge.io.g2o import read as fn
elif kind == "read_g2o_2d":
    from liebridge.io.g2o2d import read as fn
elif kind == "evo_tum":
    from evo.tools.file_interface import read_tum_trajectory_file as fn
elif kind == "evo_kitti":
    from evo.tools.file_interface import read_kitti_poses_file as fn
elif kind == "loadtxt":
    def fn(path):
        cols = [range(int(a), int(b)) for a, b in (e.split(":") for e in extra[1:])]
        paths = extra[0].split(",") if extra else [path]
        return tuple(np.loadtxt(p, usecols=c) for p, c in zip(paths, cols)) if cols else (
            np.loadtxt(path))
tracemalloc.start()
out = fn(path)
peak = tracemalloc.get_traced_memory()[1]
tracemalloc.stop()
# VmHWM: this process's peak resident set (ru_maxrss would carry the parent's across exec)
hwm = next(ln for ln in open("/proc/self/status") if ln.startswith("VmHWM")).split()[1]
print(json.dumps({"peak": peak, "returned": nbytes(out), "hwm_kib": int(hwm)}))
"""


def _probe(kind: str, path: Path, *extra: str) -> dict[str, float]:
    proc = subprocess.run(
        [sys.executable, "-c", _MEMORY_PROBE, kind, str(path), *extra],
        capture_output=True,
        text=True,
        check=True,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    r = json.loads(proc.stdout.strip().splitlines()[-1])
    return {
        "peak_mib": r["peak"] / 2**20,
        "returned_mib": r["returned"] / 2**20,
        "rss_peak_mib": r["hwm_kib"] / 2**10,
    }


def _evo_reader(kind: str) -> Any:
    from evo.tools import file_interface as fi

    return {"evo_tum": fi.read_tum_trajectory_file, "evo_kitti": fi.read_kitti_poses_file}[kind]


def _baseline_rss() -> float:
    """Peak RSS (MiB) of the probe process reading nothing: interpreter, numpy, liebridge."""
    if "rss" not in _BASELINE:
        proc = subprocess.run(
            [sys.executable, "-c", _IDLE_PROBE],
            capture_output=True,
            text=True,
            check=True,
            cwd=ROOT,
            env={**os.environ, "PYTHONPATH": str(ROOT)},
        )
        _BASELINE["rss"] = int(proc.stdout.split()[-1]) / 2**10
    return _BASELINE["rss"]


_BASELINE: dict[str, float] = {}
_IDLE_PROBE = """
import numpy, liebridge.io.g2o, liebridge.io.g2o2d, liebridge.io.trajectory
print(next(ln for ln in open("/proc/self/status") if ln.startswith("VmHWM")).split()[1])
"""


def _row(
    op: str,
    path: Path,
    ours: Any,
    baseline: Any,
    baseline_probe: tuple[str, ...],
    evo_kind: str | None,
    repeat: int,
    baseline_name: str,
    **info: Any,
) -> dict[str, Any]:
    """Time ``ours`` against ``baseline`` (and evo's reader ``evo_kind``, None: no evo reader)."""
    fns = {"liebridge": ours, "loadtxt": baseline}
    if evo_kind is not None and HAVE_EVO:
        evo_read = _evo_reader(evo_kind)
        fns["evo"] = lambda: evo_read(path)
    t = interleaved(fns, repeat, min_time=0.0)
    med = {k: v["median_s"] for k, v in t.items()}
    mem = _probe(op, path)
    mem_np = _probe("loadtxt", path, *baseline_probe)
    row: dict[str, Any] = {
        "op": op,
        **info,
        "file_mib": path.stat().st_size / 2**20,
        "s": med,
        "ratio_vs_loadtxt": med["liebridge"] / med["loadtxt"],
        "loadtxt_baseline": baseline_name,
        "peak_mib": mem["peak_mib"],
        "rss_peak_mib": mem["rss_peak_mib"],
        "rss_baseline_mib": _baseline_rss(),
        "returned_mib": mem["returned_mib"],
        "peak_over_returned": mem["peak_mib"] / mem["returned_mib"],
        "loadtxt_peak_mib": mem_np["peak_mib"],
        "loadtxt_returned_mib": mem_np["returned_mib"],
    }
    if evo_kind is None:
        row["evo"] = "evo has no reader for this format"
    elif not HAVE_EVO:
        row["evo"] = "skipped: evo is not installed (pip install evo)"
    else:
        mem_evo = _probe(evo_kind, path)
        row["ratio_vs_evo"] = med["liebridge"] / med["evo"]
        row["evo_peak_mib"] = mem_evo["peak_mib"]
        row["evo_returned_mib"] = mem_evo["returned_mib"]
    row["met"] = bool(
        row["ratio_vs_loadtxt"] <= 2.0
        and row.get("ratio_vs_evo", 0.0) <= 2.0
        and row["peak_over_returned"] <= 3.0
    )
    print(json.dumps(row), flush=True)
    return row


def trajectories(lines: int, repeat: int, d: Path) -> list[dict[str, Any]]:
    _, T = poses(lines, np.random.default_rng(0))
    tum, kitti = d / "t.txt", d / "k.txt"
    tio.write_tum(tum, np.arange(lines) * 0.01, T)
    tio.write_kitti(kitti, T)
    rows = []
    for op, path, fn, evo_kind in (
        ("read_tum", tum, lambda p: tio.read_tum(p, check=False), "evo_tum"),
        ("read_kitti", kitti, tio.read_kitti, "evo_kitti"),
    ):
        rows.append(
            _row(
                op,
                path,
                lambda f=fn, p=path: f(p),
                lambda p=path: np.loadtxt(p),
                (),
                evo_kind,
                repeat,
                "numpy.loadtxt(path)",
                lines=lines,
            )
        )
    return rows


def _replicate(src: Path, dst: Path, mib: float, stride: int) -> None:
    """Write copies of a graph file, ids shifted by ``stride`` per copy, vertices first."""
    text = src.read_text().splitlines()
    vertices = [ln.split(" ", 2) for ln in text if ln.startswith("VERTEX")]
    edges = [ln.split(" ", 3) for ln in text if ln.startswith("EDGE")]
    copies = max(1, round(mib * 2**20 / src.stat().st_size))
    with open(dst, "w", encoding="utf-8") as fh:
        for r in range(copies):
            o = stride * r
            fh.writelines(f"{t} {int(k) + o} {rest}\n" for t, k, rest in vertices)
        for r in range(copies):
            o = stride * r
            fh.writelines(f"{t} {int(i) + o} {int(j) + o} {rest}\n" for t, i, j, rest in edges)


def _split(path: Path, d: Path) -> tuple[Path, Path]:
    """Write the vertex and edge lines of ``path`` to two files (the loadtxt baseline's input)."""
    v, e = d / f"{path.stem}.vertices", d / f"{path.stem}.edges"
    with open(path, encoding="utf-8") as src, open(v, "w") as fv, open(e, "w") as fe:
        for ln in src:
            (fv if ln.startswith("VERTEX") else fe).write(ln)
    return v, e


def graphs(mib3: float, mib2: float, repeat: int, d: Path) -> list[dict[str, Any]]:
    import gtsam

    rows = []
    for op, data, mod, mib, cols, stride in (
        ("read_g2o_3d", "sphere2500.txt", g2o, mib3, ((1, 9), (1, 31)), 2500),
        ("read_g2o_2d", "w10000.graph", g2o2d, mib2, ((1, 5), (1, 12)), 10000),
    ):
        if mib <= 0:
            continue
        one = d / f"{op}_one.g2o"
        mod.write(one, mod.read(gtsam.findExampleDataFile(data)))  # type: ignore[attr-defined]
        path = d / f"{op}.g2o"
        _replicate(one, path, mib, stride)
        v, e = _split(path, d)
        (cv, ce) = (range(*cols[0]), range(*cols[1]))
        g = mod.read(path)  # type: ignore[attr-defined]
        rows.append(
            _row(
                op,
                path,
                lambda m=mod, p=path: m.read(p),
                lambda v=v, e=e, cv=cv, ce=ce: (
                    np.loadtxt(v, usecols=cv),
                    np.loadtxt(e, usecols=ce),
                ),
                (f"{v},{e}", f"{cols[0][0]}:{cols[0][1]}", f"{cols[1][0]}:{cols[1][1]}"),
                None,
                repeat,
                f"numpy.loadtxt on the vertex lines (usecols=range{cols[0]}) and on the edge "
                f"lines (usecols=range{cols[1]}), pre-split into two files",
                vertices=int(g.vertex_ids.shape[0]),
                edges=int(g.edges.shape[0]),
                source=f"{data} (GTSAM example data) written by liebridge and replicated",
            )
        )
    return rows


def _replicate_edge3(src: Path, dst: Path, mib: float) -> tuple[int, int]:
    """Write copies of an ``EDGE3``-only file, ids shifted by ``n`` per copy; return the sizes.

    Each copy's first vertex is joined to the previous copy's last by a copy of the edge
    ``0 -> 1``: one odometry chain; copies are added until the file holds ``mib`` MiB (ASCII).
    Returns ``(vertices, edges)``.
    """
    edges = [ln.split(" ", 3) for ln in src.read_text().splitlines() if ln.startswith("EDGE3 ")]
    n = 1 + max(max(int(i), int(j)) for _, i, j, _ in edges)
    link = next(rest for _, i, j, rest in edges if (int(i), int(j)) == (0, 1))
    copies, size = 0, 0
    with open(dst, "w", encoding="utf-8") as fh:
        while copies == 0 or size < mib * 2**20:  # copies until the file holds mib MiB
            o = n * copies
            text = f"EDGE3 {o - 1} {o} {link}\n" if copies else ""
            text += "".join(f"{t} {int(i) + o} {int(j) + o} {rest}\n" for t, i, j, rest in edges)
            size += fh.write(text)
            copies += 1
    return n * copies, len(edges) * copies + copies - 1


def edge3_graph(mib: float, repeat: int, d: Path) -> list[dict[str, Any]]:
    import gtsam

    if mib <= 0:
        return []
    path = d / "sphere2500_edge3.txt"
    n_vertices, n_edges = _replicate_edge3(
        Path(gtsam.findExampleDataFile("sphere2500.txt")), path, mib
    )
    return [
        _row(
            "read_g2o_edge3",
            path,
            lambda: g2o.read(path),
            lambda: np.loadtxt(path, usecols=range(1, 30)),
            (str(path), "1:30"),
            None,
            repeat,
            "numpy.loadtxt(path, usecols=range(1, 30)) on the same file (the tag dropped)",
            vertices=n_vertices,
            edges=n_edges,
            source="sphere2500.txt (GTSAM example data, EDGE3 lines only, no vertex lines) "
            "replicated with renumbered ids, one odometry edge joining the copies",
        )
    ]


def main(argv: list[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="benchmarks/results/files.json")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--lines", type=int, default=None)
    ap.add_argument("--g2o-mib", type=float, default=None)
    ap.add_argument("--g2o2d-mib", type=float, default=None)
    ap.add_argument("--edge3-mib", type=float, default=None)
    ap.add_argument("--repeat", type=int, default=None)
    ap.add_argument("--only", default=None, help="comma list of tum,kitti,g2o3d,g2o2d,edge3")
    args = ap.parse_args(argv)
    q = args.quick
    repeat = args.repeat or (1 if q else 3)
    lines = args.lines or (2000 if q else 1_000_000)
    mib3 = args.g2o_mib if args.g2o_mib is not None else (2.0 if q else 254.0)
    mib2 = args.g2o2d_mib if args.g2o2d_mib is not None else (1.0 if q else 64.0)
    mibe = args.edge3_mib if args.edge3_mib is not None else (2.0 if q else 254.0)
    only = set(args.only.split(",")) if args.only else None
    if only is not None:
        mib3 = mib3 if "g2o3d" in only else 0.0
        mib2 = mib2 if "g2o2d" in only else 0.0
        mibe = mibe if "edge3" in only else 0.0
    lscpu = subprocess.run(["lscpu"], capture_output=True, text=True, check=False).stdout
    out: dict[str, Any] = {
        "command": " ".join(["python benchmarks/bench_files.py", *(argv or sys.argv[1:])]),
        "machine": [ln for ln in lscpu.splitlines() if ln.startswith(("Model name", "CPU(s)"))],
        "python": platform.python_version(),
        "numpy": np.__version__,
        "evo": _evo_version(),
    }
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        rows = trajectories(lines, repeat, d) if only is None or {"tum", "kitti"} & only else []
        if only is not None:
            keep = {"tum": "read_tum", "kitti": "read_kitti"}
            rows = [r for r in rows if any(r["op"] == keep[k] for k in only if k in keep)]
        rows += graphs(mib3, mib2, repeat, d) + edge3_graph(mibe, repeat, d)
    if only is not None and Path(args.out).exists():  # replace these rows, keep the others
        old = json.loads(Path(args.out).read_text())
        for r in rows:
            r["command"] = out["command"]
        new_ops = {r["op"] for r in rows}
        rows = [r for r in old["rows"] if r["op"] not in new_ops] + rows
        out = {**old, **{k: v for k, v in out.items() if k != "command"}}
    out["rows"] = rows
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=2) + "\n")
    return out


def _evo_version() -> str:
    if not HAVE_EVO:
        return "not installed: evo rows skipped"
    from importlib.metadata import version

    return version("evo")


if __name__ == "__main__":
    main()
