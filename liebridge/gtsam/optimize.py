"""Levenberg–Marquardt driven from Python, so Python factors do not pay GTSAM's ``Values`` copy.

Inside GTSAM's own optimizers every ``CustomFactor`` callback receives a copy of the whole
``Values`` (measured: ≈16 µs at 200 poses, ≈4 ms at 20,000 — 94 s instead of 2.8 s on
sphere2500, ``docs/library-facts.md``). ``graph.linearize(values)`` and
``graph.error(values)`` called from Python pass the caller's ``Values`` without that copy. This
module runs GTSAM's Levenberg–Marquardt algorithm around those two calls:

* linearize, then damp with ``λ·I`` per variable (GTSAM's ``buildDampedSystem`` without diagonal
  damping) and solve with GTSAM's elimination (``GaussianFactorGraph.optimize``, multifrontal,
  Cholesky) under one ordering of the nonlinear graph computed once, of ``params.orderingType``
  (COLAMD by default), as ``LevenbergMarquardtParams::EnsureHasOrdering`` does;
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
The residuals of the error evaluation that accepted a step are reused for the next
linearization; two factors whose first-eliminated key is the same go to GTSAM as one three-key
``JacobianFactor`` (the Hessian and the elimination's structure are unchanged, the pybind calls
halved), and their three keys share one damping factor; the linearized error ``L(δ)`` is
computed in numpy from the same stacked arrays.
Other factors — native GTSAM ones and foreign ``CustomFactor``s (called once during setup) —
are linearized by GTSAM. All parameters come from a ``gtsam.LevenbergMarquardtParams``.
"""

from __future__ import annotations

import math
import sys
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import gtsam
import numpy as np

from .autodiff import AutodiffBatch, AutodiffSpec
from .batch import BatchEvaluation, PoseFactorBatch, PoseFactorSpec, group_specs
from .custom import identify, query_values
from .marginals import indeterminate_message

__all__ = ["IndeterminateSystemWarning", "OptimizeResult", "optimize"]

_MIN_MODEL_FIDELITY = 1e-3
#: Most damped solves tried within one iteration (bounds the run time whatever λ's factor).
_MAX_TRIES = 1000
#: Progress lines are printed automatically once a run has taken this long (seconds).
AUTO_PROGRESS_AFTER = 2.0


class IndeterminateSystemWarning(UserWarning):
    """:func:`optimize` ran on a graph whose linear system is not fully determined.

    Levenberg–Marquardt's damping lets it run, and the error may well stop decreasing
    (``converged``), but the optimum is one of a family (a pose graph without a prior: any
    rigid motion of it), and GTSAM's marginals of it fail.
    """


@dataclass
class OptimizeResult:
    """Outcome of :func:`optimize`.

    ``converged`` says the error stopped decreasing; ``determined`` says whether the undamped
    linear system at the result has a unique solution (``False``: e.g. no prior fixes the gauge,
    the optimum is not unique and GTSAM's marginals fail; ``indeterminate`` holds GTSAM's word).
    """

    values: Any
    initial_error: float
    final_error: float
    iterations: int
    seconds: float
    converged: bool
    final_lambda: float
    determined: bool = True
    indeterminate: str = ""

    def __repr__(self) -> str:
        """One line: the figures, and the size of ``values`` rather than every pose in it."""
        conv = f"converged={self.converged}"
        if not self.determined:
            conv += " but NOT fully determined (no gauge prior?)"
        return (
            f"OptimizeResult(error {self.initial_error:.6g} -> {self.final_error:.6g}, "
            f"{self.iterations} iterations, {conv}, "
            f"{self.seconds:.3g} s, final_lambda={self.final_lambda:.3g}, "
            f"values=<gtsam.Values, {self.values.size()} variables>)"
        )


class _Damping:
    """``√λ·I`` prior factors on every variable the graph uses (GTSAM's ``buildDampedSystem``).

    Only the graph's keys are damped: a key of ``values`` that no factor uses is not in the
    elimination ordering, and GTSAM's LM returns it unchanged (a damping prior on it made every
    solve fail, and the run "converge" at the initial values).
    Cached per λ as one ``GaussianFactorGraph``, appended to the linear system in one call (one
    ``push_back`` per factor and a deep ``clone`` per try cost ≈ 20 % of a sphere2500 run).
    """

    def __init__(
        self, values: Any, keys: list[int], together: list[tuple[int, ...]] | None = None
    ) -> None:
        """Damp ``keys``, sharing factors within the tuples of ``together``.

        ``together``: tuples of 2–3 keys of equal dimension whose damping may share one factor
        (``[√λI 0 0; 0 √λI 0; 0 0 √λI]``); taken in order, a tuple with a key already damped is
        skipped (every key is damped exactly once, its leftover keys on their own).

        A shared factor changes neither the Hessian nor the elimination's structure when its
        first-eliminated key's clique holds the others anyway (the keys of one batched factor
        pair, :class:`~liebridge.gtsam.batch.PoseFactorBatch`); it saves Python calls.
        """
        zero = values.zeroVectors()
        dim = {k: int(zero.at(k).shape[0]) for k in keys}
        used: set[int] = set()
        self.blocks: list[tuple[tuple[int, ...], int]] = []
        for group in together or []:
            if all(k in dim and k not in used for k in group) and (
                len({dim[k] for k in group}) == 1
            ):
                self.blocks.append((group, dim[group[0]]))
                used.update(group)
        self.blocks += [((k,), dim[k]) for k in keys if k not in used]
        self.cache: dict[float, Any] = {}

    def graph(self, lam: float) -> Any:
        if lam not in self.cache:
            if len(self.cache) > 32:
                self.cache.clear()
            s = float(np.sqrt(lam))
            out = gtsam.GaussianFactorGraph()
            add = out.add
            parts: dict[tuple[int, int], tuple[list[Any], Any, Any]] = {}
            for group, d in self.blocks:
                n = len(group)
                if (n, d) not in parts:
                    A = [np.zeros((n * d, d)) for _ in range(n)]
                    for m in range(n):
                        A[m][m * d : (m + 1) * d] = s * np.eye(d)
                    parts[n, d] = (A, np.zeros(n * d), gtsam.noiseModel.Unit.Create(n * d))
                A, b, unit = parts[n, d]
                if n == 1:
                    add(group[0], A[0], b, unit)
                elif n == 2:
                    add(group[0], A[0], group[1], A[1], b, unit)
                else:
                    add(group[0], A[0], group[1], A[1], group[2], A[2], b, unit)
            self.cache[lam] = out
        return self.cache[lam]

    def damped(self, linear: Any, lam: float) -> Any:
        """``linear`` plus the damping factors, sharing (not copying) ``linear``'s factors."""
        out = gtsam.GaussianFactorGraph()
        out.push_back(linear)
        out.push_back(self.graph(lam))
        return out


@dataclass(frozen=True)
class _State:
    """What :meth:`_SplitGraph.evaluate` computed at one ``Values``, kept for linearizing there."""

    poses: BatchEvaluation | None  # liebridge's between/prior factors
    autodiff: list[Any] | None  # the autodiff factors' stacked poses


class _LinearModel:
    """One linearization: the ``GaussianFactorGraph`` GTSAM eliminates and its error in numpy.

    ``error(delta)`` is GTSAM's ``GaussianFactorGraph.error`` of ``graph`` at ``delta``
    (``½ Σ ‖A δ − b‖²``): GTSAM's part through GTSAM, the batched part from the stacked numpy
    arrays (one pybind call instead of one per factor).
    """

    def __init__(
        self, split: _SplitGraph, graph: Any, rest: Any, system: Any, ad_system: Any = None
    ) -> None:
        self.split, self.graph, self.rest, self.system = split, graph, rest, system
        self.ad_system = ad_system  # the autodiff factors' stacked (A, b, at), or None

    def error(self, delta: Any) -> float:
        err = float(self.rest.error(delta))
        if self.system is None and self.ad_system is None:
            return err
        # blocks in the order of the graph's sorted keys, whatever the map's iteration order
        vec = np.asarray(delta.vector(self.split.keys), dtype=np.float64).reshape(-1)
        if self.system is not None:
            assert self.split.batch is not None
            err += self.split.batch.linear_error(self.system, vec)
        if self.ad_system is not None:
            err += AutodiffBatch.linear_error(self.ad_system, vec)
        return err

    def error_at_zero(self, delta: Any) -> float:
        """``L(0) = ½ Σ ‖b‖²``: the same for every λ of an iteration."""
        err = float(self.rest.error(gtsam.VectorValues.Zero(delta))) if self.rest.size() else 0.0
        if self.system is not None:
            err += sum(0.5 * float(np.einsum("ki,ki->", b, b)) for _, _, b in self.system.values())
        if self.ad_system is not None:
            err += AutodiffBatch.error_at_zero(self.ad_system)
        return err


class _SplitGraph:
    """A graph split into GTSAM-evaluated factors and batched liebridge factors.

    The batched factors are bound once to the graph's keys and elimination ordering
    (:class:`~liebridge.gtsam.batch.PoseFactorBatch`; autodiff factors:
    :class:`~liebridge.gtsam.autodiff.AutodiffBatch`, one vectorised call per residual
    function); ``evaluate`` returns the residuals it computed with the error, and
    ``linear_model`` linearizes from them.
    """

    def __init__(self, graph: Any, values: Any, batch: bool, ordering: Any = None) -> None:
        self.rest = gtsam.NonlinearFactorGraph()
        self.batch: PoseFactorBatch | None = None
        self.autodiff: AutodiffBatch | None = None
        self.n_batched = 0
        self.keys: list[int] = []  # the graph's keys, sorted: the layout of linear_error's delta
        if not batch:
            self.rest = graph
            return
        query = query_values()
        specs: list[PoseFactorSpec] = []
        ad_specs: list[AutodiffSpec] = []
        for k in range(graph.size()):
            f = graph.at(k)
            if f is None:
                continue
            spec = identify(f, query)
            if isinstance(spec, PoseFactorSpec):
                specs.append(spec)
                continue
            if isinstance(spec, AutodiffSpec):
                ad_specs.append(spec)
                continue
            self.rest.add(f)
        self.n_batched = len(specs) + len(ad_specs)
        if not specs and not ad_specs:
            return
        if ordering is None:
            ordering = gtsam.Ordering.ColamdNonlinearFactorGraph(graph)
        position = {int(ordering.at(n)): n for n in range(ordering.size())}
        key_set = graph.keys()  # held: iterating the temporary KeySet reads freed memory
        zero = values.zeroVectors()
        self.keys = sorted(int(k) for k in key_set)
        offset: dict[int, int] = {}
        total = 0
        for k in self.keys:
            offset[k] = total
            total += int(zero.at(k).shape[0])
        if specs:
            self.batch = PoseFactorBatch(group_specs(specs), values, position, offset)
        if ad_specs:
            self.autodiff = AutodiffBatch(ad_specs, values, offset)

    def damping_groups(self) -> list[tuple[int, ...]]:
        """Key tuples whose damping can share a factor (see :class:`_Damping`)."""
        return [] if self.batch is None else self.batch.damping_groups()

    def evaluate(self, values: Any) -> tuple[float, _State]:
        """Return the graph's error at ``values`` and the batched residuals computed for it."""
        err = float(self.rest.error(values))
        ev, ad = None, None
        if self.batch is not None:
            ev = self.batch.evaluate(values)
            err += ev.error
        if self.autodiff is not None:
            ad_err, ad = self.autodiff.evaluate(values)
            err += ad_err
        return err, _State(ev, ad)

    def error(self, values: Any) -> float:
        return self.evaluate(values)[0]

    def linear_model(self, values: Any, state: _State | None) -> _LinearModel:
        """Linearize at ``values``; ``state``: :meth:`evaluate`'s residuals there (or None)."""
        rest = self.rest.linearize(values)
        if self.batch is None and self.autodiff is None:
            return _LinearModel(self, rest, rest, None)
        if state is None:
            state = self.evaluate(values)[1]
        linear = gtsam.GaussianFactorGraph()
        linear.push_back(rest)
        system, ad_system = None, None
        if self.batch is not None:
            assert state.poses is not None
            system = self.batch.linearize(state.poses, linear)
        if self.autodiff is not None:
            assert state.autodiff is not None
            ad_system = self.autodiff.linearize(state.autodiff, linear)
        return _LinearModel(self, linear, rest, system, ad_system)

    def linearize(self, values: Any) -> Any:
        """Return the whole linear system at ``values`` as one ``GaussianFactorGraph``."""
        return self.linear_model(values, None).graph


def _positive(x: float, name: str, *, strict: bool = True, finite: bool = True) -> float:
    bad = math.isnan(x) or (x <= 0.0 if strict else x < 0.0) or (finite and math.isinf(x))
    if bad:
        what = "a finite number " if finite else "a number "
        raise ValueError(f"params.{name}: expected {what}{'>' if strict else '≥'} 0, got {x!r}")
    return x


@dataclass(frozen=True)
class _LMSettings:
    """The validated Levenberg–Marquardt parameters :func:`optimize` honours."""

    lam: float
    factor: float
    upper: float
    lower: float
    max_it: int
    rel: float
    absol: float
    errtol: float
    ordering_type: str


def _lm_settings(params: Any) -> _LMSettings:
    """Read and validate ``params`` before any work.

    Every value that could make the damping loop spin forever (λ NaN, ≤ 0 or infinite, a factor
    ≤ 1, bounds that cannot hold) or never stop (NaN tolerances) is a ``ValueError``; a parameter
    object of another kind is a ``TypeError``.
    """
    if params is None:
        params = gtsam.LevenbergMarquardtParams()
    if not isinstance(params, gtsam.LevenbergMarquardtParams):
        raise TypeError(
            "params: expected gtsam.LevenbergMarquardtParams (or None), got "
            f"{type(params).__name__}; liebridge.optimize runs Levenberg–Marquardt only "
            "(use gtsam.GaussNewtonOptimizer for Gauss–Newton)"
        )
    lam = _positive(float(params.getlambdaInitial()), "lambdaInitial")
    factor = float(params.getlambdaFactor())
    if not (math.isfinite(factor) and factor > 1.0):
        raise ValueError(f"params.lambdaFactor: expected a finite number > 1, got {factor!r}")
    upper = _positive(float(params.getlambdaUpperBound()), "lambdaUpperBound", finite=False)
    lower = _positive(float(params.getlambdaLowerBound()), "lambdaLowerBound", strict=False)
    if not lower < upper:
        raise ValueError(
            f"params.lambdaLowerBound ({lower!r}) must be below lambdaUpperBound ({upper!r})"
        )
    max_it = int(params.getMaxIterations())
    if max_it < 0:
        raise ValueError(f"params.maxIterations: expected ≥ 0, got {max_it}")
    tols = {
        "relativeErrorTol": float(params.getRelativeErrorTol()),
        "absoluteErrorTol": float(params.getAbsoluteErrorTol()),
        "errorTol": float(params.getErrorTol()),
    }
    for name, tol in tols.items():
        _positive(tol, name, strict=False, finite=False)
    ordering_type = str(params.getOrderingType())
    if ordering_type not in ("COLAMD", "METIS", "NATURAL"):
        raise ValueError(
            f"params.orderingType: {ordering_type} is not supported (a custom ordering set with "
            "setOrdering cannot be read back from Python); use COLAMD, METIS or NATURAL"
        )
    return _LMSettings(
        lam=lam,
        factor=factor,
        upper=upper,
        lower=lower,
        max_it=max_it,
        rel=tols["relativeErrorTol"],
        absol=tols["absoluteErrorTol"],
        errtol=tols["errorTol"],
        ordering_type=ordering_type,
    )


def _check_keys(graph: Any, values: Any) -> list[int]:
    """Return the graph's keys, sorted; raise ``ValueError`` if one is not in ``values``.

    ``TypeError`` (naming the argument) for a ``graph`` or ``values`` of the wrong type.
    """
    if not isinstance(graph, gtsam.NonlinearFactorGraph):
        raise TypeError(f"graph: expected gtsam.NonlinearFactorGraph, got {type(graph).__name__}")
    if not isinstance(values, gtsam.Values):
        raise TypeError(f"values: expected gtsam.Values, got {type(values).__name__}")
    key_set = graph.keys()  # held: iterating the temporary KeySet reads freed memory
    keys = sorted(int(k) for k in key_set)
    for k in keys:
        if not values.exists(k):
            for n in range(graph.size()):
                f = graph.at(n)
                f_keys = f.keys() if f is not None else []
                if k in [int(x) for x in f_keys]:
                    raise ValueError(
                        f"values: no value for key {k} ({gtsam.DefaultKeyFormatter(k)}), "
                        f"used by factor {n} of the graph"
                    )
    return keys


def _has_unary_factor(graph: Any) -> bool:
    n = graph.size()
    # priors are usually added first or last: look there before scanning the rest
    for k in (0, n - 1, *range(1, n - 1)) if n > 1 else range(n):
        f = graph.at(k)
        if f is not None and len(f.keys()) == 1:
            return True
    return False


def _indeterminate(linear_graph: Any, ordering: Any) -> str | None:
    """GTSAM's one-line reason if the undamped ``linear_graph`` has no unique solution."""
    try:
        linear_graph.optimize(ordering)
    except RuntimeError as exc:
        return indeterminate_message(exc)
    return None


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
        ``maxIterations``, ``relativeErrorTol``, ``absoluteErrorTol``, ``errorTol`` and
        ``orderingType`` (COLAMD, METIS, NATURAL) are honoured, and validated before any work
        (λ finite and > 0, factor finite and > 1, bounds ``0 ≤ lower < upper``, tolerances ≥ 0,
        not NaN; a CUSTOM ordering cannot be read back from Python and is refused). Keys of
        ``values`` that no factor uses are returned unchanged, as GTSAM's
        ``LevenbergMarquardtOptimizer`` does.
    progress : bool or callable, optional
        ``True``: one line per iteration on stderr; a callable receives the lines; ``None``
        (default): lines start once the run has taken :data:`AUTO_PROGRESS_AFTER` seconds.
    batch : bool
        Evaluate liebridge's pose factors in one numpy pass (default). ``False`` linearizes
        every factor through its GTSAM callback (still without GTSAM's ``Values`` copies).

    Returns
    -------
    OptimizeResult
        ``determined=False`` (and an :class:`IndeterminateSystemWarning`) when the graph has no
        single-key factor (no prior) and its undamped linear system at the result is
        indeterminate: a gauge-free pose graph. The check eliminates the last linear system once
        more without damping; graphs with a single-key factor skip it (their cost is unchanged).

    Raises
    ------
    TypeError
        ``params`` is not a ``gtsam.LevenbergMarquardtParams`` (e.g. ``GaussNewtonParams``).
    ValueError
        A parameter that would make the run spin or never stop (named, with its value); a factor
        key missing from ``values`` (naming the key and the factor); a non-finite initial error.
    """
    keys = _check_keys(graph, values)  # the arguments' types first, then the parameters
    P = _lm_settings(params)
    lam, factor, upper, lower, max_it = P.lam, P.factor, P.upper, P.lower, P.max_it
    rel, absol, errtol = P.rel, P.absol, P.errtol
    t0 = time.perf_counter()

    def say(msg: str) -> None:
        if callable(progress):
            progress(msg)
        elif progress or (progress is None and time.perf_counter() - t0 > AUTO_PROGRESS_AFTER):
            print(msg, file=sys.stderr, flush=True)

    # GTSAM's LM orders the nonlinear graph once, by params.orderingType (COLAMD by default)
    ordering = gtsam.Ordering.CreateNonlinearFactorGraph(
        gtsam.Ordering.OrderingType.__members__[P.ordering_type], graph
    )
    current = gtsam.Values(values)
    split = _SplitGraph(graph, current, batch, ordering)
    damping = _Damping(current, keys, split.damping_groups())
    err, state = split.evaluate(current)
    initial = err
    if not np.isfinite(err):
        raise ValueError(f"values: the initial error is not finite ({err})")
    it = 0
    converged = err <= errtol
    linear: _LinearModel | None = None
    while not converged and it < max_it:
        linear = split.linear_model(current, state)
        new_err = err
        stop = False
        lin_old: float | None = None
        for _try in range(_MAX_TRIES):
            damped = damping.damped(linear.graph, lam)
            try:
                delta = damped.optimize(ordering)
            except RuntimeError:  # indeterminant system: more damping
                delta = None
            success = False
            if delta is not None:
                if lin_old is None:  # L(0) = ½‖b‖²: the same for every λ of this iteration
                    lin_old = linear.error_at_zero(delta)
                lin_new = linear.error(delta)
                lin_change = lin_old - lin_new
                if lin_change >= 0:
                    cand = current.retract(delta)
                    cand_err, cand_state = split.evaluate(cand)
                    if lin_change > np.finfo(float).eps * lin_old:
                        fidelity = (err - cand_err) / lin_change
                        success = fidelity > _MIN_MODEL_FIDELITY
                    else:
                        stop = True  # the linear model cannot decrease: converged
            if success:
                current, new_err, state = cand, cand_err, cand_state
                lam = max(lower, lam / factor)
                break
            if stop:
                break
            lam *= factor
            if lam >= upper:
                stop = True
                break
        else:  # λ·factor^_MAX_TRIES still below the upper bound (a factor barely above 1)
            stop = True
        it += 1
        say(
            f"liebridge.optimize: iteration {it}: error {new_err:.10g} (from {err:.10g}), "
            f"lambda {lam:.3g}, {time.perf_counter() - t0:.1f} s"
        )
        converged = bool(gtsam.checkConvergence(rel, absol, errtol, err, new_err)) or stop
        err = new_err
        if not np.isfinite(err):
            break
    why = None
    if np.isfinite(err) and not _has_unary_factor(graph):
        # the rank is the same at every linearization point: reuse the last one if any
        system = linear.graph if linear is not None else split.linearize(current)
        why = _indeterminate(system, ordering)
        if why is not None:
            warnings.warn(
                f"liebridge.optimize: {why}; the result is one optimum of many "
                "(OptimizeResult.determined is False)",
                IndeterminateSystemWarning,
                stacklevel=2,
            )
    return OptimizeResult(
        values=current,
        initial_error=initial,
        final_error=err,
        iterations=it,
        seconds=time.perf_counter() - t0,
        converged=converged,
        final_lambda=lam,
        determined=why is None,
        indeterminate=why or "",
    )
