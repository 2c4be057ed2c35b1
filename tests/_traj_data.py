"""Trajectories for the traj tests: GTSAM's sphere2500 poses (shipped dataset) plus noise."""

from __future__ import annotations

import functools

import numpy as np

from liebridge.lie import se3


@functools.lru_cache(maxsize=1)
def sphere_poses() -> np.ndarray:
    import gtsam

    from liebridge.io import g2o

    return g2o.read(gtsam.findExampleDataFile("sphere2500.txt")).poses


def noisy_pair(n: int = 600, seed: int = 0, scale: float = 1.0, step: int = 2):
    """``(t_ref, T_ref, t_est, T_est)``: the estimate in another world frame, noisy, jittered
    stamps, every ``step``-th pose, translations scaled by ``scale``."""
    rng = np.random.default_rng(seed)
    T_ref = sphere_poses()[:n].copy()
    t_ref = 100.0 + 0.1 * np.arange(n)
    xi = rng.normal(scale=[0.01] * 3 + [0.05] * 3, size=(n, 6))
    G = se3.exp([0.1, -0.2, 0.5, 3.0, -2.0, 1.0])
    T_est = G @ T_ref @ se3.exp(xi)
    T_est[:, :3, 3] *= scale
    t_est = t_ref + rng.uniform(-0.004, 0.004, n)
    return t_ref, T_ref, t_est[::step].copy(), T_est[::step].copy()
