"""What the doctor is handed: group elements (arrays or GTSAM objects), their kind, candidates.

A *kind* is what an input or output of a user's function is: the name of its group's record
(:mod:`liebridge.lie`) — ``"se3"`` (a ``(4, 4)`` pose), ``"so3"`` (a ``(3, 3)`` rotation),
``"se2"`` (a ``(3, 3)`` planar pose ``[R t; 0 1]``) — or ``"vector"`` (a ``(n,)`` array: a bias,
a residual). Everything the doctor needs about a kind (tangent length, rotation coordinates,
charts) is read from that record (:func:`record`). The candidate conventions of a kind are every
registered preset of its group plus every side × order × chart × rotation-coordinate combination
of the model (Euler angles excluded: they are absolute, not increments); a rotation is perturbed
through the SE(3) conventions, which act on rotations too.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions import GROUP_PRESETS, PRESETS, Convention, get, tangent_map
from ..conventions.convention import CHARTS, ORDERS, SIDES
from ..lie import GROUPS, Group, se2, se3, so3
from ..lie import group as group_record

__all__ = [
    "CANONICAL_NAME",
    "VECTOR",
    "ConventionClass",
    "Element",
    "as_element",
    "candidates",
    "conventions_classes",
    "kind_of_output",
    "label",
    "record",
    "rotation_index",
    "with_angle",
]

#: The kind of a plain vector (a bias, a residual): not a group element.
VECTOR = "vector"

#: The hub convention (GTSAM's) of each group record's tangent: finite differences are read
#: through it. A rotation is read through SE(3)'s, which acts on rotations too.
CANONICAL_NAME: dict[Group, str] = {
    se3.GROUP: "gtsam",
    so3.GROUP: "gtsam",
    se2.GROUP: "gtsam_pose2",
}


def record(kind: str) -> Group | None:
    """Return the group record of ``kind`` (``None`` for :data:`VECTOR`)."""
    return None if kind == VECTOR else group_record(kind)


def has_blocks(kind: str) -> bool:
    """Whether ``kind``'s tangent has translation blocks beside its rotation (an order, a chart)."""
    rec = record(kind)
    return rec is None or bool(rec.vecs)


#: Increment rotation coordinates (Euler angles are absolute, not candidates for a Jacobian).
_INC_ROTS = ("exp", "half_exp", "quat_vec", "cayley")

#: Generic unit axis used when a rotation is the identity (no axis of its own).
_AXIS = np.array([1.0, 2.0, 3.0]) / math.sqrt(14.0)


def _is_rotation(A: FloatArray, tol: float = 1e-6) -> bool:
    return bool(
        A.shape == (3, 3)
        and np.abs(A.T @ A - np.eye(3)).max() < tol
        and abs(np.linalg.det(A) - 1.0) < tol
    )


def _is_pose2(A: FloatArray, tol: float = 1e-6) -> bool:
    return bool(
        A.shape == (3, 3)
        and np.abs(A[2] - [0.0, 0.0, 1.0]).max() < tol
        and np.abs(A[:2, :2].T @ A[:2, :2] - np.eye(2)).max() < tol
        and np.linalg.det(A[:2, :2]) > 0
    )


@dataclass(frozen=True)
class Element:
    """One input of a user's function: its array, kind and how to hand it back to the user."""

    array: FloatArray
    kind: str
    rebuild: Callable[[FloatArray], Any]

    @property
    def record(self) -> Group | None:
        """The group record of the element (``None`` for a vector)."""
        return record(self.kind)

    @property
    def dim(self) -> int:
        """Tangent (or vector) length."""
        rec = self.record
        return int(self.array.shape[-1]) if rec is None else rec.dim


def _rebuilder(x: Any) -> Callable[[FloatArray], Any]:
    """Turn an array back into the type the user passed (a GTSAM ``Pose3``/``Rot3``/``Pose2``)."""
    if not hasattr(x, "matrix"):
        return lambda a: a
    cls = type(x)

    def rebuild(a: FloatArray) -> Any:
        try:
            return cls(a)
        except TypeError:  # gtsam.Pose2 is built from (θ, t)
            return cls(math.atan2(a[1, 0], a[0, 0]), a[:2, 2].copy())

    return rebuild


def as_element(x: Any, name: str, group: str | None = None) -> Element:
    """Read one input: a pose, rotation, planar pose (array or library object) or a vector.

    A ``(3, 3)`` array is a rotation when orthonormal, else an SE(2) pose; ``group`` decides
    when both readings hold (the identity).
    """
    arr = validate.as_float_array(x, name)
    validate.check_finite(arr, name)
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim == 1:
        return Element(arr.copy(), VECTOR, _rebuilder(x))
    if arr.shape == (4, 4):
        return Element(validate.pose(arr, name).copy(), se3.GROUP.name, _rebuilder(x))
    if arr.shape == (3, 3):
        want = GROUPS.get(group) if isinstance(group, str) else None
        if want is se2.GROUP or (
            want is not so3.GROUP and not _is_rotation(arr) and _is_pose2(arr)
        ):
            return Element(validate.pose2(arr, name).copy(), se2.GROUP.name, _rebuilder(x))
        return Element(validate.rotation(arr, name).copy(), so3.GROUP.name, _rebuilder(x))
    raise ValueError(
        f"{name}: expected a (4, 4) pose, a (3, 3) rotation or SE(2) pose, or a vector (n,); "
        f"got shape {arr.shape}"
    )


def kind_of_output(y: FloatArray, input_kinds: Sequence[str]) -> str:
    """Kind of a function's output (a ``(3, 3)`` one read as the inputs suggest)."""
    if y.ndim <= 1:
        return VECTOR
    if y.shape == (4, 4):
        return se3.GROUP.name
    if y.shape == (3, 3):
        planar_in = any(record(k) is se2.GROUP for k in input_kinds)
        if _is_rotation(y) and not (planar_in and _is_pose2(y)):
            return so3.GROUP.name
        if _is_pose2(y):
            return se2.GROUP.name
    raise ValueError(
        f"f: returned shape {y.shape}; expected a (4, 4) pose, a (3, 3) rotation or SE(2) pose, "
        "or a vector"
    )


def rotation_index(conv: Convention, kind: str) -> list[int]:
    """Tangent indices of the rotation coordinates of ``conv`` on an element of ``kind``.

    Read from the kind's record: where its rotation block lands in ``conv.order`` (a rotation
    has only rotation coordinates, whatever the order).
    """
    rec = record(kind)
    if conv.embed is not None or rec is None or rec.rot is None:
        return []
    rot = rec.rot
    return [i for i, c in enumerate(rec.perm(conv.order)) if rot.start <= c < rot.stop]


def with_angle(el: Element, theta: float) -> FloatArray:
    """``el``'s array with its rotation replaced by one of angle ``theta`` about its own axis."""
    A = el.array.copy()
    rot_dim = 0 if el.record is None else el.record.rot_dim
    if rot_dim == 1:
        c, s = math.cos(theta), math.sin(theta)
        A[:2, :2] = [[c, -s], [s, c]]
        return A
    if rot_dim != 3:
        return A
    R = A[:3, :3]
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    u = w / np.linalg.norm(w) if np.linalg.norm(w) > 1e-6 else _AXIS
    K = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    A[:3, :3] = np.eye(3) + math.sin(theta) * K + (1.0 - math.cos(theta)) * (K @ K)
    return A


def candidates(kind: str, extra: Sequence[Convention] = ()) -> list[Convention]:
    """Every convention the doctor tries on an element of ``kind``: ``extra``, presets, combos."""
    rec = record(kind)
    if rec is not None and rec is not se3.GROUP and rec is not so3.GROUP:
        presets = [p for p in GROUP_PRESETS if p.record is rec]
        combos = [
            Convention("/".join(c), c[0], c[1], c[2], "exp", "wxyz", group=rec.name)  # type: ignore[arg-type]
            for c in itertools.product(SIDES, ORDERS, rec.charts)
        ]
    else:
        # a stored inverse (dpvo) is not a side/order/chart the doctor's words describe
        presets = [p for p in PRESETS if not p.is_euler and p.stores == "pose"]
        if rec is so3.GROUP:
            combos = [
                Convention("/".join((s, r)), s, "rot_first", "so3xr3_body", r, "wxyz")  # type: ignore[arg-type]
                for s in SIDES
                for r in _INC_ROTS
            ]
        else:
            combos = [
                Convention("/".join(c), c[0], c[1], c[2], c[3], "wxyz")  # type: ignore[arg-type]
                for c in itertools.product(SIDES, ORDERS, CHARTS, _INC_ROTS)
                if c[2] != se3.GROUP.coupled_chart or c[3] == "exp"
            ]
    return [*extra, *presets, *combos]


def _words(conv: Convention, kind: str) -> str:
    side = (
        "right-perturbation (X·Exp(δ))" if conv.side == "right" else "left-perturbation (Exp(δ)·X)"
    )
    rot = {"exp": "", "cayley": "", "half_exp": ", half-angle rotation coordinates"}.get(
        conv.rotation, ", quaternion-vector (half-angle) rotation coordinates"
    )
    if not has_blocks(kind):
        return f"{side}{rot}"
    if conv.embed is not None:
        return f"{side}, embedded in {conv.embed.size} coordinates at {conv.embed.index}"
    if record(kind) is se2.GROUP:
        order = "(θ, x, y)" if conv.order == "rot_first" else "(x, y, θ)"
    else:
        order = "(ω, v)" if conv.order == "rot_first" else "(v, ω)"
    frame = conv.record.split_frame(conv.chart)
    chart = (
        ""
        if frame is None
        else f", rotation and translation perturbed separately ({frame}-frame translation)"
    )
    return f"{side} in {order} order{chart}{rot}"


def label(members: Sequence[Convention], kind: str) -> str:
    """``"right-perturbation … (gtsam, mr_body)"``: the words of a class and its preset names."""
    names = list(dict.fromkeys(m.name for m in members if "/" not in m.name and m.name))
    named = f" [{', '.join(names[:6])}{', …' if len(names) > 6 else ''}]" if names else ""
    return _words(members[0], kind) + named


@dataclass
class ConventionClass:
    """Conventions with the same first-order map at every probe point (same Jacobians there)."""

    members: list[Convention]
    kind: str
    maps: list[FloatArray]  # tangent_map(X_p, member, canonical) at each point p

    @property
    def rep(self) -> Convention:
        """The member finite differences are taken through (the first one)."""
        return self.members[0]

    @property
    def label(self) -> str:
        """Plain-words description with the preset names."""
        return label(self.members, self.kind)

    def presets(self) -> list[str]:
        """Return the registered preset names in the class."""
        return [m.name for m in self.members if "/" not in m.name]


def conventions_classes(
    kind: str, points: Sequence[FloatArray], extra: Sequence[Convention] = ()
) -> list[ConventionClass]:
    """Group the candidates of ``kind`` by their first-order maps at ``points``."""
    rec = record(kind)
    if rec is None or rec not in CANONICAL_NAME:
        raise ValueError(f"kind: expected one of {[g.name for g in CANONICAL_NAME]}, got {kind!r}")
    canon = get(CANONICAL_NAME[rec])
    classes: list[ConventionClass] = []
    for c in candidates(kind, extra):
        try:
            maps = [np.asarray(tangent_map(P, c, canon), dtype=np.float64) for P in points]
        except (ValueError, TypeError):
            continue
        for cl in classes:
            if all(
                a.shape == b.shape and np.abs(a - b).max() < 1e-9
                for a, b in zip(cl.maps, maps, strict=True)
            ):
                if c not in cl.members:
                    cl.members.append(c)
                break
        else:
            classes.append(ConventionClass([c], kind, maps))
    return classes
