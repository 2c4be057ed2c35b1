"""Inputs for the library-oracle tests, built without liebridge (so they cannot share its bugs).

Rotations come from scipy, poses are assembled by hand; angles cover the generic range and the
edges (near 0, near π). Used by ``test_presets_libs.py`` and ``test_presets_symforce_mr.py``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

PI = math.pi
N_AXES = 4  # random axes per angle


def unit(rng: np.random.Generator, n: int) -> np.ndarray:
    u = rng.normal(size=(n, 3))
    return u / np.linalg.norm(u, axis=-1, keepdims=True)


def pose(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    T = np.zeros((*R.shape[:-2], 4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = t
    T[..., 3, 3] = 1.0
    return T


def rot(w: np.ndarray) -> np.ndarray:
    w = np.asarray(w, dtype=np.float64)
    return np.asarray(Rotation.from_rotvec(w.reshape(-1, 3)).as_matrix()).reshape(
        (*w.shape[:-1], 3, 3)
    )


def translations(rng: np.random.Generator, n: int, max_norm: float = 30.0) -> np.ndarray:
    return rng.uniform(0.0, max_norm, size=(n, 1)) * unit(rng, n)


def rotvecs(rng: np.random.Generator, angles: tuple[float, ...]) -> np.ndarray:
    th = np.repeat(np.asarray(angles), N_AXES)
    return th[:, None] * unit(rng, th.size)


def base_poses(rng: np.random.Generator, n: int) -> np.ndarray:
    """Poses with rotation angles uniform in [0, π] and translations up to 30 m."""
    return pose(rot(rng.uniform(0.0, PI, size=(n, 1)) * unit(rng, n)), translations(rng, n))
