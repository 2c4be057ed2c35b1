"""What the doctor is handed: group elements (arrays or GTSAM objects), their kind, candidates.

A *kind* is what an input or output of a user's function is: ``"se3"`` (a ``(4, 4)`` pose),
``"so3"`` (a ``(3, 3)`` rotation), ``"se2"`` (a ``(3, 3)`` planar pose ``[R t; 0 1]``) or
``"vector"`` (a ``(n,)`` array: a bias, a residual). The candidate conventions of a kind are
every registered preset of its group plus every side × order × chart × rotation-coordinate
combination of the model (Euler angles excluded: they are absolute, not increments).
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
from ..lie import se2 as _se2_module

__all__ = [
    "CANONICAL_NAME",
    "ConventionClass",
    "Element",
    "as_element",
    "candidates",
    "conventions_classes",
    "kind_of_output",
    "label",
    "rotation_index",
    "with_angle",
]

#: The hub convention of each kind's tangent (GTSAM's): finite differences are read through it.
CANONICAL_NAME = {"se3": "gtsam", "so3": "gtsam", "se2": "gtsam_pose2"}

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
    def dim(self) -> int:
        """Tangent (or vector) length."""
        if self.kind == "vector":
            return int(self.array.shape[-1])
        return {"se3": 6, "so3": 3, "se2": 3}[self.kind]


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
        return Element(arr.copy(), "vector", _rebuilder(x))
    if arr.shape == (4, 4):
        return Element(validate.pose(arr, name).copy(), "se3", _rebuilder(x))
    if arr.shape == (3, 3):
        if group == "se2" or (group != "so3" and not _is_rotation(arr) and _is_pose2(arr)):
            return Element(validate.pose2(arr, name).copy(), "se2", _rebuilder(x))
        return Element(validate.rotation(arr, name).copy(), "so3", _rebuilder(x))
    raise ValueError(
        f"{name}: expected a (4, 4) pose, a (3, 3) rotation or SE(2) pose, or a vector (n,); "
        f"got shape {arr.shape}"
    )


def kind_of_output(y: FloatArray, input_kinds: Sequence[str]) -> str:
    """Kind of a function's output (a ``(3, 3)`` one read as the inputs suggest)."""
    if y.ndim <= 1:
        return "vector"
    if y.shape == (4, 4):
        return "se3"
    if y.shape == (3, 3):
        if _is_rotation(y) and not ("se2" in input_kinds and _is_pose2(y)):
            return "so3"
        if _is_pose2(y):
            return "se2"
    raise ValueError(
        f"f: returned shape {y.shape}; expected a (4, 4) pose, a (3, 3) rotation or SE(2) pose, "
        "or a vector"
    )


def rotation_index(conv: Convention, kind: str) -> list[int]:
    """Tangent indices of the rotation coordinates of ``conv`` on an element of ``kind``."""
    if conv.embed is not None:
        return []
    if kind == "so3":
        return [0, 1, 2]
    if kind == "se3":
        return [0, 1, 2] if conv.order == "rot_first" else [3, 4, 5]
    if kind == "se2":
        return [0] if conv.order == "rot_first" else [2]
    return []


def with_angle(el: Element, theta: float) -> FloatArray:
    """``el``'s array with its rotation replaced by one of angle ``theta`` about its own axis."""
    A = el.array.copy()
    if el.kind == "se2":
        c, s = math.cos(theta), math.sin(theta)
        A[:2, :2] = [[c, -s], [s, c]]
        return A
    if el.kind not in ("se3", "so3"):
        return A
    R = A[:3, :3]
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    u = w / np.linalg.norm(w) if np.linalg.norm(w) > 1e-6 else _AXIS
    K = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    A[:3, :3] = np.eye(3) + math.sin(theta) * K + (1.0 - math.cos(theta)) * (K @ K)
    return A


def candidates(kind: str, extra: Sequence[Convention] = ()) -> list[Convention]:
    """Every convention the doctor tries on an element of ``kind``: ``extra``, presets, combos."""
    if kind == "se2":
        presets = [p for p in GROUP_PRESETS if p.group == "se2"]
        combos = [
            Convention("/".join(c), c[0], c[1], c[2], "exp", "wxyz", group="se2")  # type: ignore[arg-type]
            for c in itertools.product(SIDES, ORDERS, _se2_module.GROUP.charts)
        ]
    else:
        presets = [p for p in PRESETS if not p.is_euler]
        if kind == "so3":
            combos = [
                Convention("/".join((s, r)), s, "rot_first", "so3xr3_body", r, "wxyz")  # type: ignore[arg-type]
                for s in SIDES
                for r in _INC_ROTS
            ]
        else:
            combos = [
                Convention("/".join(c), c[0], c[1], c[2], c[3], "wxyz")  # type: ignore[arg-type]
                for c in itertools.product(SIDES, ORDERS, CHARTS, _INC_ROTS)
                if c[2] != "se3" or c[3] == "exp"
            ]
    return [*extra, *presets, *combos]


def _words(conv: Convention, kind: str) -> str:
    side = (
        "right-perturbation (X·Exp(δ))" if conv.side == "right" else "left-perturbation (Exp(δ)·X)"
    )
    rot = {"exp": "", "cayley": "", "half_exp": ", half-angle rotation coordinates"}.get(
        conv.rotation, ", quaternion-vector (half-angle) rotation coordinates"
    )
    if kind == "so3":
        return f"{side}{rot}"
    if conv.embed is not None:
        return f"{side}, embedded in {conv.embed.size} coordinates at {conv.embed.index}"
    if kind == "se2":
        order = "(θ, x, y)" if conv.order == "rot_first" else "(x, y, θ)"
    else:
        order = "(ω, v)" if conv.order == "rot_first" else "(v, ω)"
    chart = {
        "se3": "",
        "se2": "",
        "so3xr3_body": ", rotation and translation perturbed separately (body-frame translation)",
        "split_body": ", rotation and translation perturbed separately (body-frame translation)",
        "so3xr3_world": ", rotation and translation perturbed separately (world-frame translation)",
        "split_world": ", rotation and translation perturbed separately (world-frame translation)",
    }[conv.chart]
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
    canon = get(CANONICAL_NAME[kind])
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
