"""(N, 4, 4) arrays <-> gtsam.Values: liebridge's glue against the per-key loop a user would write.

Run: ``python benchmarks/bench_values.py`` (prints a table; not a test). Rows:

* insert, loop        — ``for k, T: values.insert(k, gtsam.Pose3(T))`` (no validation)
* insert, to_values   — ``gtsam_glue.to_values`` (validates every rotation, checks keys, copies)
* read, loop          — ``np.stack([values.atPose3(k).matrix() for k in keys])``
* read, from_values   — ``gtsam_glue.from_values`` (``values.extract`` + one
  ``gtsam.utilities.extractPose3`` call + reorder)
* read, extractPose3  — the bare batch call alone (all Pose3 in key order, no key selection)
"""

from __future__ import annotations

import sys
import timeit
from collections.abc import Callable

import gtsam
import numpy as np
from scipy.spatial.transform import Rotation

from liebridge.gtsam import glue as gtsam_glue


def best_of(fn: Callable[[], object], repeat: int = 5) -> float:
    number = 1
    while timeit.timeit(fn, number=number) < 0.05:
        number *= 2
    return min(timeit.repeat(fn, number=number, repeat=repeat)) / number


def bench_size(n: int) -> None:
    rng = np.random.default_rng(0)
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3] = Rotation.random(n, random_state=rng).as_matrix()
    T[:, :3, 3] = rng.normal(size=(n, 3))
    keys = [int(k) for k in rng.permutation(10 * n)[:n]]  # unsorted, sparse keys

    def insert_loop() -> gtsam.Values:
        vals = gtsam.Values()
        for k, Ti in zip(keys, T, strict=True):
            vals.insert(k, gtsam.Pose3(Ti))
        return vals

    vals = insert_loop()

    def read_loop() -> np.ndarray:
        return np.stack([vals.atPose3(k).matrix() for k in keys])

    assert np.array_equal(gtsam_glue.from_values(vals, keys), read_loop())
    assert np.array_equal(gtsam_glue.from_values(gtsam_glue.to_values(T, keys), keys), T)
    rows: list[tuple[str, Callable[[], object]]] = [
        ("insert, loop", insert_loop),
        ("insert, to_values", lambda: gtsam_glue.to_values(T, keys)),
        ("read, loop", read_loop),
        ("read, from_values", lambda: gtsam_glue.from_values(vals, keys)),
        ("read, extractPose3", lambda: gtsam.utilities.extractPose3(vals)),
    ]
    base: dict[str, float] = {}
    for name, fn in rows:
        t = best_of(fn)
        kind = name.split(",")[0]
        base.setdefault(kind, t)
        print(f"{n:>7} {name:<22} {1e3 * t:>11.3f} {1e6 * t / n:>14.3f} {base[kind] / t:>7.2f}x")


def main(sizes: tuple[int, ...]) -> None:
    print(f"numpy {np.__version__}; 'vs loop' > 1 means faster than the per-key loop")
    print(f"{'N':>7} {'operation':<22} {'total [ms]':>11} {'per pose [µs]':>14} {'vs loop':>8}")
    for n in sizes:
        bench_size(n)


if __name__ == "__main__":
    main(tuple(int(a) for a in sys.argv[1:]) or (100, 1_000, 10_000))
