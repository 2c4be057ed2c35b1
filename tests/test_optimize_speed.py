"""The damped system is built by sharing the linear factors and a cached damping graph.

The damping graph holds one ``√λ·I`` factor per variable of the graph's *own* dimension; a graph
mixing ``Pose3`` (6) and ``Point3`` (3) variables exercises both sizes. The property is the one
GTSAM's ``LevenbergMarquardtOptimizer`` defines: same iterations, same final error.
"""

from __future__ import annotations

import gtsam
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from liebridge.gtsam import between, optimize, prior


def _pose(rng: np.random.Generator) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(rng.normal(size=3) * 0.3).as_matrix()
    T[:3, 3] = rng.normal(size=3)
    return T


def _mixed_graph(conv: str, seed: int) -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values]:
    rng = np.random.default_rng(seed)
    n = 8
    truth = [np.eye(4)] + [_pose(rng) for _ in range(n - 1)]
    for k in range(1, n):
        truth[k] = truth[k - 1] @ truth[k]
    g = gtsam.NonlinearFactorGraph()
    v = gtsam.Values()
    cov = np.diag([0.01, 0.02, 0.01, 0.05, 0.04, 0.05])
    g.add(prior(0, truth[0], cov, "gtsam", native=False))
    for k in range(n):
        v.insert(k, gtsam.Pose3(truth[k]).retract(rng.normal(size=6) * 0.1))
    for i, j in [(k, k + 1) for k in range(n - 1)] + [(0, n - 1), (2, 6)]:
        Z = np.linalg.inv(truth[i]) @ truth[j]
        g.add(between(i, j, Z, cov, conv, native=False))
    # Point3 variables (native GTSAM factors, linearized by GTSAM): a prior and a chain
    pts = [rng.normal(size=3) * 3 for _ in range(3)]
    noise = gtsam.noiseModel.Isotropic.Sigma(3, 0.05)
    for m, p_world in enumerate(pts):
        v.insert(100 + m, gtsam.Point3(*(p_world + rng.normal(size=3) * 0.2)))
        g.add(gtsam.PriorFactorPoint3(100 + m, gtsam.Point3(*p_world), noise))
        if m:
            g.add(
                gtsam.BetweenFactorPoint3(
                    99 + m, 100 + m, gtsam.Point3(*(p_world - pts[m - 1])), noise
                )
            )
    return g, v


@pytest.mark.parametrize("conv", ["gtsam", "barfoot", "ros"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_mixed_dimensions_match_gtsam_lm(conv: str, seed: int) -> None:
    g, v = _mixed_graph(conv, seed)
    size = g.size()
    p = gtsam.LevenbergMarquardtParams()
    ours = optimize(g, v, p, progress=False)
    opt = gtsam.LevenbergMarquardtOptimizer(g, v, p)
    theirs = opt.optimize()
    assert g.size() == size  # the caller's graph is not extended by damping factors
    assert ours.iterations == opt.iterations()
    ref = g.error(theirs)
    assert ours.final_error == pytest.approx(ref, rel=1e-6, abs=1e-9)
    for k in [0, 5, 101]:
        assert v.exists(k)
    assert ours.values.atPoint3(101) == pytest.approx(theirs.atPoint3(101), abs=1e-6)


def test_repeated_lambda_reuses_damping_without_changing_the_result() -> None:
    # A λ that bounces (factor 2, bad start) revisits values; the cached damping graphs must
    # give the same steps as GTSAM, which rebuilds them every time.
    g, v = _mixed_graph("barfoot", 3)
    p = gtsam.LevenbergMarquardtParams()
    p.setlambdaInitial(1e3)
    p.setlambdaFactor(2.0)
    ours = optimize(g, v, p, progress=False)
    opt = gtsam.LevenbergMarquardtOptimizer(g, v, p)
    theirs = opt.optimize()
    assert ours.iterations == opt.iterations()
    assert ours.final_error == pytest.approx(g.error(theirs), rel=1e-6, abs=1e-9)
