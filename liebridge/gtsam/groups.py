"""GTSAM's facts about each group, registered once: class, factors, hub convention, Values I/O.

A :class:`GtsamGroup` sits on top of a group record (:class:`liebridge.lie.Group`) and says how
the hub stores its elements: the GTSAM class (``Pose3``), how a liebridge matrix becomes an object
and back, the native between and prior factors, the convention GTSAM's ``retract`` implements for
that class (the hub preset its marginals are in), and an optional batched reader of a
``Values``. The glue, the factors, the marginals, the graph and the optimizer read this record;
a user registers one for their own group with :func:`register` (then ``between``/``prior`` with
``native=False`` work for it, and ``native=True`` where GTSAM has the factor classes).

Matrix conventions at the boundary: ``se3``: ``Pose3``; ``so3``: ``Rot3``; ``se2``: ``Pose2``
(``[R t; 0 0 1]``); ``so2``: ``Rot2`` (2×2); ``sim3``: ``Similarity3`` — liebridge's matrix is
``[sR t; 0 1]`` (``p ↦ sRp + t``) while GTSAM's ``Similarity3(R, t_g, s).matrix()`` is
``[R t_g; 0 1/s]`` (``p ↦ s(Rp + t_g)``), so ``t = s·t_g``: the glue converts, never copies
``t``; ``se23``: ``NavState`` with ``matrix() = [R p v; 0 1 0; 0 0 1]``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import gtsam
import numpy as np
import numpy.typing as npt

from .._validate import FloatArray
from ..conventions import GTSAM_NAVSTATE, GTSAM_POSE2, GTSAM_ROT2, GTSAM_SIMILARITY3, Convention
from ..lie import Group, se2, se3, se23, sim3, so2, so3
from ..lie import group as lie_group


@dataclass(frozen=True, eq=False)
class GtsamGroup:
    """How GTSAM holds the elements of one group (see the module docstring).

    Parameters
    ----------
    group : liebridge.lie.Group
        The group record.
    cls : str
        GTSAM class name (``"Pose3"``); ``Values.at<cls>`` reads it.
    to_object, from_object : callable
        liebridge matrix ``(n, n)`` → GTSAM object, and back.
    hub : Convention or callable
        The convention GTSAM's ``retract`` of ``cls`` implements (or a function measuring it).
    between, prior : GTSAM factor classes, optional
        ``BetweenFactor<cls>``, ``PriorFactor<cls>``: the native factors (None: custom only).
    native_warning : str
        Said once when a native factor is built (empty: nothing to say).
    prefer_custom : bool
        Whether a graph uses liebridge's factors even where the covariance conversion is exact
        (GTSAM's own factors have a known defect for this class).
    read_values : callable, optional
        ``(values, keys) -> (N, n, n)``: a batched reader (default: ``at<cls>`` per key).
    read_all : callable, optional
        ``(values, keys or None) -> (sorted keys, (N, n, n))``: every element of the class in
        one call; where set, the optimizer's batched pass evaluates this group's factors.
    """

    group: Group
    cls: str
    to_object: Callable[[FloatArray], Any]
    from_object: Callable[[Any], FloatArray]
    hub: Convention | Callable[[], Convention]
    between: Any = None
    prior: Any = None
    native_warning: str = ""
    prefer_custom: bool = False
    read_values: Callable[[Any, Any], FloatArray] | None = None
    read_all: Callable[[Any, KeyArray | None], tuple[KeyArray, FloatArray]] | None = None

    @property
    def batched(self) -> bool:
        """Whether the optimizer's batched pass evaluates factors of this group."""
        return self.read_all is not None

    @property
    def name(self) -> str:
        """The group's registry name."""
        return self.group.name

    def hub_convention(self) -> Convention:
        """GTSAM's tangent of this class: the preset its ``retract`` implements."""
        return self.hub if isinstance(self.hub, Convention) else self.hub()

    def element_at(self, values: Any, key: int) -> FloatArray:
        """Read the matrix stored under ``key`` (no validation of the key)."""
        return np.asarray(self.from_object(getattr(values, f"at{self.cls}")(key)), dtype=np.float64)


KeyArray = npt.NDArray[np.uint64]  # GTSAM keys are uint64 (≥ 2**63 included)

#: Every group GTSAM holds, by group name.
GTSAM_GROUPS: dict[str, GtsamGroup] = {}


def register(rec: GtsamGroup) -> GtsamGroup:
    """Register GTSAM's facts about ``rec.group`` (which must be a registered group record)."""
    if not isinstance(rec, GtsamGroup):
        raise TypeError(f"register: expected a GtsamGroup, got {type(rec).__name__}")
    lie_group(rec.group.name)  # a registered group only
    GTSAM_GROUPS[rec.name] = rec
    return rec


def gtsam_group(group: str | Group) -> GtsamGroup:
    """Return GTSAM's record of ``group``; ``ValueError`` naming the groups GTSAM holds."""
    name = group.name if isinstance(group, Group) else group
    rec = GTSAM_GROUPS.get(name) if isinstance(name, str) else None
    if rec is None:
        raise ValueError(
            f"group: expected one of {tuple(GTSAM_GROUPS)} (the groups GTSAM holds; register "
            f"another with liebridge.gtsam.register_group), got {group!r}"
        )
    return rec


# --------------------------------------------------------------------------- the shipped groups
def _matrix_of(obj: Any) -> FloatArray:
    return np.asarray(obj.matrix(), dtype=np.float64)


def _sim3_to(X: FloatArray) -> Any:
    s = float(np.cbrt(np.linalg.det(X[:3, :3])))
    # liebridge's [sR t; 0 1] maps p ↦ sRp + t; GTSAM's Similarity3(R, t_g, s) maps p ↦ s(Rp + t_g)
    return gtsam.Similarity3(gtsam.Rot3(X[:3, :3] / s), X[:3, 3] / s, s)


def _sim3_from(S: Any) -> FloatArray:
    s = float(S.scale())
    out = np.eye(4)
    out[:3, :3] = s * np.asarray(S.rotation().matrix())
    out[:3, 3] = s * np.asarray(S.translation())
    return out


def _read_pose3s(values: Any, keys: Any) -> FloatArray:
    from .glue import from_values_pose3  # one batched call (gtsam.utilities.extractPose3)

    return from_values_pose3(values, keys)


def _all_pose2s(values: Any, keys: KeyArray | None) -> tuple[KeyArray, FloatArray]:
    if keys is None:
        keys = np.asarray(list(gtsam.utilities.allPose2s(values).keys()), dtype=np.uint64)
    xyt = np.asarray(gtsam.utilities.extractPose2(values), dtype=np.float64).reshape(-1, 3)
    if xyt.shape[0] != len(keys):
        raise ValueError(f"values: {xyt.shape[0]} Pose2 entries, expected {len(keys)}")
    c, s = np.cos(xyt[:, 2]), np.sin(xyt[:, 2])
    T2 = np.zeros((len(keys), 3, 3))
    T2[:, 0, 0], T2[:, 0, 1], T2[:, 1, 0], T2[:, 1, 1] = c, -s, s, c
    T2[:, :2, 2] = xyt[:, :2]
    T2[:, 2, 2] = 1.0
    return keys, T2


def _all_pose3s(values: Any, keys: KeyArray | None) -> tuple[KeyArray, FloatArray]:
    if keys is None:
        keys = np.asarray(list(gtsam.utilities.allPose3s(values).keys()), dtype=np.uint64)
    m = np.asarray(gtsam.utilities.extractPose3(values), dtype=np.float64).reshape(-1, 12)
    if m.shape[0] != len(keys):
        raise ValueError(f"values: {m.shape[0]} Pose3 entries, expected {len(keys)}")
    T = np.zeros((len(keys), 4, 4))
    T[:, :3, :3] = m[:, :9].reshape(-1, 3, 3)
    T[:, :3, 3] = m[:, 9:]
    T[:, 3, 3] = 1.0
    return keys, T


def _pose3_hub() -> Convention:
    from .build import gtsam_convention  # measured on the installed build (cached)

    return gtsam_convention()


_SIM3_WARNING = (
    "liebridge: GTSAM's BetweenFactorSimilarity3/PriorFactorSimilarity3 linearize with the "
    "zero-residual Jacobians (−Ad(H⁻¹), I) (Similarity3::Logmap's derivative is not "
    "implemented in GTSAM 4.3), so an optimizer stops where those vanish, not at the "
    "minimum of the objective. Use native=False for exact Jacobians."
)

register(
    GtsamGroup(
        se3.GROUP, "Pose3", gtsam.Pose3, _matrix_of, _pose3_hub,
        gtsam.BetweenFactorPose3, gtsam.PriorFactorPose3,
        read_values=_read_pose3s, read_all=_all_pose3s,
    )
)  # fmt: skip
register(GtsamGroup(so3.GROUP, "Rot3", gtsam.Rot3, _matrix_of, _pose3_hub))
register(
    GtsamGroup(
        se2.GROUP, "Pose2",
        lambda X: gtsam.Pose2(gtsam.Rot2.atan2(X[1, 0], X[0, 0]), X[:2, 2]),
        _matrix_of, GTSAM_POSE2, gtsam.BetweenFactorPose2, gtsam.PriorFactorPose2,
        read_all=_all_pose2s,
    )
)  # fmt: skip
register(
    GtsamGroup(
        so2.GROUP, "Rot2", lambda X: gtsam.Rot2.atan2(X[1, 0], X[0, 0]), _matrix_of, GTSAM_ROT2
    )
)
register(
    GtsamGroup(
        sim3.GROUP, "Similarity3", _sim3_to, _sim3_from, GTSAM_SIMILARITY3,
        gtsam.BetweenFactorSimilarity3, gtsam.PriorFactorSimilarity3,
        native_warning=_SIM3_WARNING, prefer_custom=True,
    )
)  # fmt: skip
register(
    GtsamGroup(
        se23.GROUP, "NavState",
        lambda X: gtsam.NavState(gtsam.Rot3(X[:3, :3]), X[:3, 3], X[:3, 4]),
        _matrix_of, GTSAM_NAVSTATE, gtsam.BetweenFactorNavState, gtsam.PriorFactorNavState,
    )
)  # fmt: skip
