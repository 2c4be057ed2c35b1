"""Levenberg–Marquardt never accepts an uphill step (a mutation the slow tests alone caught)."""

from __future__ import annotations

import itertools
import re

import gtsam
import numpy as np
import pytest

from liebridge.gtsam import between, optimize, prior
from liebridge.lie import se3


def _loop_graph(conv: str, seed: int) -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values]:
    """A 12-pose circle with loop closures, initialized far off (GN steps overshoot there)."""
    rng = np.random.default_rng(seed)
    n = 12
    T = [np.eye(4)]
    for _ in range(1, n):
        T.append(T[-1] @ se3.exp(np.r_[0, 0, 2 * np.pi / n, 2 * np.sin(np.pi / n), 0, 0]))
    g = gtsam.NonlinearFactorGraph()
    g.add(prior(0, T[0], np.eye(6) * 1e-4, conv, native=False))
    cov = np.diag([0.01, 0.01, 0.01, 0.04, 0.04, 0.04])
    for i in range(n):
        for j in (i + 1, i + 3):
            if j < n:
                Z = se3.inverse(T[i]) @ T[j] @ se3.exp(rng.normal(scale=0.05, size=6))
                g.add(between(i, j, Z, cov, conv, native=False))
    v = gtsam.Values()
    for k in range(n):
        v.insert(k, gtsam.Pose3(T[k] @ se3.exp(rng.normal(scale=[1.2, 1.2, 1.2, 6, 6, 6]))))
    return g, v


@pytest.mark.parametrize("conv", ["gtsam", "g2o", "ros"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_every_accepted_step_lowers_the_error(conv: str, seed: int) -> None:
    g, v = _loop_graph(conv, seed)
    params = gtsam.LevenbergMarquardtParams()
    params.setlambdaInitial(1e-9)  # start as Gauss–Newton: overshooting steps get proposed
    params.setMaxIterations(60)
    lines: list[str] = []
    res = optimize(g, v, params, progress=lines.append)
    pairs = [
        (float(a), float(b))
        for a, b in re.findall(r"error ([-+0-9.eE]+) \(from ([-+0-9.eE]+)\)", "\n".join(lines))
    ]
    assert pairs, "no iteration reported"
    for new, old in pairs:
        assert new <= old * (1 + 1e-12), f"an iteration went uphill: {old} -> {new}"
    errors = [old for _, old in pairs] + [pairs[-1][0]]
    assert all(b <= a * (1 + 1e-12) for a, b in itertools.pairwise(errors))
    assert res.final_error < res.initial_error
    # and the same optimum as GTSAM's own LM on the same graph
    ref = gtsam.LevenbergMarquardtOptimizer(g, v, params).optimize()
    assert res.final_error == pytest.approx(g.error(ref), rel=1e-6, abs=1e-9)


def _errors(lines: list[str]) -> list[tuple[float, float]]:
    found = re.findall(r"error ([-+0-9.eE]+) \(from ([-+0-9.eE]+)\)", "\n".join(lines))
    return [(float(a), float(b)) for a, b in found]


@pytest.mark.parametrize("angle_deg", [100.0, 120.0, 135.0, 170.0])
def test_an_overshooting_gauss_newton_step_is_rejected(angle_deg: float) -> None:
    """A prior in g2o's quaternion-vector chart, 100–170° off: there ∂qvec/∂δ ≈ cos(θ/2)/2 is
    small, the undamped step is huge and lands uphill; LM must reject it and raise λ.
    """
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    Z = se3.exp(np.r_[np.deg2rad(angle_deg) * axis, 1.0, 2.0, 3.0])
    g = gtsam.NonlinearFactorGraph()
    g.add(prior(0, Z, np.eye(6) * 0.01, "g2o", native=False))
    v = gtsam.Values()
    v.insert(0, gtsam.Pose3())
    params = gtsam.LevenbergMarquardtParams()
    params.setlambdaInitial(1e-9)
    lines: list[str] = []
    res = optimize(g, v, params, progress=lines.append)
    pairs = _errors(lines)
    assert pairs and all(new <= old for new, old in pairs), pairs
    assert res.final_error < 1e-12 * max(1.0, res.initial_error)
