"""liebridge.gtsam.ISAM2 against GTSAM's own iSAM2, on sphere2500 fed 25 poses per update.

The promise (docs/isam2.md): GTSAM eliminates, at every update, the convention's own Jacobians at
exactly the linearization points its native iSAM2 uses. Checked three ways: (1) every liebridge
container in GTSAM's graph equals the liebridge factor linearized by GTSAM at GTSAM's current θ;
(2) estimates equal ``gtsam.ISAM2`` with GTSAM's native factors (conventions related to GTSAM's
linearly: the same objective) to 1e-8 on a 300-pose prefix (measured 6e-11); (3) for a
non-linear chart (g2o) they equal ``gtsam.ISAM2`` fed the very same ``CustomFactor``s.
The full sphere2500 run is the slow test.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gtsam
import numpy as np
import pytest

import liebridge.factors as F
from liebridge.conventions import convert_covariance, is_exactly_linear
from liebridge.gtsam import ISAM2

ROOT = Path(__file__).resolve().parents[1]
PRIOR_COV = np.eye(6) * 1e-8


@pytest.fixture(scope="module")
def sphere() -> list[Any]:
    graph, _ = gtsam.readG2o(gtsam.findExampleDataFile("sphere2500.txt"), True)
    return [graph.at(k) for k in range(graph.size())]


def _factors(edges: list[Any], conv: str | None, native: bool = False) -> tuple[Any, list[Any]]:
    """(prior on 0, factor per edge); ``conv`` None: GTSAM's own factors."""
    if conv is None:
        noise = gtsam.noiseModel.Gaussian.Covariance(PRIOR_COV)
        return gtsam.PriorFactorPose3(0, gtsam.Pose3(), noise), list(edges)
    out = []
    for f in edges:
        i, j = f.keys()
        Z = f.measured().matrix()
        cov = convert_covariance(f.noiseModel().covariance(), Z, "gtsam", conv)
        out.append(F.between(i, j, Z, cov, conv, native=native))
    cov0 = convert_covariance(PRIOR_COV, np.eye(4), "gtsam", conv)
    return F.prior(0, np.eye(4), cov0, conv, native=native), out


def feed(
    edges: list[Any],
    n: int,
    isam: Any,
    conv: str | None,
    after: Callable[[Any], None] | None = None,
    prior_native: bool = False,
    native_below: int = 0,
) -> Any:
    """Poses 0..n-1 in updates of 25, each new pose at the estimate of the previous ∘ odometry."""
    edges = [f for f in edges if max(f.keys()) < n]
    first, factors = _factors(edges, conv)
    factors = [
        f if max(f.keys()) >= native_below else e for f, e in zip(factors, edges, strict=True)
    ]
    if prior_native or native_below > 0:
        first = _factors([], None)[0]
    by_last: dict[int, list[Any]] = {}
    for f, g in zip(edges, factors, strict=True):
        by_last.setdefault(max(f.keys()), []).append(g)
    odo = {f.keys()[1]: f.measured() for f in edges if f.keys()[1] == f.keys()[0] + 1}
    inner = isam.isam2 if isinstance(isam, ISAM2) else isam
    prev = gtsam.Pose3()
    for start in range(0, n, 25):
        graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        for k in range(start, min(start + 25, n)):
            T = gtsam.Pose3() if k == 0 else prev.compose(odo[k])
            if k == 0:
                graph.add(first)
            values.insert(k, T)
            prev = T
            for g in by_last.get(k, []):
                graph.add(g)
        isam.update(graph, values)
        if after is not None:
            after(graph)
        prev = inner.calculateEstimatePose3(min(start + 25, n) - 1)
    return isam.calculate_estimate() if isinstance(isam, ISAM2) else isam.calculateEstimate()


def max_diff(a: Any, b: Any, n: int) -> float:
    return max(float(np.abs(a.atPose3(k).matrix() - b.atPose3(k).matrix()).max()) for k in range(n))


def params(threshold: float = 0.1, skip: int = 10, wildfire: float | None = None) -> Any:
    p = gtsam.ISAM2Params()
    p.setRelinearizeThreshold(threshold)
    p.relinearizeSkip = skip
    if wildfire is not None:
        gn = gtsam.ISAM2GaussNewtonParams()
        gn.setWildfireThreshold(wildfire)
        p.setOptimizationParams(gn)
    return p


# ----------------------------------------------------------------------------- the same estimates
#: presets whose residual is a constant linear map of GTSAM's: the same objective as native factors
EXACTLY_LINEAR = ["gtsam", "barfoot", "sophus", "manif", "pinocchio"]


@pytest.mark.parametrize("conv", EXACTLY_LINEAR)
@pytest.mark.parametrize(
    "kw", [{}, {"threshold": 0.05, "skip": 1}, {"wildfire": 0.0}], ids=["default", "skip1", "wf0"]
)
def test_same_estimates_as_native_isam2_on_a_prefix(sphere, conv, kw):
    assert is_exactly_linear(conv, "gtsam")
    n = 300  # 12 updates: relinearization at update 10 (default skip), or every update
    ref = feed(sphere, n, gtsam.ISAM2(params(**kw)), None)
    est = feed(sphere, n, ISAM2(params(**kw)), conv)
    assert max_diff(est, ref, n) < 1e-8


def test_odometry_alone_would_be_far_off(sphere):
    """The comparison above can fail: the estimates moved far from the initial guesses."""
    n = 300
    ref = feed(sphere, n, gtsam.ISAM2(), None)
    edges = [f for f in sphere if max(f.keys()) < n]
    odo = {f.keys()[1]: f.measured() for f in edges if f.keys()[1] == f.keys()[0] + 1}
    T = gtsam.Pose3()
    chain = gtsam.Values()
    chain.insert(0, T)
    for k in range(1, n):
        T = T.compose(odo[k])
        chain.insert(k, T)
    assert max_diff(chain, ref, n) > 1.0


@pytest.mark.parametrize("conv", ["g2o", "ros", "symforce"])
def test_non_linear_chart_equals_isam2_with_the_same_custom_factors(sphere, conv):
    assert not is_exactly_linear(conv, "gtsam")  # another objective: no native factor is exact
    n = 100  # gtsam.ISAM2 with CustomFactors is the slow baseline
    ref = feed(sphere, n, gtsam.ISAM2(params(skip=1)), conv)
    est = feed(sphere, n, ISAM2(params(skip=1)), conv)
    assert max_diff(est, ref, n) < 1e-8


def test_mixed_graph_gtsam_prior_with_liebridge_betweens(sphere):
    n = 150
    ref = feed(sphere, n, gtsam.ISAM2(params(skip=2)), None)
    est = feed(sphere, n, ISAM2(params(skip=2)), "barfoot", prior_native=True)
    assert max_diff(est, ref, n) < 1e-8


@pytest.mark.parametrize("skip", [1, 10])
def test_bayes_tree_has_the_native_size(sphere, skip):
    """Refreshed factors do not pull their keys to the root: the tree is native iSAM2's."""
    n = 300
    ref = gtsam.ISAM2(params(skip=skip))
    feed(sphere, n, ref, None)
    ours = ISAM2(params(skip=skip))
    feed(sphere, n, ours, "barfoot")
    assert ours.isam2.treeNnz() == ref.treeNnz()


def test_liebridge_factors_join_after_native_relinearizations(sphere):
    """GTSAM's own factors first (θ relinearized meanwhile), liebridge's afterwards."""
    n = 300
    kw = {"threshold": 0.05, "skip": 2}
    ref = feed(sphere, n, gtsam.ISAM2(params(**kw)), None)
    est = feed(sphere, n, ISAM2(params(**kw)), "barfoot", native_below=150)
    assert max_diff(est, ref, n) < 1e-8


# ----------------------------------------------------------------------------- the invariant
def _augmented(f: Any) -> Any:
    return np.asarray(f.augmentedJacobian(), dtype=np.float64)


def test_every_container_is_the_factor_linearized_at_gtsams_theta(sphere):
    """After every update, GTSAM's linear system for liebridge's factors is the factor's own."""
    isam = ISAM2(params(threshold=0.05, skip=3))
    originals: dict[tuple[int, ...], list[Any]] = {}
    checked = {"containers": 0, "updates": 0}

    def after(graph: Any) -> None:
        for k in range(graph.size()):
            f = graph.at(k)
            originals.setdefault(tuple(f.keys()), []).append(f)
        theta = isam.isam2.getLinearizationPoint()
        factors = isam.isam2.getFactorsUnsafe()
        for s in range(factors.size()):
            c = factors.at(s)
            if c is None or not isinstance(c, gtsam.LinearContainerFactor):
                continue
            same = originals[tuple(c.keys())]
            if len(same) != 1:
                continue
            want = _augmented(same[0].linearize(theta))
            got = _augmented(c.linearize(theta))
            np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9 * np.abs(want).max())
            checked["containers"] += 1
        checked["updates"] += 1

    feed(sphere, 150, isam, "barfoot", after=after)
    assert checked["updates"] == 6 and checked["containers"] > 6 * 25


# ----------------------------------------------------------------------------- API and bad input
def test_facade_and_params_threshold_read():
    assert F.ISAM2 is ISAM2
    assert ISAM2().relinearize_threshold == 0.1
    assert ISAM2(params(threshold=0.05)).relinearize_threshold == 0.05
    assert isinstance(ISAM2().calculate_estimate(), gtsam.Values)


@pytest.mark.parametrize("threshold", [0.1, 0.05, 1e-3, 0.0123456789, 1 / 3, 2.5e-7, 7.0, 0.0])
def test_relinearize_threshold_is_read_exactly(threshold):
    """GTSAM prints 6 digits; the probe pins the double GTSAM compares against."""
    assert ISAM2(params(threshold=threshold)).relinearize_threshold == threshold


def test_many_digit_threshold_gives_native_decisions(sphere):
    """A threshold that printing would round: the same estimates as native iSAM2."""
    n = 200
    kw = {"threshold": 0.0123456789, "skip": 1}
    ref = feed(sphere, n, gtsam.ISAM2(params(**kw)), None)
    est = feed(sphere, n, ISAM2(params(**kw)), "barfoot")
    assert max_diff(est, ref, n) < 1e-8


def test_bad_params_are_refused():
    with pytest.raises(TypeError, match=r"params: expected gtsam\.ISAM2Params"):
        ISAM2(gtsam.LevenbergMarquardtParams())
    p = gtsam.ISAM2Params()
    p.enablePartialRelinearizationCheck = True
    with pytest.raises(ValueError, match="enablePartialRelinearizationCheck"):
        ISAM2(p)
    p = gtsam.ISAM2Params()
    p.setRelinearizeThreshold(gtsam.ISAM2ThresholdMap())
    with pytest.raises(ValueError, match="scalar relinearizeThreshold"):
        ISAM2(p)


def test_bad_updates_are_refused_without_corrupting_the_state():
    cov = np.eye(6) * 0.01
    isam = ISAM2()
    g = gtsam.NonlinearFactorGraph()
    g.add(F.prior(0, np.eye(4), cov, "barfoot", native=False))
    v = gtsam.Values()
    v.insert(0, gtsam.Pose3())
    isam.update(g, v)
    with pytest.raises(TypeError, match=r"graph: expected gtsam\.NonlinearFactorGraph"):
        isam.update([F.prior(0, np.eye(4), cov, native=False)], gtsam.Values())
    with pytest.raises(TypeError, match=r"values: expected gtsam\.Values"):
        isam.update(gtsam.NonlinearFactorGraph(), {1: np.eye(4)})
    bad = gtsam.NonlinearFactorGraph()
    bad.add(F.between(0, 7, np.eye(4), cov, "barfoot", native=False))
    with pytest.raises(ValueError, match=r"factor 0 uses key 7, which is neither"):
        isam.update(bad, gtsam.Values())
    again = gtsam.Values()
    again.insert(0, gtsam.Pose3())
    with pytest.raises(ValueError, match="values: key 0 is already in the system"):
        isam.update(gtsam.NonlinearFactorGraph(), again)
    # the refused calls changed nothing: a valid update still works and is exact
    Z = np.eye(4)
    Z[:3, 3] = [1.0, 0.0, 0.0]
    g = gtsam.NonlinearFactorGraph()
    g.add(F.between(0, 1, Z, cov, "barfoot", native=False))
    v = gtsam.Values()
    v.insert(1, gtsam.Pose3(gtsam.Rot3.Rz(0.2), [0.5, 0.3, 0.0]))
    isam.update(g, v)
    for _ in range(3):
        isam.update()
    est = isam.calculate_estimate()
    np.testing.assert_allclose(est.atPose3(1).matrix(), Z, atol=1e-6)


# ----------------------------------------------------------------------------- full run, bench
@pytest.mark.slow
def test_full_sphere2500_matches_native_isam2(sphere):
    n = 2500
    ref = feed(sphere, n, gtsam.ISAM2(), None)
    est = feed(sphere, n, ISAM2(), "barfoot")
    assert max_diff(est, ref, n) < 1e-3  # measured 8e-5: iSAM2's wildfire, see docs/isam2.md
    ref0 = feed(sphere, n, gtsam.ISAM2(params(wildfire=0.0)), None)
    est0 = feed(sphere, n, ISAM2(params(wildfire=0.0)), "barfoot")
    assert max_diff(est0, ref0, n) < 1e-5  # measured 6e-7


def test_bench_isam2_quick_writes_the_expected_json(tmp_path: Path) -> None:
    out = tmp_path / "isam2.json"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "bench_isam2.py"), "--quick", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads(out.read_text())
    assert {"machine", "config", "rows", "ratios", "wildfire", "met"} <= set(res)
    assert res["config"]["quick"] is True
    designs = {r["design"]: r for r in res["rows"]}
    assert set(designs) == {"a", "b", "c", "d", "e", "f", "g", "a'", "c'"}
    for d in ("c", "d", "b", "c'"):
        assert designs[d]["max_abs_diff_vs_a"] < 1e-8
    assert {"c_over_a", "b_over_a_prefix", "b_over_c_prefix"} <= set(res["ratios"])


def test_keys_at_or_above_2_63_work_like_the_optimizers() -> None:
    """Keys at or above 2**63 on the incremental path: GTSAM keys are uint64."""
    import gtsam
    import numpy as np

    from liebridge.gtsam import ISAM2, between, prior
    from liebridge.lie import se3

    T1 = se3.exp(np.array([0.1, -0.2, 0.3, 1.0, 2.0, 3.0]))

    def run(k0: int, k1: int) -> np.ndarray:
        g = gtsam.NonlinearFactorGraph()
        g.add(prior(k0, np.eye(4), np.eye(6) * 1e-4, "g2o", native=False))
        g.add(between(k0, k1, T1, np.eye(6) * 1e-2, "g2o", native=False))
        v = gtsam.Values()
        v.insert(k0, gtsam.Pose3())
        v.insert(k1, gtsam.Pose3(se3.exp(np.array([0.2, 0, 0, 1.5, 2, 3]))))
        isam = ISAM2()
        isam.update(g, v)
        for _ in range(3):
            isam.update(gtsam.NonlinearFactorGraph(), gtsam.Values())
        return np.asarray(isam.calculate_estimate().atPose3(k1).matrix())

    np.testing.assert_allclose(run(2**63 + 5, 2**64 - 2), run(0, 1), rtol=0, atol=1e-12)
