"""iSAM2 with liebridge's factors: batched numpy linearization, GTSAM's Bayes tree.

GTSAM's ``ISAM2`` linearizes every nonlinear factor from C++; a Python ``CustomFactor`` then
costs one callback **and one copy of the whole ``Values``** per linearization (the copy grows with
the map: ≈0.5 ms at 2,500 poses). :class:`ISAM2` keeps GTSAM's incremental solver and takes the
linearization of liebridge's between/prior factors out of it:

* every liebridge factor (``between``/``prior`` with ``native=False``, recognised by
  :func:`liebridge.gtsam.custom.identify`) is linearized in one batched numpy pass per
  (kind, convention) — :mod:`liebridge.gtsam.factor_math`, the same formulas as its callback — and
  handed to GTSAM's ``ISAM2`` as a whitened ``gtsam.LinearContainerFactor`` carrying its
  linearization point; other factors (GTSAM's own, foreign ``CustomFactor``s) go to ``ISAM2``
  unchanged;
* before each update that GTSAM will relinearize (update number ``n`` with
  ``n % relinearizeSkip == 0``), the variables GTSAM is about to relinearize are computed exactly
  as GTSAM does (``ISAM2::update`` → ``UpdateImpl::gatherRelinearizeKeys`` →
  ``CheckRelinearizationFull``: ``‖Δ_k‖_∞ ≥ relinearizeThreshold``, on the same ``Δ`` that
  ``ISAM2::getDelta`` returns; GTSAM 4.2/4.3 ``gtsam/nonlinear/ISAM2.cpp``,
  ``ISAM2-impl.h``); liebridge's factors touching them are removed (``removeFactorIndices``) and
  re-added, linearized at the new linearization point ``θ_k ⊕ Δ_k``, **in that same update**.

The keys of refreshed factors are not constrained to the end of the ordering (only those of new
factors, as natively: ``constrainedKeys``), so the Bayes tree is native iSAM2's.

So GTSAM eliminates, at every update, Jacobians of the convention's own residual at exactly the
linearization points its native iSAM2 would use. The estimates are native iSAM2's up to the
cliques iSAM2 re-eliminates (a removed factor also marks its other variable), which moves where
iSAM2's partial "wildfire" back-substitution stops: on sphere2500 the two differ by 8e-5, less
than GTSAM's own estimate moves between ``wildfireThreshold`` 0.001 and 0 (4.6e-4);
``docs/isam2.md`` has the measurements and the tested tolerances.

A ``LinearContainerFactor`` that GTSAM relinearizes at another point keeps its Jacobian and only
shifts its right-hand side (``b' = b − A·Local(x₀, x)``, ``LinearContainerFactor::linearize``):
a first-order model. With the same ``Δ`` and the exact threshold the prediction is GTSAM's own
decision, so this does not happen to liebridge's containers — unless the wrapped ``gtsam.ISAM2``
is updated directly.

GTSAM's Python API has no getter for ``relinearizeThreshold``: it is read from the printed
``ISAM2Params`` (6 significant digits), then pinned to the exact double by probing a one-variable
iSAM2 built with the same params. Limitations: per-type threshold maps and
``enablePartialRelinearizationCheck`` are refused; ``error``-style nonlinear quantities of
``ISAM2`` (``evaluateNonlinearError``) see liebridge's factors as their quadratic models.
"""

from __future__ import annotations

import re
from typing import Any

import gtsam
import numpy as np

from .._validate import FloatArray
from ..conventions import Convention, unchecked
from ..lie import se3
from .batch import IntArray, KeyArray, PoseFactorGroup, PoseFactorSpec, poses_of
from .build import gtsam_convention
from .custom import QUERY_KEY, identify, query_values

__all__ = ["ISAM2"]


def _printed_threshold(params: Any) -> float:
    """``relinearizeThreshold`` as ``ISAM2Params`` prints it (6 significant digits)."""
    m = re.search(r"relinearizeThreshold:\s*(\S+)", repr(params))
    if m is None or m.group(1) == "{mapped}":
        raise ValueError(
            "params: liebridge.gtsam.ISAM2 supports a scalar relinearizeThreshold only "
            f"(got {m.group(1) if m else 'none printed'}); per-type threshold maps are not "
            "readable from GTSAM's Python API"
        )
    return float(m.group(1))


def _check_params(p: Any) -> None:
    """Refuse iSAM2 parameters GTSAM would crash or misbehave on, before GTSAM sees them.

    ``relinearizeSkip < 1`` makes GTSAM's ``ISAM2::update`` divide by zero (``update % skip``:
    SIGFPE, the process dies); a NaN or negative ``relinearizeThreshold`` or
    ``wildfireThreshold`` makes every comparison false. ``gtsam.ISAM2`` itself does not check.
    """
    skip = int(p.relinearizeSkip)
    if skip < 1:
        raise ValueError(
            f"params.relinearizeSkip: expected an integer ≥ 1 (relinearize every n-th update), "
            f"got {skip}; GTSAM divides by it"
        )
    printed = repr(p)
    for name in ("relinearizeThreshold", "wildfireThreshold"):
        m = re.search(rf"{name}:\s*(\S+)", printed)
        if m is None or m.group(1) == "{mapped}":
            continue
        try:
            value = float(m.group(1))
        except ValueError:
            continue
        if not (np.isfinite(value) and value >= 0.0):
            raise ValueError(f"params.{name}: expected a finite number ≥ 0, got {m.group(1)}")


def _relinearizes(params: Any, delta: float) -> bool:
    """Return whether iSAM2 with ``params`` relinearizes a variable whose ``Δ`` is ``delta``.

    A one-variable problem (prior at ``delta``, start 0: the first update solves ``Δ = delta``
    exactly), then an update with ``force_relinearize``: the linearization point moves iff
    ``|Δ| ≥ relinearizeThreshold`` (``CheckRelinearizationFull``).
    """
    isam = gtsam.ISAM2(params)
    graph = gtsam.NonlinearFactorGraph()
    graph.add(gtsam.PriorFactorVector(0, np.array([delta]), gtsam.noiseModel.Unit.Create(1)))
    values = gtsam.Values()
    values.insert(0, np.zeros(1))
    isam.update(graph, values)
    force = gtsam.ISAM2UpdateParams()
    force.force_relinearize = True
    isam.update(gtsam.NonlinearFactorGraph(), gtsam.Values(), force)
    return bool(isam.getLinearizationPoint().atVector(0)[0] != 0.0)


def _relinearize_threshold(params: Any) -> float:
    """``relinearizeThreshold`` of ``params``, exactly (GTSAM's Python API has no getter).

    The printed value (6 significant digits) brackets it; bisection over the doubles of that
    bracket with :func:`_relinearizes` pins the exact value (≈40 probes, a few ms). If the
    probes disagree with the printed value (e.g. a Dogleg trust region clips the probe's step),
    the printed value is returned.
    """
    printed = _printed_threshold(params)
    if not np.isfinite(printed) or printed <= 0.0:
        return printed
    lo, hi = printed * (1.0 - 1e-5), printed * (1.0 + 1e-5)
    if _relinearizes(params, lo) or not _relinearizes(params, hi):
        return printed
    a = int(np.float64(lo).view(np.int64))  # positive doubles order like their bit patterns
    b = int(np.float64(hi).view(np.int64))
    while b - a > 1:
        mid = (a + b) // 2
        if _relinearizes(params, float(np.int64(mid).view(np.float64))):
            b = mid
        else:
            a = mid
    return float(np.int64(b).view(np.float64))


class ISAM2:
    """GTSAM's iSAM2 taking liebridge's factors, linearized batched in numpy (see module doc).

    Mirrors ``gtsam.ISAM2``: ``update(graph, values)`` adds new factors (any mix of liebridge's
    ``between``/``prior`` factors and GTSAM's own) and the initial values of the new variables;
    :meth:`calculate_estimate` returns the current estimate as ``gtsam.Values``.

    Parameters
    ----------
    params : gtsam.ISAM2Params, optional
        Passed to ``gtsam.ISAM2`` unchanged (relinearization threshold and skip, wildfire,
        factorization, ...). Default: ``gtsam.ISAM2Params()`` (threshold 0.1, skip 10).

    Raises
    ------
    TypeError
        If ``params`` is not a ``gtsam.ISAM2Params``.
    ValueError
        If ``params`` uses a per-type threshold map or ``enablePartialRelinearizationCheck``
        (the variables GTSAM relinearizes could then not be predicted from Python).

    Notes
    -----
    Poses are GTSAM's ``Pose3`` (right perturbation ``T·Exp(ξ)``, ξ = (ω, v)); each liebridge
    factor's residual is its convention's own (``conv.local(Z, T_i⁻¹T_j)``), whitened by its
    square-root information, with Jacobians in GTSAM's tangent columns
    (:mod:`liebridge.gtsam.factor_math`). Tempting and false: "a ``LinearContainerFactor`` is
    relinearized by iSAM2" — it only shifts its right-hand side; this class replaces it.
    """

    def __init__(self, params: Any = None) -> None:
        p = params if params is not None else gtsam.ISAM2Params()
        if not isinstance(p, gtsam.ISAM2Params):
            raise TypeError(f"params: expected gtsam.ISAM2Params, got {type(p).__name__}")
        if bool(p.enablePartialRelinearizationCheck):
            raise ValueError(
                "params: enablePartialRelinearizationCheck=True is not supported (the variables "
                "GTSAM relinearizes could not be predicted); set it to False"
            )
        _check_params(p)
        self._params = p
        # every successful gtsam.ISAM2.update call, to rebuild GTSAM's object after a failure
        self._log: list[tuple[Any, Any, list[int], Any]] = []
        self._threshold = _relinearize_threshold(p)
        self._relinearize = bool(p.enableRelinearization)
        self._skip = max(int(p.relinearizeSkip), 1)
        self._isam = gtsam.ISAM2(p)
        self._count = 0
        self._query = query_values()
        self._hub: Convention = gtsam_convention()
        # every variable in the system, sorted, with its tangent dimension (slices getDelta())
        self._var_keys: KeyArray = np.zeros(0, dtype=np.uint64)
        self._var_dims: IntArray = np.zeros(0, dtype=np.int64)
        # mirror of GTSAM's linearization point θ for the Pose3 variables (sorted keys)
        self._pose_keys: KeyArray = np.zeros(0, dtype=np.uint64)
        self._theta: FloatArray = np.zeros((0, 4, 4))
        # the same θ as gtsam.Values (retracted by GTSAM's own Pose3::retract): the containers'
        # linearization point, equal to GTSAM's θ bit for bit
        self._point = gtsam.Values()
        # liebridge factors: spec, keys (j = -1 for a prior), slot in GTSAM's factor graph
        self._specs: list[PoseFactorSpec] = []
        self._fi: KeyArray = np.zeros(0, dtype=np.uint64)
        self._fj: KeyArray = np.zeros(0, dtype=np.uint64)  # QUERY_KEY for a prior
        self._slot: IntArray = np.zeros(0, dtype=np.int64)

    # ------------------------------------------------------------------ public
    @property
    def isam2(self) -> Any:
        """The wrapped ``gtsam.ISAM2``, to read from (its own ``update`` would bypass liebridge)."""
        return self._isam

    @property
    def relinearize_threshold(self) -> float:
        """The ``relinearizeThreshold`` this object predicts GTSAM's relinearization with."""
        return self._threshold

    def calculate_estimate(self) -> Any:
        """Return the current estimate ``θ ⊕ Δ`` of every variable, as ``gtsam.Values``."""
        return self._isam.calculateEstimate()

    def update(self, graph: Any = None, values: Any = None) -> Any:
        """Add new factors and the initial values of new variables; one iSAM2 step.

        Parameters
        ----------
        graph : gtsam.NonlinearFactorGraph, optional
            New factors: liebridge's ``between``/``prior`` (``native=False``) are linearized
            batched; any other factor goes to GTSAM's iSAM2 as is.
        values : gtsam.Values, optional
            Initial estimates of the variables new in ``graph`` (as for ``gtsam.ISAM2``).

        Returns
        -------
        gtsam.ISAM2Result
            GTSAM's result of the one ``ISAM2.update`` call this makes.

        Notes
        -----
        An update that fails (GTSAM raises, e.g. an underdetermined system without a prior)
        changes nothing: the mirrored state is restored and the wrapped ``gtsam.ISAM2`` — which
        GTSAM leaves holding the failed update's variables and factors — is rebuilt by replaying
        the successful updates, whose inputs are kept for that (as many factor references as
        GTSAM's own graph holds, plus the refreshed containers). A retry then gives native
        iSAM2's result.
        """
        graph = gtsam.NonlinearFactorGraph() if graph is None else graph
        values = gtsam.Values() if values is None else values
        if not isinstance(graph, gtsam.NonlinearFactorGraph):
            raise TypeError(
                f"graph: expected gtsam.NonlinearFactorGraph, got {type(graph).__name__}"
            )
        if not isinstance(values, gtsam.Values):
            raise TypeError(f"values: expected gtsam.Values, got {type(values).__name__}")

        rest = gtsam.NonlinearFactorGraph()
        new_specs: list[PoseFactorSpec] = []
        for k in range(graph.size()):
            f = graph.at(k)
            if f is None:
                continue
            spec = identify(f, self._query)
            if isinstance(spec, PoseFactorSpec) and spec.conv.record is se3.GROUP:  # Pose3 mirror
                new_specs.append(spec)
            else:
                rest.add(f)
        self._check_keys(values, new_specs)

        saved = self._save()
        try:
            return self._update(rest, values, new_specs)
        except BaseException:
            self._restore(saved, values)
            raise

    def _update(self, rest: Any, values: Any, new_specs: list[PoseFactorSpec]) -> Any:
        # What GTSAM's update is about to relinearize, and θ after it (ISAM2::update steps 4–6).
        self._count += 1
        stale = np.zeros(len(self._specs), dtype=bool)
        if self._relinearize and self._count % self._skip == 0 and self._var_keys.size:
            # also without liebridge factors yet: the θ mirror must follow GTSAM's θ
            relin = self._predict_relinearized()
            if relin.size:
                stale = np.isin(self._fi, relin) | np.isin(self._fj, relin)
        self._add_variables(values)  # after the prediction: GTSAM's Δ of new variables is 0
        stale_idx = np.flatnonzero(stale)
        todo = [self._specs[int(s)] for s in stale_idx] + new_specs
        constrained = self._observed_keys(rest, new_specs) if stale_idx.size else None
        n_native = rest.size()
        rest.push_back(self._linearize(todo))
        removed = [int(s) for s in self._slot[stale_idx]]
        result = self._isam.update(rest, values, removed, constrained)
        self._log.append((rest, gtsam.Values(values), removed, constrained))

        slots = np.asarray(list(result.getNewFactorsIndices()), dtype=np.int64)[n_native:]
        self._slot[stale_idx] = slots[: len(stale_idx)]
        if new_specs:
            self._specs.extend(new_specs)
            self._fi = np.concatenate(
                [self._fi, np.array([s.i for s in new_specs], dtype=np.uint64)]
            )
            j = [s.j if s.j is not None else QUERY_KEY for s in new_specs]  # never a real key
            self._fj = np.concatenate([self._fj, np.array(j, dtype=np.uint64)])
            self._slot = np.concatenate([self._slot, slots[len(stale_idx) :]])
        return result

    # ------------------------------------------------------------------ internals
    def _save(self) -> tuple[Any, ...]:
        """Return the mirror's state before an update (arrays reassigned, not mutated, but θ)."""
        return (
            self._count,
            self._var_keys,
            self._var_dims,
            self._pose_keys,
            self._theta.copy(),
            self._point,
            len(self._specs),
            self._fi,
            self._fj,
            self._slot.copy(),
        )

    def _restore(self, saved: tuple[Any, ...], values: Any) -> None:
        """Undo a failed update: the mirror as before, and GTSAM's ISAM2 rebuilt.

        GTSAM's ``ISAM2::update`` adds the new variables and factors before it eliminates, so an
        update that fails (an underdetermined system: no prior) leaves GTSAM's object holding
        them, and later estimates wrong. It is rebuilt from the parameters by replaying every
        successful update (the same inputs, so the same state).
        """
        (
            self._count,
            self._var_keys,
            self._var_dims,
            self._pose_keys,
            self._theta,
            self._point,
            n_specs,
            self._fi,
            self._fj,
            self._slot,
        ) = saved
        del self._specs[n_specs:]
        for k in values.keys():  # _add_variables inserts into the saved Values in place
            if self._point.exists(k):
                self._point.erase(k)
        isam = gtsam.ISAM2(self._params)
        for graph, vals, removed, constrained in self._log:
            isam.update(graph, vals, removed, constrained)
        self._isam = isam

    def _check_keys(self, values: Any, new_specs: list[PoseFactorSpec]) -> None:
        """Refuse, before any state changes, what would corrupt the mirror of GTSAM's state."""
        keys = np.asarray(list(values.keys()), dtype=np.uint64)
        old = np.isin(keys, self._var_keys)
        if old.any():
            raise ValueError(
                f"values: key {int(keys[old][0])} is already in the system (values holds the "
                "initial estimates of new variables only, as for gtsam.ISAM2)"
            )
        if not new_specs:
            return
        pk, _ = poses_of(values)
        known = np.concatenate([self._pose_keys, pk])
        used = np.array([[s.i, s.i if s.j is None else s.j] for s in new_specs], dtype=np.uint64)
        missing = ~np.isin(used, known)
        if missing.any():
            n, c = np.argwhere(missing)[0]
            raise ValueError(
                f"graph: liebridge factor {n} uses key {int(used[n, c])}, which is neither in "
                "the system nor a Pose3 in values"
            )

    @staticmethod
    def _observed_keys(rest: Any, new_specs: list[PoseFactorSpec]) -> Any:
        """Return the ordering constraint native iSAM2 would use: keys of *new* factors last.

        GTSAM constrains the keys of new factors and of removed factors to the end of the
        ordering (``ISAM2::recalculate``, ``result.observedKeys``); a refreshed factor is neither
        new nor removed natively, so its keys must not be pulled to the root.
        """
        keys = {int(k) for k in rest.keys()}
        for s in new_specs:
            keys.add(s.i)
            if s.j is not None:
                keys.add(s.j)
        groups = gtsam.KeyGroupMap()
        for k in keys:
            groups.insert2(k, 1)
        return groups

    def _add_variables(self, values: Any) -> None:
        keys = np.asarray(list(values.keys()), dtype=np.uint64)
        if keys.size == 0:
            return
        zero = values.zeroVectors()
        dims = np.asarray([zero.at(int(k)).shape[0] for k in keys], dtype=np.int64)
        all_keys = np.concatenate([self._var_keys, keys])
        order = np.argsort(all_keys, kind="stable")
        self._var_keys = all_keys[order]
        self._var_dims = np.concatenate([self._var_dims, dims])[order]
        self._point.insert(values)
        pk, T = poses_of(values)
        if pk.size:
            all_pk = np.concatenate([self._pose_keys, pk])
            order = np.argsort(all_pk, kind="stable")
            self._pose_keys = all_pk[order]
            self._theta = np.concatenate([self._theta, T])[order]

    def _predict_relinearized(self) -> KeyArray:
        """Keys with ``‖Δ_k‖_∞ ≥ threshold``; retracts the θ mirror of those that are poses."""
        vec = np.asarray(self._isam.getDelta().vector(), dtype=np.float64)
        if vec.size != int(self._var_dims.sum()):
            raise RuntimeError(
                "liebridge.gtsam.ISAM2: GTSAM's delta does not match the variables added through "
                "update() (was the wrapped gtsam.ISAM2 updated directly?)"
            )
        starts = np.concatenate([[0], np.cumsum(self._var_dims)[:-1]])
        norm = np.maximum.reduceat(np.abs(vec), starts) if vec.size else vec
        relin = self._var_keys[norm >= self._threshold]
        rows = np.searchsorted(self._pose_keys, relin)
        rows = np.clip(rows, 0, max(len(self._pose_keys) - 1, 0))
        if len(self._pose_keys) == 0:  # no Pose3 variable at all (e.g. a Pose2 graph)
            return relin
        is_pose = (rows < len(self._pose_keys)) & (self._pose_keys[rows] == relin)
        rows = rows[is_pose]
        if rows.size:
            at = starts[np.searchsorted(self._var_keys, self._pose_keys[rows])]
            delta = vec[at[:, None] + np.arange(6)]
            self._theta[rows] = unchecked.retract(self._hub, self._theta[rows], delta)
            moved = gtsam.VectorValues()
            for k, d in zip(self._pose_keys[rows], delta, strict=True):
                moved.insert(int(k), d)
            self._point = self._point.retract(moved)  # ISAM2::update step 6, for our poses
        return relin

    def _linearize(self, specs: list[PoseFactorSpec]) -> Any:
        """``LinearContainerFactor``s of ``specs`` at the mirrored θ, in the order of ``specs``."""
        if not specs:
            return gtsam.NonlinearFactorGraph()
        groups: dict[tuple[bool, Convention], list[int]] = {}
        for n, s in enumerate(specs):
            groups.setdefault((s.j is not None, s.conv), []).append(n)
        out: list[Any] = [None] * len(specs)
        for idx in groups.values():
            jfs = PoseFactorGroup([specs[n] for n in idx]).linearize(self._pose_keys, self._theta)
            for n, jf in zip(idx, jfs, strict=True):
                out[n] = jf
        linear = gtsam.GaussianFactorGraph()
        for jf in out:
            linear.push_back(jf)
        return gtsam.LinearContainerFactor.ConvertLinearGraph(linear, self._point)
