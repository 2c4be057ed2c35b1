"""Regression tests for the 13 classes of wrong outcome of issue 21, one or more per class.

Each test is named after its class (``test_classN_...``) and failed on the code before the fix:
a silent wrong answer, a traceback instead of one clear error, or a hang. What each class gets
now is tabulated in ``docs/bad-input.md``.
"""

from __future__ import annotations

import math
import signal
import sys
from collections.abc import Iterator
from contextlib import contextmanager

import gtsam
import numpy as np
import pytest

from liebridge.gtsam import between, optimize, prior

@contextmanager
def within(seconds: float) -> Iterator[None]:
    """Fail (instead of hanging the suite) if the block runs longer than ``seconds``."""
    if sys.platform == "win32":
        yield
        return

    def _timeout(signum: int, frame: object) -> None:
        raise TimeoutError(f"still running after {seconds} s")

    old = signal.signal(signal.SIGALRM, _timeout)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, old)


T1 = np.eye(4)
T1[0, 3] = 1.0


def _small_graph() -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values]:
    g = gtsam.NonlinearFactorGraph()
    g.add(prior(0, np.eye(4), np.eye(6), native=False))
    g.add(between(0, 1, T1, np.eye(6)))
    v = gtsam.Values()
    v.insert(0, gtsam.Pose3(gtsam.Rot3.Rx(0.2), [0.1, 0.0, 0.0]))
    v.insert(1, gtsam.Pose3())
    return g, v


# --------------------------------------------------------------------------- class 5
@pytest.mark.parametrize("batch", [True, False])
def test_class5_unused_key_is_optimized_like_gtsam(batch: bool) -> None:
    g, v = _small_graph()
    v.insert(7, gtsam.Pose3(gtsam.Rot3.Ry(0.3), [1.0, 2.0, 3.0]))  # no factor uses key 7
    res = optimize(g, v, batch=batch)
    ref = gtsam.LevenbergMarquardtOptimizer(g, v, gtsam.LevenbergMarquardtParams()).optimize()
    assert res.initial_error > 0.1
    assert res.final_error < 1e-12
    assert abs(res.final_error - g.error(ref)) < 1e-12
    assert res.values.atPose3(7).equals(v.atPose3(7), 0.0)  # unused key returned unchanged
    assert res.values.size() == 3


def test_class13_factor_key_missing_from_values_is_a_clear_error() -> None:
    g, v = _small_graph()
    g.add(gtsam.BetweenFactorPose3(1, 9, gtsam.Pose3(), gtsam.noiseModel.Unit.Create(6)))
    with pytest.raises(ValueError, match=r"values: no value for key 9 .*factor 2"):
        optimize(g, v)


# --------------------------------------------------------------------------- class 11
def _lm(**kw: float) -> gtsam.LevenbergMarquardtParams:
    p = gtsam.LevenbergMarquardtParams()
    for name, val in kw.items():
        getattr(p, "set" + name)(val)
    return p


@pytest.mark.parametrize(
    ("setting", "match"),
    [
        ({"lambdaInitial": math.nan}, r"params\.lambdaInitial: .*nan"),
        ({"lambdaInitial": -1.0}, r"params\.lambdaInitial: .*-1"),
        ({"lambdaInitial": 0.0}, r"params\.lambdaInitial"),
        ({"lambdaFactor": 1.0}, r"params\.lambdaFactor"),
        ({"lambdaFactor": math.inf}, r"params\.lambdaFactor"),
        ({"lambdaUpperBound": math.nan}, r"params\.lambdaUpperBound"),
        ({"lambdaLowerBound": -1.0}, r"params\.lambdaLowerBound"),
        ({"RelativeErrorTol": math.nan}, r"params\.relativeErrorTol"),
        ({"AbsoluteErrorTol": -1.0}, r"params\.absoluteErrorTol"),
        ({"ErrorTol": math.nan}, r"params\.errorTol"),
    ],
)
def test_class11_bad_lm_parameters_raise_before_work(setting: dict[str, float], match: str) -> None:
    g, v = _small_graph()
    with within(10.0), pytest.raises(ValueError, match=match):
        optimize(g, v, _lm(**setting))


def test_class11_lambda_bounds_that_cannot_hold_are_refused() -> None:
    g, v = _small_graph()
    with pytest.raises(ValueError, match=r"params\.lambdaLowerBound .* lambdaUpperBound"):
        optimize(g, v, _lm(lambdaLowerBound=10.0, lambdaUpperBound=1.0))


@pytest.mark.parametrize("params", ["fast", gtsam.GaussNewtonParams(), 3])
def test_class13_params_of_another_kind_are_refused(params: object) -> None:
    g, v = _small_graph()
    with pytest.raises(TypeError, match=r"params: expected gtsam\.LevenbergMarquardtParams"):
        optimize(g, v, params)
