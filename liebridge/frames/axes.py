"""Axis conventions as named constant frames: ENU/NED, FLU/FRD, camera optical, OpenGL.

An :class:`Axes` names what its ``x``, ``y``, ``z`` axes point at, in words. Two kinds:

* world (geographic) axes, from ``east/west``, ``north/south``, ``up/down``:
  ``ENU`` (x east, y north, z up; ROS REP-103 ``map``/``odom``) and ``NED`` (x north, y east,
  z down; aerospace, PX4);
* body axes, from ``forward/backward``, ``left/right``, ``up/down``:
  ``FLU`` (x forward, y left, z up; ROS REP-103 ``base_link``), ``FRD`` (x forward, y right,
  z down; aerospace, PX4), ``RDF`` = camera **optical** (x right, y down, z forward: OpenCV, ROS
  ``*_optical_frame``), ``RUB`` = **OpenGL** camera (x right, y up, z backward: it looks along
  −z).

:func:`rotation` gives the constant ``R_a_b`` that maps coordinates in axes ``b`` to axes ``a``
of the same physical frame (``R_a_b[i, j]`` = cosine between axis ``i`` of ``a`` and axis ``j``
of ``b``), and :func:`axes_transform` wraps it as a :class:`~liebridge.frames.Transform` between
two frame names, so a change of axes is a composition:
``T_{world_ned}_{body_frd} = T_{ned}_{enu} ∘ T_{enu}_{flu} ∘ T_{flu}_{frd}``. A covariance in the
(right, body-frame) tangent follows through the composition: the body change rotates it
(``Ad`` of a pure rotation), the world change leaves it unchanged; a covariance in a world-frame
tangent (e.g. ROS ``PoseWithCovariance``) is rotated by the world change instead — convert with
:meth:`~liebridge.frames.Transform.with_convention` to see it. Tempting and false:
``R_ENU_NED`` as a change of *body* axes (``ENU`` is not a body convention: mixing a world
convention with a body one raises).
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass

import numpy as np

from .._validate import FloatArray
from .transform import Transform

__all__ = [
    "ENU",
    "FLU",
    "FRD",
    "NED",
    "OPENGL",
    "OPTICAL",
    "RDF",
    "RUB",
    "Axes",
    "axes_transform",
    "get",
    "names",
    "rotation",
]

#: unit vectors of the named directions, in a right-handed reference basis per kind
_WORLD = {
    "east": (1, 0, 0),
    "west": (-1, 0, 0),
    "north": (0, 1, 0),
    "south": (0, -1, 0),
    "up": (0, 0, 1),
    "down": (0, 0, -1),
}
_BODY = {
    "forward": (1, 0, 0),
    "backward": (-1, 0, 0),
    "left": (0, 1, 0),
    "right": (0, -1, 0),
    "up": (0, 0, 1),
    "down": (0, 0, -1),
}


@dataclass(frozen=True)
class Axes:
    """An axis convention: where ``x``, ``y``, ``z`` point, in words.

    Parameters
    ----------
    name : str
    kind : {"world", "body"}
        ``world`` directions: east/west/north/south/up/down; ``body``:
        forward/backward/left/right/up/down.
    x, y, z : str
        Direction of each axis; must form a right-handed frame.
    used_by : str
        Who uses it.
    """

    name: str
    kind: str
    x: str
    y: str
    z: str
    used_by: str = ""

    def __post_init__(self) -> None:
        for field_name in ("name", "kind", "x", "y", "z", "used_by"):
            value = getattr(self, field_name)
            if not isinstance(value, str):
                raise TypeError(
                    f"Axes.{field_name}: expected a str, got {type(value).__name__} ({value!r})"
                )
        table = _WORLD if self.kind == "world" else _BODY if self.kind == "body" else None
        if table is None:
            raise ValueError(f"Axes {self.name!r}: kind must be 'world' or 'body'")
        for ax in (self.x, self.y, self.z):
            if ax not in table:
                raise ValueError(
                    f"Axes {self.name!r}: {ax!r} is not a {self.kind} direction "
                    f"({', '.join(table)})"
                )
        if abs(np.linalg.det(self.matrix) - 1.0) > 1e-12:
            raise ValueError(
                f"Axes {self.name!r}: ({self.x}, {self.y}, {self.z}) is not right-handed"
            )

    @property
    def matrix(self) -> FloatArray:
        """Columns: the x, y, z axes in the reference basis of its kind (a rotation)."""
        table = _WORLD if self.kind == "world" else _BODY
        return np.array([table[self.x], table[self.y], table[self.z]], dtype=np.float64).T

    def describe(self) -> str:
        """E.g. ``NED: x north, y east, z down (world axes; aerospace, PX4)``."""
        tail = f"; {self.used_by}" if self.used_by else ""
        return f"{self.name}: x {self.x}, y {self.y}, z {self.z} ({self.kind} axes{tail})"


ENU = Axes("ENU", "world", "east", "north", "up", "ROS REP-103 map/odom")
NED = Axes("NED", "world", "north", "east", "down", "aerospace, PX4")
FLU = Axes("FLU", "body", "forward", "left", "up", "ROS REP-103 base_link")
FRD = Axes("FRD", "body", "forward", "right", "down", "aerospace, PX4")
RDF = Axes("RDF", "body", "right", "down", "forward", "camera optical: OpenCV, ROS *_optical_frame")
RUB = Axes("RUB", "body", "right", "up", "backward", "OpenGL camera (looks along -z)")
#: aliases
OPTICAL = RDF
OPENGL = RUB

_REGISTRY = {a.name: a for a in (ENU, NED, FLU, FRD, RDF, RUB)}
_ALIASES = {"OPTICAL": RDF, "OPENCV": RDF, "CAMERA": RDF, "OPENGL": RUB}


def names() -> tuple[str, ...]:
    """Return the axis conventions' names (aliases: optical/opencv/camera = RDF, opengl = RUB)."""
    return tuple(_REGISTRY)


def get(name: str | Axes) -> Axes:
    """Return the :class:`Axes` called ``name`` (case-insensitive; an ``Axes`` unchanged)."""
    if isinstance(name, Axes):
        return name
    if not isinstance(name, str):
        raise TypeError(f"axes: expected a name or Axes, got {type(name).__name__}")
    key = name.strip().upper()
    if key in _REGISTRY:
        return _REGISTRY[key]
    if key in _ALIASES:
        return _ALIASES[key]
    known = [*_REGISTRY, *(k.lower() for k in _ALIASES)]
    close = difflib.get_close_matches(key, [*_REGISTRY, *_ALIASES], n=2, cutoff=0.5)
    hint = f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
    raise ValueError(f"axes: unknown axis convention {name!r}{hint} (known: {', '.join(known)})")


def rotation(a: str | Axes, b: str | Axes) -> FloatArray:
    """``R_a_b``: maps coordinates in axes ``b`` to coordinates in axes ``a`` (same origin).

    ``rotation("ENU", "NED") = [[0, 1, 0], [1, 0, 0], [0, 0, −1]]``;
    ``rotation("FLU", "RDF") = [[0, 0, 1], [−1, 0, 0], [0, −1, 0]]`` (optical z forward is body
    x). Both must be of the same kind (world or body).
    """
    A, B = get(a), get(b)
    if A.kind != B.kind:
        raise ValueError(
            f"cannot relate {A.name} ({A.kind} axes) and {B.name} ({B.kind} axes) by a constant "
            f"rotation: a {A.kind} and a {B.kind} frame are related by a pose, not an axis "
            "convention"
        )
    return np.asarray(np.rint(A.matrix.T @ B.matrix), dtype=np.float64)


def axes_transform(a: str | Axes, b: str | Axes, target_frame: str, source_frame: str) -> Transform:
    """Return the constant ``T_target_source`` that only changes axes ``b`` → ``a``.

    ``target_frame`` and ``source_frame`` are the names of the same physical frame in the two
    axis conventions (e.g. ``"map"`` and ``"map_ned"``); the translation is zero, no covariance.
    """
    T = np.eye(4)
    T[:3, :3] = rotation(a, b)
    return Transform(T, target_frame, source_frame)
