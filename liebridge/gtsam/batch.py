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

#: Groups whose liebridge factors carry a batch spec (``Pose3``, ``Pose2``: GTSAM extracts all
#: of them in one call). Factors of the other groups (Similarity3, NavState) are evaluated by
#: GTSAM through their single-factor callbacks, which call the same
#: :mod:`~liebridge.gtsam.factor_math`. :class:`~liebridge.gtsam.ISAM2` batches ``Pose3`` only.
BATCHED_GROUPS = frozenset({"se3", "se2"})


@dataclass(frozen=True)
class PoseFactorSpec:
    """One between (``j`` set) or prior (``j`` None) factor on keys of ``conv.group``."""

    conv: Convention
    i: int
    j: int | None
    Z: FloatArray
    sqrt_info: FloatArray  # upper-triangular R with RᵀR = Σ⁻¹ (GTSAM's noiseModel.R())


KeyArray = npt.NDArray[np.uint64]  # GTSAM keys are uint64 (≥ 2**63 included)
IntArray = npt.NDArray[np.int64]


def poses_of(values: Any, group: str = "se3") -> tuple[KeyArray, FloatArray]:
    """All ``Pose3`` (``group="se2"``: ``Pose2``) entries of ``values``: sorted keys, matrices.

    Matrices are ``(N, 4, 4)`` (``(N, 3, 3)`` for Pose2), in the order of the keys.
    """
    if group == "se2":
        keys = np.asarray(list(gtsam.utilities.allPose2s(values).keys()), dtype=np.uint64)
        xyt = np.asarray(gtsam.utilities.extractPose2(values), dtype=np.float64).reshape(-1, 3)
        c, s = np.cos(xyt[:, 2]), np.sin(xyt[:, 2])
        T2 = np.zeros((len(keys), 3, 3))
        T2[:, 0, 0], T2[:, 0, 1], T2[:, 1, 0], T2[:, 1, 1] = c, -s, s, c
        T2[:, :2, 2] = xyt[:, :2]
        T2[:, 2, 2] = 1.0
        return keys, T2
    keys = np.asarray(list(gtsam.utilities.allPose3s(values).keys()), dtype=np.uint64)
    m = np.asarray(gtsam.utilities.extractPose3(values), dtype=np.float64)
    T = np.zeros((len(keys), 4, 4))
    T[:, :3, :3] = m[:, :9].reshape(-1, 3, 3)
    T[:, :3, 3] = m[:, 9:]
    T[:, 3, 3] = 1.0
    return keys, T


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
