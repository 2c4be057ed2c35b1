"""Scale under hostile sizes: bounded memory for big bags and big batches, one parse per file.

Rows, each against what a user would otherwise write, in the same run:

* ``bag_export_tum``: ``liebridge bag export BAG --topic /odom --format tum`` (streamed,
  :func:`liebridge.ros.iter_messages`) on ROS 1 bags of ``nav_msgs/Odometry`` at two sizes,
  against ``read_messages`` (all arrays in memory) and the loop a user writes with rosbags
  (``AnyReader``: every message deserialized into a list, then written). Peak resident set
  (``ru_maxrss`` of a fresh subprocess each) and its growth per message between the two sizes:
  the streamed export must not grow with the bag.
* ``read_messages_bytes``: bytes that :func:`liebridge.ros.read_messages`' result holds per
  ``nav_msgs/Odometry`` message (``tracemalloc``: allocated and still held after the call, and
  the peak during it), on a ROS 1 bag of 1e5 messages, against the list of deserialized
  message objects a user's ``AnyReader`` loop holds (measured the same way on a tenth of them).
* ``unscented_compose``: ``liebridge.uncertain.compose(A, B, method="unscented")`` of ``n``
  poses (chunked) at two sizes; the unchunked pass (one chunk: what the code did before) at the
  smaller size only, its growth per pose extrapolated.
* ``kalibr_20mb``: ``liebridge extrinsics convert`` on a Kalibr YAML of ``--yaml-mb`` MB (a
  large look-up table under ``cam0``): time, and the number of parses (one), against
  ``yaml.safe_load`` (PyYAML's pure-Python loader, what a user writes) of the same file.

Usage: ``python benchmarks/bench_scale.py [--quick] [--out benchmarks/results/scale.json]``.
The machine may be shared: compare ratios and growths, not times.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


def _child(code: str, timeout: float = 3600) -> dict[str, Any]:
    """Run ``code`` in a fresh interpreter; it prints a JSON dict; add its peak RSS (MiB)."""
    wrapper = textwrap.dedent(
        """
        import json, resource, sys, time
        t0 = time.perf_counter()
        out = {}
        exec(compile(sys.argv[1], "<bench>", "exec"), {"out": out})
        out["seconds"] = time.perf_counter() - t0
        out["peak_rss_mib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(json.dumps(out))
        """
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.run(
        [sys.executable, "-c", wrapper, textwrap.dedent(code)],
        capture_output=True, text=True, timeout=timeout, env=env, cwd=ROOT,
    )  # fmt: skip
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr[-3000:])
    return dict(json.loads(proc.stdout.strip().splitlines()[-1]))


def _write_bag(path: Path, n: int) -> None:
    _child(
        f"""
        import numpy as np
        from liebridge import ros
        from liebridge.lie import se3
        rng = np.random.default_rng(0)
        k = 20000
        batches = []
        T = se3.exp(rng.normal(size=({n}, 6)))
        A = rng.normal(size=(k, 6, 6)) * 0.1
        C = A @ np.swapaxes(A, -1, -2) + 0.01 * np.eye(6)
        m = ros.from_poses(T, np.resize(C, ({n}, 6, 6)), stamps=np.arange({n}) * 0.01 + 1.0,
                           msgtype="nav_msgs/msg/Odometry", frame_id="odom",
                           twist=rng.normal(size=({n}, 6)))
        ros.write_messages({str(path)!r}, "/odom", m)
        """
    )


_EXPORT = """
from liebridge.cli import main
assert main(["bag", "export", {bag!r}, "--topic", "/odom", "--format", "tum", {out!r}]) == 0
"""
_READ = """
from liebridge import ros
m = ros.read_messages({bag!r}, "/odom")
out["n"] = len(m)
"""
_USER = """
from pathlib import Path
from rosbags.highlevel import AnyReader
with AnyReader([Path({bag!r})]) as r:
    conns = [c for c in r.connections if c.topic == "/odom"]
    msgs = [(t, r.deserialize(raw, c.msgtype)) for c, t, raw in r.messages(connections=conns)]
with open({out!r}, "w") as fh:
    for t, m in msgs:
        p, q = m.pose.pose.position, m.pose.pose.orientation
        s = m.header.stamp
        fh.write(f"{{s.sec}}.{{s.nanosec:09d}} {{p.x!r}} {{p.y!r}} {{p.z!r}} "
                 f"{{q.x!r}} {{q.y!r}} {{q.z!r}} {{q.w!r}}\\n")
"""


def bench_bags(sizes: tuple[int, int], tmp: Path) -> dict[str, Any]:
    rows: dict[str, Any] = {"sizes": list(sizes), "bag_mib": []}
    runs: dict[str, list[dict[str, Any]]] = {"export_tum": [], "read_messages": [], "user": []}
    for n in sizes:
        bag = tmp / f"odom_{n}.bag"
        _write_bag(bag, n)
        rows["bag_mib"].append(bag.stat().st_size / 2**20)
        for name, code in (("export_tum", _EXPORT), ("read_messages", _READ), ("user", _USER)):
            runs[name].append(_child(code.format(bag=str(bag), out=str(tmp / f"{name}.tum"))))
        bag.unlink()
    (n1, n2) = sizes
    for name, rs in runs.items():
        growth = (rs[1]["peak_rss_mib"] - rs[0]["peak_rss_mib"]) * 2**20 / (n2 - n1)
        rows[name] = {
            "peak_rss_mib": [r["peak_rss_mib"] for r in rs],
            "seconds": [r["seconds"] for r in rs],
            "rss_growth_bytes_per_message": growth,
        }
    rows["time_ratio_export_vs_user"] = (
        runs["export_tum"][1]["seconds"] / runs["user"][1]["seconds"]
    )
    return rows


def bench_bag_1gb(n: int, tmp: Path) -> dict[str, Any]:
    """``bag export --format tum`` of one bag of ``n`` Odometry messages (1.4e6: about 1 GB).

    The bag is written first, then exported in a fresh process whose peak resident set is the
    figure.
    """
    bag = tmp / "odom_1gb.bag"
    _write_bag(bag, n)  # (the writer holds the messages; the export below is what is measured)
    size = bag.stat().st_size
    run = _child(_EXPORT.format(bag=str(bag), out=str(tmp / "x.tum")))
    lines = sum(1 for _ in open(tmp / "x.tum"))
    bag.unlink()
    return {
        "messages": n,
        "bag_mib": size / 2**20,
        "export_peak_rss_mib": run["peak_rss_mib"],
        "export_seconds": run["seconds"],
        "tum_lines": lines,
    }


_HELD = """
import gc, tracemalloc
from pathlib import Path
from rosbags.highlevel import AnyReader
from liebridge import ros
ros.bag_info({bag!r})  # imports and type stores loaded before the count starts
gc.collect()
tracemalloc.start()
before = tracemalloc.get_traced_memory()[0]
if {user}:
    with AnyReader([Path({bag!r})]) as r:
        conns = [c for c in r.connections if c.topic == "/odom"]
        held = []
        for c, t, raw in r.messages(connections=conns):
            held.append((t, r.deserialize(raw, c.msgtype)))
            if len(held) == {n}:
                break
else:
    held = ros.read_messages({bag!r}, "/odom")
gc.collect()
now, peak = tracemalloc.get_traced_memory()
out["n"] = len(held)
out["held_bytes_per_message"] = (now - before) / len(held)
out["peak_bytes_per_message"] = (peak - before) / len(held)
"""


def bench_read_bytes(n: int, tmp: Path) -> dict[str, Any]:
    """``read_messages``' bytes per Odometry message held (tracemalloc), vs the user's list."""
    bag = tmp / f"odom_read_{n}.bag"
    _write_bag(bag, n)
    ours = _child(_HELD.format(bag=str(bag), user=False, n=n))
    user = _child(_HELD.format(bag=str(bag), user=True, n=max(n // 10, 1)))
    bag.unlink()
    return {
        "messages": n,
        "read_messages_held_bytes_per_message": ours["held_bytes_per_message"],
        "read_messages_peak_bytes_per_message": ours["peak_bytes_per_message"],
        "read_messages_seconds_traced": ours["seconds"],
        "user_list_messages": user["n"],
        "user_list_held_bytes_per_message": user["held_bytes_per_message"],
        "ratio_held_vs_user": ours["held_bytes_per_message"] / user["held_bytes_per_message"],
    }


_COMPOSE = """
import numpy as np
from liebridge.lie import se3
from liebridge.uncertain import UncertainPose, compose, ops
if {one_chunk}:
    ops.UNSCENTED_BYTES = 2**62
X = se3.exp(np.random.default_rng(0).normal(size=({n}, 6)) * 0.3)
C = np.diag([0.01, 0.02, 0.03, 0.1, 0.2, 0.3])
r = compose(UncertainPose(X, C, "gtsam"), UncertainPose(X, C, "gtsam"), method="unscented")
out["finite"] = bool(np.isfinite(r.cov).all())
"""


def bench_compose(sizes: tuple[int, int]) -> dict[str, Any]:
    chunked = [_child(_COMPOSE.format(n=n, one_chunk=False)) for n in sizes]
    small = sizes[0] // 4
    whole = [_child(_COMPOSE.format(n=n, one_chunk=True)) for n in (small, sizes[0])]
    per_pose_whole = (
        (whole[1]["peak_rss_mib"] - whole[0]["peak_rss_mib"]) * 2**20 / (sizes[0] - small)
    )
    per_pose_chunked = (
        (chunked[1]["peak_rss_mib"] - chunked[0]["peak_rss_mib"]) * 2**20 / (sizes[1] - sizes[0])
    )
    return {
        "sizes": list(sizes),
        "chunked_peak_rss_mib": [r["peak_rss_mib"] for r in chunked],
        "chunked_seconds": [r["seconds"] for r in chunked],
        "chunked_rss_growth_bytes_per_pose": per_pose_chunked,
        "one_chunk_sizes": [small, sizes[0]],
        "one_chunk_peak_rss_mib": [r["peak_rss_mib"] for r in whole],
        "one_chunk_rss_growth_bytes_per_pose": per_pose_whole,
        "one_chunk_extrapolated_mib_at_largest": whole[0]["peak_rss_mib"]
        + per_pose_whole * (sizes[1] - small) / 2**20,
    }


def bench_yaml(mb: float, tmp: Path) -> dict[str, Any]:
    f = tmp / "camchain-imucam.yaml"
    rng = np.random.default_rng(0)
    head = (
        "cam0:\n  T_cam_imu:\n  - [1.0, 0.0, 0.0, 0.0]\n  - [0.0, 1.0, 0.0, 0.0]\n"
        "  - [0.0, 0.0, 1.0, 0.0]\n  - [0.0, 0.0, 0.0, 1.0]\n  timeshift_cam_imu: 0.01\n  lut:\n"
    )
    with open(f, "w") as fh:
        fh.write(head)
        size = len(head)
        while size < mb * 1e6:
            rows = rng.normal(size=(1000, 8))
            text = "".join("  - [" + ", ".join(map(repr, r.tolist())) + "]\n" for r in rows)
            fh.write(text)
            size += len(text)
    ours = _child(
        f"""
        from liebridge.cli import main
        from liebridge.frames import calibration as C
        calls = []
        real = C._load_text
        C._load_text = lambda text, path: calls.append(1) or real(text, path)
        assert main(["extrinsics", "convert", {str(f)!r}, "--to-system", "okvis"]) == 0
        out["parses"] = len(calls)
        """
    )
    user = _child(
        f"""
        import yaml
        with open({str(f)!r}) as fh:
            yaml.safe_load(fh)
        """
    )
    return {
        "file_mib": f.stat().st_size / 2**20,
        "extrinsics_convert_seconds": ours["seconds"],
        "extrinsics_convert_parses": ours["parses"],
        "extrinsics_convert_peak_rss_mib": ours["peak_rss_mib"],
        "yaml_safe_load_seconds": user["seconds"],
        "ratio_vs_safe_load": ours["seconds"] / user["seconds"],
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (a smoke run)")
    ap.add_argument("--out", default=str(HERE / "results" / "scale.json"))
    ap.add_argument("--yaml-mb", type=float, default=None)
    ap.add_argument(
        "--only",
        choices=("read_messages_bytes", "bag_1gb"),
        default=None,
        help="run one row only (bag_1gb: the streamed export of a 1 GB bag, --messages)",
    )
    ap.add_argument("--messages", type=int, default=1_400_000, help="bag_1gb: Odometry messages")
    args = ap.parse_args()
    if args.only == "bag_1gb":
        with tempfile.TemporaryDirectory() as d:
            res = {"bag_1gb": bench_bag_1gb(args.messages, Path(d))}
        print(json.dumps(res, indent=2))
        out = Path(args.out)
        old = json.loads(out.read_text()) if out.exists() else {}
        old.update(res)
        out.write_text(json.dumps(old, indent=2) + "\n")
        return 0
    if args.only == "read_messages_bytes":
        with tempfile.TemporaryDirectory() as d:
            res = {
                "read_messages_bytes": bench_read_bytes(10_000 if args.quick else 100_000, Path(d))
            }
        print(json.dumps(res, indent=2))
        return 0
    bag_sizes = (10_000, 40_000) if args.quick else (100_000, 400_000)
    compose_sizes = (2_000, 8_000) if args.quick else (25_000, 100_000)
    yaml_mb = args.yaml_mb or (1.0 if args.quick else 20.0)
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        res = {
            "machine": f"{platform.machine()}, {os.cpu_count()} cores, {platform.platform()}",
            "python": platform.python_version(),
            "quick": args.quick,
            "bag_export_tum": bench_bags(bag_sizes, tmp),
            "read_messages_bytes": bench_read_bytes(bag_sizes[0], tmp),
            "unscented_compose": bench_compose(compose_sizes),
            "kalibr_yaml": bench_yaml(yaml_mb, tmp),
        }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(res, indent=2) + "\n")
    print(json.dumps(res, indent=2))
    return 0


if __name__ == "__main__":
    t0 = time.perf_counter()
    rc = main()
    print(f"total {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    sys.exit(rc)
