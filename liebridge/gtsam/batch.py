"""Batched evaluation of liebridge's pose factors: one numpy pass for all factors of a kind.

A spec holds what a factor needs (keys, measurement, convention, square-root information);
:func:`linearize_batch` evaluates every spec of a group with the same batched formulas as the
single-factor callbacks in :mod:`liebridge.gtsam.pose_factors` (both call
:mod:`liebridge.gtsam.factor_math`), whitens them with ``R`` (``RᵀR = Σ⁻¹``) and returns GTSAM
``JacobianFactor``s with unit noise — the same linear system GTSAM's ``linearize`` would build.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import gtsam
import numpy as np
import numpy.typing as npt

from .._validate import FloatArray
from ..conventions import Convention
from . import factor_math
from .groups import KeyArray, gtsam_group

# Groups whose liebridge factors carry a batch spec are those whose GTSAM record has
# ``read_all`` (``Pose3``, ``Pose2``: GTSAM extracts all of them in one call). Factors of the
# other groups (Similarity3, NavState) are evaluated by GTSAM through their single-factor
# callbacks, which call the same :mod:`~liebridge.gtsam.factor_math`.
# :class:`~liebridge.gtsam.ISAM2` batches ``Pose3`` only.


@dataclass(frozen=True)
class PoseFactorSpec:
    """One between (``j`` set) or prior (``j`` None) factor on keys of ``conv.group``."""

    conv: Convention
    i: int
    j: int | None
    Z: FloatArray
    sqrt_info: FloatArray  # upper-triangular R with RᵀR = Σ⁻¹ (GTSAM's noiseModel.R())


IntArray = npt.NDArray[np.int64]


def poses_of(
    values: Any, group: str = "se3", keys: KeyArray | None = None
) -> tuple[KeyArray, FloatArray]:
    """All entries of ``group``'s GTSAM class in ``values``: sorted keys, matrices.

    Matrices are ``(N, n, n)`` (``(N, 4, 4)`` for ``Pose3``, ``(N, 3, 3)`` for ``Pose2``), in the
    order of the keys. ``keys``: the keys read from the same ``Values`` before (a retract keeps
    them), which skips the copy ``allPose3s`` makes to list them; a count that differs raises
    ``ValueError``. The group's GTSAM record says how (``read_all``).
    """
    rec = gtsam_group(group)
    if rec.read_all is None:
        raise ValueError(f"group: the optimizer's batched pass does not read {rec.cls} values")
    return rec.read_all(values, keys)


def _rows(keys: KeyArray, wanted: KeyArray) -> IntArray:
    idx = np.searchsorted(keys, wanted)
    idx = np.clip(idx, 0, len(keys) - 1)
    missing = keys[idx] != wanted
    if missing.any():
        raise ValueError(f"values: no pose of the factor's group for key {int(wanted[missing][0])}")
    return np.asarray(idx, dtype=np.int64)


class PoseFactorGroup:
    """Factors of one kind (between or prior) and one convention, stacked for numpy."""

    def __init__(self, specs: list[PoseFactorSpec]) -> None:
        self.specs = specs
        self.conv = specs[0].conv
        self.group = self.conv.group
        self.between = specs[0].j is not None
        self.i = np.array([s.i for s in specs], dtype=np.uint64)
        self.j = np.array([s.j if s.j is not None else 0 for s in specs], dtype=np.uint64)
        self.Z = np.stack([s.Z for s in specs])
        self.R = np.stack([s.sqrt_info for s in specs])
        # coupled charts: residual ξ in the canonical order, R·e = R_xi·ξ (factor_math, fused path)
        self.fused = factor_math.is_coupled_chart(self.conv)
        if self.fused:
            self.Z_inv = self.conv.record.kernels.inverse(self.Z)
            self.R_xi = np.empty_like(self.R)
            self.R_xi[..., factor_math.order_permutation(self.conv)] = self.R

    def _residuals(self, keys: KeyArray, T: FloatArray) -> tuple[FloatArray, FloatArray]:
        Tj = T[_rows(keys, self.j)] if self.between else None
        H = factor_math.relative(T[_rows(keys, self.i)], Tj, self.conv.group)
        return H, factor_math.residual(self.conv, self.Z, H)

    def error(self, keys: KeyArray, T: FloatArray) -> float:
        """``½ Σ ‖R e‖²`` over the group."""
        _, e = self._residuals(keys, T)
        w = np.einsum("kij,kj->ki", self.R, e)
        return 0.5 * float(np.sum(w * w))

    def linearize(self, keys: KeyArray, T: FloatArray) -> list[Any]:
        """Whitened ``JacobianFactor``s (unit noise), one per factor, in GTSAM's tangents."""
        H, e = self._residuals(keys, T)
        J_e_i, J_e_j = factor_math.jacobians(self.conv, self.Z, H, self.between)
        b = -np.einsum("kij,kj->ki", self.R, e)
        Ai = self.R @ J_e_i
        unit = gtsam.noiseModel.Unit.Create(self.R.shape[-1])
        if J_e_j is None:
            return [
                gtsam.JacobianFactor(int(k), A, bb, unit)
                for k, A, bb in zip(self.i, Ai, b, strict=True)
            ]
        Aj = self.R @ J_e_j
        return [
            gtsam.JacobianFactor(int(ki), A1, int(kj), A2, bb, unit)
            for ki, kj, A1, A2, bb in zip(self.i, self.j, Ai, Aj, b, strict=True)
        ]


def group_specs(specs: list[PoseFactorSpec]) -> list[PoseFactorGroup]:
    """Group specs by (kind, convention) so each group is one batched evaluation."""
    groups: dict[tuple[bool, Convention], list[PoseFactorSpec]] = {}
    for s in specs:
        groups.setdefault((s.j is not None, s.conv), []).append(s)
    return [PoseFactorGroup(g) for g in groups.values()]


@dataclass(frozen=True)
class BatchEvaluation:
    """Residuals of every batched factor at one ``Values``, kept for linearizing there.

    ``parts[n] = (H, e, R·e)`` for group ``n`` (``H = T_i⁻¹T_j`` or ``T_i``, ``e`` the residual in
    the group's convention, or ξ in (ω, v) for a fused SE(3)-chart group, whitened by ``R_xi``);
    ``error = ½ Σ ‖R e‖²`` over all groups.
    """

    error: float
    parts: tuple[tuple[FloatArray, FloatArray, FloatArray], ...]  # (H, e, R·e); e = ξ if fused


@dataclass(frozen=True)
class _Plan:
    """Factors of one pose group, stacked, and how they are handed to GTSAM.

    ``pairs`` holds two between factors with the same key ``v`` eliminated first in the
    ordering and different other keys: they go to GTSAM as one three-key ``JacobianFactor``
    (``[A_pv A_po 0; A_qv 0 A_qo]``), which changes neither the symbolic elimination (``v``'s
    clique holds all three keys either way) nor the Hessian ``Σ AᵀA`` — only half the Python
    calls. ``singles`` are the other between factors, ``priors`` the one-key factors.
    """

    index: IntArray  # stacked position -> (group number, row in that group)
    pairs: IntArray  # (P, 2) stacked positions
    gather: IntArray  # (4, P) rows of concatenate([A_i, A_j]): v's two blocks, the others'
    pair_keys: list[tuple[int, int, int]]  # (v, other of the first, other of the second)
    singles: IntArray
    single_keys: list[tuple[int, int]]
    priors: IntArray
    prior_keys: list[int]


@dataclass(frozen=True)
class _Calls:
    """Buffers the whitened blocks of one pose group are written into, and the ``add`` calls."""

    pair_blocks: FloatArray  # (3, P, 2m, d): v's, the first factor's other, the second's other
    pair_b: FloatArray  # (P, 2m)
    single_blocks: FloatArray  # (2, S, m, d)
    single_b: FloatArray  # (S, m)
    prior_blocks: FloatArray  # (Q, m, d)
    prior_b: FloatArray  # (Q, m)
    args: list[tuple[Any, ...]]  # one tuple of GaussianFactorGraph.add arguments per factor


class PoseFactorBatch:
    """Every batched factor of a graph, bound once to the graph's pose keys and ordering.

    The pose keys of ``values`` and each factor's rows into them are fixed for a run (a retract
    keeps the keys), so :meth:`evaluate` reads the poses with one ``extractPose3``
    (``extractPose2``) call per group and no key lookup. :meth:`evaluate` returns the residuals
    it computed; :meth:`linearize` starts from them (an accepted candidate is not evaluated
    twice).
    """

    def __init__(
        self,
        groups: list[PoseFactorGroup],
        values: Any,
        position: dict[int, int],
        offset: dict[int, int],
    ) -> None:
        """Bind ``groups`` to ``values``' pose keys.

        ``position[k]``: the place of key ``k`` in the elimination ordering; ``offset[k]``: where
        ``k``'s block starts in a solution's ``VectorValues.vector(sorted keys)``.
        """
        self.groups = groups
        self.keys = {pg: poses_of(values, pg)[0] for pg in {g.group for g in groups}}
        self.rows = []
        for g in groups:
            keys = self.keys[g.group]
            self.rows.append((_rows(keys, g.i), _rows(keys, g.j) if g.between else None))
        self.between_groups = {g.group for g in groups if g.between}
        # per pose group: where each factor's key-i and key-j blocks sit in a solution vector
        self.offsets: dict[str, tuple[IntArray, IntArray]] = {}
        self.plans = {pg: self._plan(pg, position, offset) for pg in self.keys}
        self.units: dict[int, Any] = {}
        self.calls: dict[str, _Calls] = {}

    def _unit(self, m: int) -> Any:
        if m not in self.units:
            self.units[m] = gtsam.noiseModel.Unit.Create(m)
        return self.units[m]

    def _plan(self, pg: str, position: dict[int, int], offset: dict[int, int]) -> _Plan:
        members = [n for n, g in enumerate(self.groups) if g.group == pg]
        index = np.array(
            [(n, r) for n in members for r in range(len(self.groups[n].specs))], dtype=np.int64
        ).reshape(-1, 2)
        ki = np.concatenate([self.groups[n].i for n in members])
        kj = np.concatenate([self.groups[n].j for n in members])
        between = np.concatenate(
            [np.full(len(self.groups[n].specs), self.groups[n].between) for n in members]
        )
        priors = np.flatnonzero(~between)
        d = np.arange(self.groups[members[0]].R.shape[-1])  # each key's block: d entries
        self.offsets[pg] = (
            np.array([offset[int(k)] for k in ki], dtype=np.int64)[:, None] + d,
            np.array([offset[int(k)] for k in np.where(between, kj, ki)], dtype=np.int64)[:, None]
            + d,
        )
        by_v: dict[int, list[tuple[int, int, int]]] = {}
        for s in np.flatnonzero(between).tolist():
            i, j = int(ki[s]), int(kj[s])
            side = 0 if position[i] <= position[j] else 1
            v, other = (i, j) if side == 0 else (j, i)
            by_v.setdefault(v, []).append((s, side, other))
        pairs, v_side, pair_keys, singles, single_keys = [], [], [], [], []
        for v, fs in by_v.items():
            fs.sort(key=lambda f: f[2])
            n = 0
            while n < len(fs):
                if n + 1 < len(fs) and fs[n][2] != fs[n + 1][2]:
                    (p, sp, op), (q, sq, oq) = fs[n], fs[n + 1]
                    pairs.append((p, q))
                    v_side.append((sp, sq))
                    pair_keys.append((v, op, oq))
                    n += 2
                else:
                    s = fs[n][0]
                    singles.append(s)
                    single_keys.append((int(ki[s]), int(kj[s])))
                    n += 1
        pq = np.array(pairs, dtype=np.int64).reshape(-1, 2)
        sides = np.array(v_side, dtype=np.int64).reshape(-1, 2)
        K = len(ki)
        gather = np.stack(
            [
                pq[:, 0] + K * sides[:, 0],
                pq[:, 1] + K * sides[:, 1],
                pq[:, 0] + K * (1 - sides[:, 0]),
                pq[:, 1] + K * (1 - sides[:, 1]),
            ]
        )
        return _Plan(
            index=index,
            pairs=pq,
            gather=gather,
            pair_keys=pair_keys,
            singles=np.array(singles, dtype=np.int64),
            single_keys=single_keys,
            priors=priors,
            prior_keys=[int(k) for k in ki[priors]],
        )

    def damping_groups(self) -> list[tuple[int, ...]]:
        """Key triples of the factor pairs, then key pairs of the single between factors.

        Each tuple's first-eliminated key has the others in its clique (they share a factor
        with it), so one damping factor on the tuple leaves the elimination's structure as is.
        """
        out: list[tuple[int, ...]] = []
        for plan in self.plans.values():
            out += plan.pair_keys
            out += plan.single_keys
        return out

    def poses(self, values: Any) -> dict[str, FloatArray]:
        """Pose matrices of every group, rows in the order of the keys bound at construction."""
        out = {}
        for pg, keys in self.keys.items():
            _, T = poses_of(values, pg, keys)
            out[pg] = T
        return out

    def evaluate(self, values: Any) -> BatchEvaluation:
        """Residuals and ``½ Σ ‖R e‖²`` of every batched factor at ``values``."""
        T = self.poses(values)
        # each pose inverted once (not once per factor): H = (T⁻¹)[i]·T[j]
        T_inv = {pg: gtsam_group(pg).group.kernels.inverse(T[pg]) for pg in self.between_groups}
        parts = []
        err = 0.0
        for g, (ri, rj) in zip(self.groups, self.rows, strict=True):
            Tp = T[g.group]
            if rj is None:
                H = np.take(Tp, ri, axis=0)  # a prior: H = T_i
            else:
                H = np.take(T_inv[g.group], ri, axis=0) @ np.take(Tp, rj, axis=0)
            if g.fused:  # e = ξ[perm]: kept as ξ, whitened by R_xi
                e = factor_math.coupled_chart_log(g.conv, g.Z_inv, H)
                w = np.einsum("kij,kj->ki", g.R_xi, e)
            else:
                e = factor_math.residual(g.conv, g.Z, H)
                w = np.einsum("kij,kj->ki", g.R, e)
            err += 0.5 * float(np.einsum("ki,ki->", w, w))
            parts.append((H, e, w))
        return BatchEvaluation(err, tuple(parts))

    def whitened(self, ev: BatchEvaluation) -> dict[str, tuple[FloatArray, FloatArray, FloatArray]]:
        """``(A_i, A_j, b)`` stacked per pose group (whitened; ``A_j = 0`` for a prior)."""
        out = {}
        for pg, plan in self.plans.items():
            K = len(plan.index)
            members = np.unique(plan.index[:, 0]).tolist()
            m, d = ev.parts[members[0]][2].shape[-1], self.groups[members[0]].R.shape[-1]
            # one array: factor f's block of key i at f, of key j at K + f (pairs gather from it)
            A = np.empty((2 * K, m, d))
            b = np.empty((K, m))
            start = 0
            for n in members:
                g = self.groups[n]
                H, e, w = ev.parts[n]
                if g.fused:
                    Ai, Aj = factor_math.coupled_chart_jacobians(g.conv, e, H, g.between, g.R_xi)
                else:
                    J_e_i, J_e_j = factor_math.jacobians(g.conv, g.Z, H, g.between)
                    Ai, Aj = g.R @ J_e_i, None if J_e_j is None else g.R @ J_e_j
                stop = start + len(g.specs)
                A[start:stop] = Ai
                A[K + start : K + stop] = 0.0 if Aj is None else Aj
                np.negative(w, out=b[start:stop])
                start = stop
            out[pg] = (A[:K], A[K:], b)
        return out

    def linearize(self, ev: BatchEvaluation, linear: Any) -> dict[str, Any]:
        """Append the whitened factors at ``ev`` to the ``GaussianFactorGraph`` ``linear``.

        Returns the stacked ``(A_i, A_j, b)`` per pose group (for :meth:`linear_error`).
        """
        system = self.whitened(ev)
        add = linear.add
        for pg, plan in self.plans.items():
            A_i, A_j, b = system[pg]
            calls = self._calls(pg, b.shape[-1], A_i.shape[-1])
            if len(plan.pairs):
                A = A_i.base  # (2K, m, d): A_i and A_j are its halves (see whitened)
                if A is None or A_j.base is not A or A.shape[0] != 2 * len(A_i):
                    A = np.concatenate([A_i, A_j])
                m = b.shape[-1]
                blocks, bb = calls.pair_blocks, calls.pair_b  # zero halves written once
                np.take(A, plan.gather[0], axis=0, out=blocks[0, :, :m])  # v: first factor's,
                np.take(A, plan.gather[1], axis=0, out=blocks[0, :, m:])  # then the second's
                np.take(A, plan.gather[2], axis=0, out=blocks[1, :, :m])  # first factor's other
                np.take(A, plan.gather[3], axis=0, out=blocks[2, :, m:])  # second's other
                np.take(b, plan.pairs[:, 0], axis=0, out=bb[:, :m])
                np.take(b, plan.pairs[:, 1], axis=0, out=bb[:, m:])
            np.take(A_i, plan.singles, axis=0, out=calls.single_blocks[0])
            np.take(A_j, plan.singles, axis=0, out=calls.single_blocks[1])
            np.take(b, plan.singles, axis=0, out=calls.single_b)
            np.take(A_i, plan.priors, axis=0, out=calls.prior_blocks)
            np.take(b, plan.priors, axis=0, out=calls.prior_b)
            for args in calls.args:
                add(*args)
        return system

    def _calls(self, pg: str, m: int, d: int) -> _Calls:
        """Return the persistent buffers and ready-made ``add`` arguments of pose group ``pg``.

        Each linearization writes its numbers into the same buffers, and the argument tuples
        hold views of them: no array view and no tuple is made per call (GTSAM copies the
        blocks into its own factor).
        """
        if pg not in self.calls:
            plan = self.plans[pg]
            P, S, Q = len(plan.pairs), len(plan.singles), len(plan.priors)
            c = _Calls(
                pair_blocks=np.zeros((3, P, 2 * m, d)),
                pair_b=np.zeros((P, 2 * m)),
                single_blocks=np.zeros((2, S, m, d)),
                single_b=np.zeros((S, m)),
                prior_blocks=np.zeros((Q, m, d)),
                prior_b=np.zeros((Q, m)),
                args=[],
            )
            unit, unit2 = self._unit(m), self._unit(2 * m)
            for n, (v, o1, o2) in enumerate(plan.pair_keys):
                blk = c.pair_blocks
                c.args.append((v, blk[0, n], o1, blk[1, n], o2, blk[2, n], c.pair_b[n], unit2))
            for n, (i, j) in enumerate(plan.single_keys):
                blk = c.single_blocks
                c.args.append((i, blk[0, n], j, blk[1, n], c.single_b[n], unit))
            for n, i in enumerate(plan.prior_keys):
                c.args.append((i, c.prior_blocks[n], c.prior_b[n], unit))
            self.calls[pg] = c
        return self.calls[pg]

    def linear_error(self, system: dict[str, Any], delta: FloatArray) -> float:
        """``½ Σ ‖A_i δ_i + A_j δ_j − b‖²`` of :meth:`linearize`'s factors at ``delta``.

        ``delta``: ``VectorValues.vector(sorted keys)`` of a solution (blocks at the offsets bound
        at construction). The same number as GTSAM's ``GaussianFactorGraph.error`` of them.
        """
        err = 0.0
        for pg, (A_i, A_j, b) in system.items():
            at_i, at_j = self.offsets[pg]
            res = (
                np.einsum("kij,kj->ki", A_i, np.take(delta, at_i))
                + np.einsum("kij,kj->ki", A_j, np.take(delta, at_j))
                - b
            )
            err += 0.5 * float(np.einsum("ki,ki->", res, res))
        return err
