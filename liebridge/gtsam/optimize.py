"""Levenberg–Marquardt driven from Python, so Python factors do not pay GTSAM's ``Values`` copy.

Inside GTSAM's own optimizers every ``CustomFactor`` callback receives a copy of the whole
``Values`` (measured: ≈16 µs at 200 poses, ≈4 ms at 20,000 — 94 s instead of 2.8 s on
sphere2500, ``docs/library-facts.md``). ``graph.linearize(values)`` and
``graph.error(values)`` called from Python pass the caller's ``Values`` without that copy. This
module runs GTSAM's Levenberg–Marquardt algorithm around those two calls:

* linearize, then damp with ``λ·I`` per variable (GTSAM's ``buildDampedSystem`` without diagonal
  damping) and solve with GTSAM's elimination under a COLAMD ordering computed once;
* accept a step when the model fidelity ``(f(x) − f(x⊕δ)) / (L(0) − L(δ))`` exceeds
  ``minModelFidelity`` (1e-3), then ``λ ← max(λ / factor, lower)``; else ``λ ← λ·factor`` and
  retry until ``lambdaUpperBound``; stop on ``gtsam.checkConvergence`` (relative, absolute and
  total error tolerances) or ``maxIterations`` — GTSAM's ``LevenbergMarquardtOptimizer::tryLambda``
  (``gtsam/nonlinear/LevenbergMarquardtOptimizer.cpp``) with the fixed lambda factor.

On top of that, liebridge's own between/prior factors are recognised (their callbacks answer an
identification query with a registry number: :func:`liebridge.gtsam.custom.identify`) and
evaluated **all at once**, one batched numpy pass per (kind, convention), then handed to GTSAM
as whitened ``JacobianFactor``s; per-factor Python callbacks are the slow part otherwise
(≈0.3 ms error, ≈1.5 ms with Jacobians, against ≈4 µs of GTSAM's own per-callback overhead).
Other factors — native GTSAM ones and foreign ``CustomFactor``s (called once during setup) —
are linearized by GTSAM. All parameters come from a ``gtsam.LevenbergMarquardtParams``.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import gtsam
import numpy as np

from .batch import PoseFactorGroup, PoseFactorSpec, group_specs, poses_of
from .custom import identify, query_values

__all__ = ["OptimizeResult", "optimize"]

_MIN_MODEL_FIDELITY = 1e-3
#: Progress lines are printed automatically once a run has taken this long (seconds).
AUTO_PROGRESS_AFTER = 2.0


@dataclass
class OptimizeResult:
    """Outcome of :func:`optimize`."""

    values: Any
    initial_error: float
    final_error: float
    iterations: int
    seconds: float
    converged: bool
    final_lambda: float

    def __repr__(self) -> str:
        """One line: the figures, and the size of ``values`` rather than every pose in it."""
        return (
            f"OptimizeResult(error {self.initial_error:.6g} -> {self.final_error:.6g}, "
            f"{self.iterations} iterations, converged={self.converged}, "
            f"{self.seconds:.3g} s, final_lambda={self.final_lambda:.3g}, "
            f"values=<gtsam.Values, {self.values.size()} variables>)"
        )


class _Damping:
    """``√λ·I`` prior factors on every variable (GTSAM's ``buildDampedSystem``), cached per λ."""

    def __init__(self, values: Any) -> None:
        zero = values.zeroVectors()
        self.dims = [(int(k), int(zero.at(k).shape[0])) for k in values.keys()]
        self.cache: dict[float, list[Any]] = {}

    def factors(self, lam: float) -> list[Any]:
        if lam not in self.cache:
            if len(self.cache) > 32:
                self.cache.clear()
            s = np.sqrt(lam)
            self.cache[lam] = [
                gtsam.JacobianFactor(k, s * np.eye(d), np.zeros(d), gtsam.noiseModel.Unit.Create(d))
                for k, d in self.dims
            ]
        return self.cache[lam]


class _SplitGraph:
    """A graph split into GTSAM-evaluated factors and batched liebridge groups."""

    def __init__(self, graph: Any, values: Any, batch: bool) -> None:
        self.rest = gtsam.NonlinearFactorGraph()
        specs: list[PoseFactorSpec] = []
        if not batch:
            self.rest = graph
            self.groups: list[PoseFactorGroup] = []
            return
        query = query_values()
        for k in range(graph.size()):
            f = graph.at(k)
            if f is None:
                continue
            spec = identify(f, query)
            if isinstance(spec, PoseFactorSpec):
                specs.append(spec)
                continue
            self.rest.add(f)
        self.groups = group_specs(specs)
        self.n_batched = len(specs)

    def error(self, values: Any) -> float:
        err = float(self.rest.error(values))
        if self.groups:
            keys, T = poses_of(values)
            err += sum(g.error(keys, T) for g in self.groups)
        return err

    def linearize(self, values: Any) -> Any:
        linear = self.rest.linearize(values)
        if self.groups:
            keys, T = poses_of(values)
            for g in self.groups:
                for jf in g.linearize(keys, T):
                    linear.push_back(jf)
        return linear


def optimize(
    graph: Any,
    values: Any,
    params: Any = None,
    *,
    progress: bool | Callable[[str], None] | None = None,
    batch: bool = True,
) -> OptimizeResult:
    """Optimize ``graph`` from ``values`` with Levenberg–Marquardt, without per-callback copies.

    Parameters
    ----------
    graph : gtsam.NonlinearFactorGraph
        Any mix of native GTSAM factors and Python ``CustomFactor``s (e.g. from
        :func:`liebridge.factors.between` with ``native=False``).
    values : gtsam.Values
        Initial estimate (not modified).
    params : gtsam.LevenbergMarquardtParams, optional
        ``lambdaInitial``, ``lambdaFactor``, ``lambdaUpperBound``, ``lambdaLowerBound``,
        ``maxIterations``, ``relativeErrorTol``, ``absoluteErrorTol``, ``errorTol`` are honoured.
    progress : bool or callable, optional
        ``True``: one line per iteration on stderr; a callable receives the lines; ``None``
        (default): lines start once the run has taken :data:`AUTO_PROGRESS_AFTER` seconds.
    batch : bool
        Evaluate liebridge's pose factors in one numpy pass (default). ``False`` linearizes
        every factor through its GTSAM callback (still without GTSAM's ``Values`` copies).

    Returns
    -------
    OptimizeResult
    """
    p = params if params is not None else gtsam.LevenbergMarquardtParams()
    lam = float(p.getlambdaInitial())
    factor = float(p.getlambdaFactor())
    upper, lower = float(p.getlambdaUpperBound()), float(p.getlambdaLowerBound())
    max_it = int(p.getMaxIterations())
    rel, absol, errtol = (
        float(p.getRelativeErrorTol()),
        float(p.getAbsoluteErrorTol()),
        float(p.getErrorTol()),
    )
    t0 = time.perf_counter()

    def say(msg: str) -> None:
        if callable(progress):
            progress(msg)
        elif progress or (progress is None and time.perf_counter() - t0 > AUTO_PROGRESS_AFTER):
            print(msg, file=sys.stderr, flush=True)

    ordering = gtsam.Ordering.ColamdNonlinearFactorGraph(graph)
    current = gtsam.Values(values)
    split = _SplitGraph(graph, current, batch)
    damping = _Damping(current)
    err = split.error(current)
    initial = err
    if not np.isfinite(err):
        raise ValueError(f"values: the initial error is not finite ({err})")
    it = 0
    converged = err <= errtol
    while not converged and it < max_it:
        linear = split.linearize(current)
        new_err = err
        stop = False
        while True:
            damped = linear.clone()
            for f in damping.factors(lam):
                damped.push_back(f)
            try:
                delta = damped.optimize(ordering)
            except RuntimeError:  # indeterminant system: more damping
                delta = None
            success = False
            if delta is not None:
                lin_old = float(linear.error(gtsam.VectorValues.Zero(delta)))
                lin_new = float(linear.error(delta))
                lin_change = lin_old - lin_new
                if lin_change >= 0:
                    cand = current.retract(delta)
                    cand_err = split.error(cand)
                    if lin_change > np.finfo(float).eps * lin_old:
                        fidelity = (err - cand_err) / lin_change
                        success = fidelity > _MIN_MODEL_FIDELITY
                    else:
                        stop = True  # the linear model cannot decrease: converged
            if success:
                current, new_err = cand, cand_err
                lam = max(lower, lam / factor)
                break
            if stop:
                break
            lam *= factor
            if lam >= upper:
                stop = True
                break
        it += 1
        say(
            f"liebridge.optimize: iteration {it}: error {new_err:.10g} (from {err:.10g}), "
            f"lambda {lam:.3g}, {time.perf_counter() - t0:.1f} s"
        )
        converged = bool(gtsam.checkConvergence(rel, absol, errtol, err, new_err)) or stop
        err = new_err
        if not np.isfinite(err):
            break
    return OptimizeResult(
        values=current,
        initial_error=initial,
        final_error=err,
        iterations=it,
        seconds=time.perf_counter() - t0,
        converged=converged,
        final_lambda=lam,
    )
