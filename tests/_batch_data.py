"""A synthetic fleet for the batch tests: (REF, EST) TUM pairs, some with covariances or broken."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from liebridge.io import trajfile
from liebridge.lie import se3

#: Kinds of deliberately broken pairs :func:`make_fleet` can write.
BROKEN = ("garbage", "missing", "nan", "no_overlap")


def trajectory(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A smooth helix with attitude wiggles, 10 Hz."""
    rng = np.random.default_rng(seed)
    s = 0.1 * np.arange(n)
    a = rng.uniform(0.03, 0.08)
    xi = np.zeros((n, 6))
    xi[:, 0] = 0.05 * np.sin(0.7 * s)
    xi[:, 1] = 0.03 * np.sin(1.3 * s)
    xi[:, 2] = a * s
    xi[:, 3] = 20 * np.cos(a * s)
    xi[:, 4] = 20 * np.sin(a * s)
    xi[:, 5] = 0.05 * s
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3] = se3.exp(np.column_stack([xi[:, :3], np.zeros((n, 3))]))[:, :3, :3]
    T[:, :3, 3] = xi[:, 3:]
    return 1.6e9 + 0.1 * np.arange(n), T


def make_pair(
    root: Path, k: int, n: int, *, cov: bool = False, broken: str | None = None
) -> dict[str, str]:
    """Write ``run{k}_ref.txt`` and ``run{k}_est.txt`` (and ``run{k}_est.cov.npy``); return the
    manifest row (``ref``, ``est`` and, with covariances, ``est_cov`` and ``convention``)."""
    rng = np.random.default_rng(1000 + k)
    t, T = trajectory(n, k)
    sigma = np.array([0.002, 0.002, 0.002, 0.02, 0.02, 0.02])  # GTSAM order (ω, v)
    d = rng.normal(size=(n, 6)) * sigma
    T_est = T @ se3.exp(d)
    t_est = t + rng.uniform(-0.003, 0.003, n)
    ref = root / f"run{k:04d}_ref.txt"
    est = root / f"run{k:04d}_est.txt"
    trajfile.write_trajectory(ref, t, T)
    trajfile.write_trajectory(est, t_est, T_est)
    row = {"ref": str(ref), "est": str(est)}
    if cov:
        C = np.tile(np.diag(sigma**2), (n, 1, 1))
        cpath = root / f"run{k:04d}_est.cov.npy"
        np.save(cpath, C)
        row.update(est_cov=str(cpath), convention="gtsam")
    if broken == "garbage":
        est.write_text("# timestamp tx ty tz qx qy qz qw\n1.0 2.0 three 4 5 6 7 8\n")
    elif broken == "missing":
        est.unlink()
    elif broken == "nan":
        lines = ref.read_text().splitlines()
        lines[5] = "nan " + " ".join(lines[5].split()[1:])
        ref.write_text("\n".join(lines) + "\n")
    elif broken == "no_overlap":
        trajfile.write_trajectory(est, t_est + 1e5, T_est)
    elif broken is not None:
        raise ValueError(broken)
    return row


def make_fleet(
    root: Path, pairs: int, n: int, *, broken: dict[int, str] | None = None, cov_every: int = 3
) -> list[dict[str, str]]:
    """``pairs`` pairs of ``n`` poses; every ``cov_every``-th with covariances; ``broken`` maps
    pair index to a kind of :data:`BROKEN`. Returns the manifest rows."""
    broken = broken or {}
    args = [(root, k, n, k % cov_every == 0, broken.get(k)) for k in range(pairs)]
    if pairs < 100:
        return [_pair(a) for a in args]
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    # a large fleet is written by a small pool (the files do not depend on one another)
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
        return list(pool.map(_pair, args, chunksize=25))


def _pair(a: tuple[Path, int, int, bool, str | None]) -> dict[str, str]:
    root, k, n, cov, broken = a
    return make_pair(root, k, n, cov=cov, broken=broken)


def write_manifest(path: Path, rows: list[dict[str, str]]) -> None:
    cols = ["ref", "est", "est_cov", "convention"]
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(",".join(cols) + "\n")
        for r in rows:
            fh.write(",".join(r.get(c, "") for c in cols) + "\n")


def environment_job(names: str) -> dict[str, str]:
    """A job that reports its worker's environment (picklable by reference: a module function)."""
    import os

    return {k: os.environ.get(k, "") for k in names.split(",")}
