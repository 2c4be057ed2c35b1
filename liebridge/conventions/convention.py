"""The convention descriptor: a frozen value object with its retraction and first-order maps.

A :class:`Convention` says how a library perturbs a pose ``X = (R, t)`` with a 6-vector ``d``
(or a rotation with a 3-vector):

``side``
    ``right``: the increment acts in the body frame, ``X·Exp(d)``; ``left``: in the world frame,
    ``Exp(d)·X``. For the decoupled charts the side applies to the rotation only.
``order``
    ``rot_first``: ``d = (r, u)`` (GTSAM, Modern Robotics, pytransform3d, symforce);
    ``trans_first``: ``d = (u, r)`` (Sophus, manif, Pinocchio, Barfoot, ROS, g2o).
``chart``
    ``se3``: the coupled SE(3) exponential (translation ``V(ω)·u``); ``so3xr3_body``: rotation and
    translation perturbed separately, translation increment in the body frame ``t + R·u``;
    ``so3xr3_world``: separately, translation increment in the world frame ``t + u``.
``rotation``
    how ``r`` becomes a rotation: see :mod:`liebridge.conventions.rotation_coords`. The Euler
    coordinates ``euler_zyx`` (yaw, pitch, roll) and ``euler_rpy`` (roll, pitch, yaw) are absolute
    (``R = E(e(R) + r)``, ``side`` ignored), for SO(3)/SE(3) split charts only.
``quat_order``
    how the library stores quaternions (``wxyz``, ``xyzw`` Hamilton, or ``jpl``: JPL ``(x, y, z,
    w)``, the transpose); it does not enter the retraction.

``group``
    which Lie group the elements belong to: the name of a registered group record
    (:func:`liebridge.lie.group`; shipped: ``so2``, ``se2``, ``so3``, ``se3``, ``sim3``, ``se23``)
    or the record itself (default ``se3``, which also accepts a ``(..., 3, 3)`` rotation as its
    SO(3) part, as before groups existed). Each group has its own canonical tangent (GTSAM's) and
    its charts, read from the record: the coupled one named after the group (``se2``, ``se3``,
    ``sim3``, ``se23``) and the split ones ``split_body``/``split_world`` (SE(3) spells them
    ``so3xr3_body``/``so3xr3_world``). See ``docs/design-groups.md``.
``embed``
    optional :class:`Embed`: the tangent is a longer vector holding the group's coordinates at
    fixed entries (``ros_pose2``: SE(2)'s ``(x, y, yaw)`` at entries 0, 1, 5 of ROS's 6-vector).
``stores``
    ``pose`` (default): the library holds liebridge's element ``X``; ``inverse``: it holds
    ``X⁻¹`` and applies the fields above to that (DPVO and DROID-SLAM keep world→camera poses in
    lietorch, liebridge's element is ``T_world_cam``), so ``retract(X, d) =
    inv(retract_Y(X⁻¹, d))`` and ``to_canonical(X) = −Ad_{X⁻¹}·M_Y(X⁻¹)``; coupled chart only
    (:mod:`liebridge.conventions.stored_inverse`).

Canonical (GTSAM) is ``right, rot_first, se3, exp``. ``local(X, retract(X, d)) == d`` within the
chart's domain (``‖ω‖ < π``; ``‖r‖ < 1`` for ``quat_vec``), and the first-order maps
:meth:`Convention.to_canonical` / :meth:`Convention.from_canonical` are closed form.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

from .. import arrays
from .._validate import FloatArray
from ..lie import GROUPS, Group
from . import se3_engine as _se3_engine  # noqa: F401  (registers SE(3)/SO(3)'s fast engine)
from .chart import Chart
from .engine import Engine, engine_for
from .rotation_coords import EULER_COORDS, FIRST_ORDER_SCALE, ROTATION_COORDS
from .se3_engine import group_input
from .stored_inverse import STORES, engine_storing

#: The groups liebridge ships (every registered one: ``liebridge.lie.GROUPS``).
GROUP_NAMES = ("so2", "se2", "so3", "se3", "sim3", "se23")
#: The group of a convention that names none.
DEFAULT_GROUP = "se3"


@dataclass(frozen=True)
class Embed:
    """A group tangent stored inside a longer vector.

    ``index[k]`` is where the convention's ``k``-th coordinate (in its ``order``) sits in a vector
    of length ``size``; the other entries are not coordinates of the group: ``retract`` ignores
    them and ``local`` returns 0 there (a planar pose cannot leave its plane).
    """

    index: tuple[int, ...]
    size: int

    def __post_init__(self) -> None:
        idx = self.index
        if len(set(idx)) != len(idx) or not all(0 <= i < self.size for i in idx):
            raise ValueError(f"Embed: index {idx} must be distinct entries of range({self.size})")


Side = Literal["right", "left"]
Stores = Literal["pose", "inverse"]
Order = Literal["rot_first", "trans_first"]
#: A chart's name (the shipped groups': their own, ``split_body``/``split_world``, SE(3)'s
#: ``se3``/``so3xr3_body``/``so3xr3_world``; a registered group may declare others).
ChartName = str
SIDES = ("right", "left")
ORDERS = ("rot_first", "trans_first")
CHARTS = ("se3", "so3xr3_body", "so3xr3_world")
QUAT_ORDERS = ("wxyz", "xyzw", "jpl")


def _check_field(name: str, value: str, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise ValueError(f"Convention.{name}: expected one of {allowed}, got {value!r}")


def _resolve_group(name: str, group: Any) -> Group:
    """Return the registered record of ``group`` (a name or a record)."""
    if isinstance(group, Group):
        if GROUPS.get(group.name) is not group:
            raise ValueError(
                f"Convention {name!r}: group {group.name!r} is not registered; call "
                f"liebridge.lie.register(group) first"
            )
        return group
    if not isinstance(group, str) or group not in GROUPS:
        raise ValueError(
            f"Convention.group: expected one of {tuple(GROUPS)} (or a registered "
            f"liebridge.lie.Group), got {group!r}"
        )
    return GROUPS[group]


@dataclass(frozen=True)
class Convention(Chart):
    """A Lie-group convention as data. See the module docstring for the fields' meaning.

    Parameters
    ----------
    name : str
        Registry name (presets) or a user's label.
    side, order, chart, rotation, quat_order : str
        See the module docstring.
    source : str
        Where the facts come from (library, version, file).
    notes : str
        Defining identity, and tempting identities that are false, in words.
    group : str or liebridge.lie.Group
        The group (its registered name or record; stored as the name).
    embed : Embed, optional
        A tangent stored inside a longer vector.
    stores : {"pose", "inverse"}
        What the library holds: liebridge's element, or its inverse (a world→camera pose).
    """

    name: str
    side: Side
    order: Order
    chart: ChartName
    rotation: str
    quat_order: str
    source: str = ""
    notes: str = field(default="", compare=False, repr=False)
    group: str = DEFAULT_GROUP  # a registered Group record is accepted and stored as its name
    embed: Embed | None = None
    stores: Stores = "pose"
    _key: tuple[str, str, str, str] = field(init=False, repr=False, compare=False)
    _eng: Engine = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        g = _resolve_group(self.name, self.group)
        object.__setattr__(self, "group", g.name)
        _check_field("side", self.side, SIDES)
        _check_field("order", self.order, ORDERS)
        object.__setattr__(self, "chart", g.chart(self.chart))
        _check_field("rotation", self.rotation, ROTATION_COORDS)
        _check_field("quat_order", self.quat_order, QUAT_ORDERS)
        _check_field("stores", self.stores, STORES)
        eng = engine_storing(engine_for(g), self.stores)
        object.__setattr__(self, "_eng", eng)  # the group's engine, looked up once
        if self.rotation in EULER_COORDS and not eng.euler:
            raise ValueError(
                f"Convention {self.name!r}: Euler-angle coordinates ({self.rotation!r}) are "
                f"implemented for SO(3)/SE(3) conventions, not {g.name}"
            )
        if g.rot_dim != 3 and self.rotation != "exp":
            what = (
                "a planar rotation has one coordinate, the angle"
                if g.rot_dim
                else (f"{g.name} has no rotation coordinates")
            )
            raise ValueError(
                f"Convention {self.name!r}: {what}: rotation must be 'exp', not {self.rotation!r}"
            )
        if self.embed is not None and not eng.embed:
            raise ValueError(f"Convention {self.name!r}: embed is for the other groups")
        eng.check(self, g)
        if self.chart == g.coupled_chart and self.rotation != "exp":
            raise ValueError(
                f"Convention {self.name!r}: chart {self.chart!r} is the {g.label} exponential of "
                f"a tangent whose rotation part is a rotation vector, so it needs rotation='exp', "
                f"not {self.rotation!r}; a library that builds the rotation another way perturbs "
                f"rotation and translation separately (the split charts {g.charts[1:]})"
            )
        # the retraction-determining fields, kept as one tuple: the key of the map caches
        object.__setattr__(self, "_key", (self.side, self.order, self.chart, self.rotation))

    # ----------------------------------------------------------------- descriptors
    @property
    def _engine(self) -> Engine:
        return self._eng

    @property
    def _array_api(self) -> bool:
        return self.record.array_api

    def _run(self, *xs: Any) -> Engine:
        """Return the engine for these inputs.

        numpy: the group's (its fast implementation where it has one); torch/JAX arrays: the
        group's engine for tensors (:meth:`Engine.for_tensors`: the record-driven one, written
        array-generically, or a group's own).
        """
        if arrays.any_foreign(*xs):
            return engine_storing(engine_for(self.group).for_tensors(), self.stores)
        return self._eng

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state.pop("_eng", None)  # looked up again where it is unpickled (that process's registry)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        for k, v in state.items():
            object.__setattr__(self, k, v)
        stores = state.setdefault("stores", "pose")  # pickled before the field existed
        object.__setattr__(self, "stores", stores)
        object.__setattr__(self, "_eng", engine_storing(engine_for(state["group"]), stores))

    @property
    def fields(self) -> tuple[str, ...]:
        """``(side, order, chart, rotation)``: what a retraction determines (not ``quat_order``).

        A convention that stores the inverse appends ``"inverse"``: its retraction differs.
        """
        return self._key if self.stores == "pose" else (*self._key, "inverse")

    @property
    def is_euler(self) -> bool:
        """Whether the rotation coordinates are absolute Euler angles (``euler_zyx``/``_rpy``)."""
        return self.rotation in EULER_COORDS

    def dim(self, X: Any = None) -> int:
        """Length of this convention's tangent (at ``X``, for an SE(3) one given a rotation: 3)."""
        return self._run(X).dim(self, X)

    def element(self, X: Any, name: str = "X") -> FloatArray:
        """Validate ``X`` as an element of this convention's group (the record's validator)."""
        return self._run(X).element(self, X, name)

    @property
    def rotation_scale(self) -> float:
        """First-order ``dω/dr`` of the rotation coordinates (2 for half angles, else 1)."""
        return FIRST_ORDER_SCALE[self.rotation]

    def describe(self) -> str:
        """One line: name and fields."""
        head = f"{self.name}: " if self.group == DEFAULT_GROUP else f"{self.name} ({self.group}): "
        tail = f", embed={self.embed.index} in {self.embed.size}" if self.embed else ""
        if self.stores != "pose":
            tail += f", stores={self.stores}"
        return (
            f"{head}side={self.side}, order={self.order}, chart={self.chart}, "
            f"rotation={self.rotation}, quat_order={self.quat_order}{tail}"
        )

    def _pair(self, X: Any, Y: Any) -> tuple[FloatArray, FloatArray]:
        return self._run(X, Y).pair(self, X, Y)

    # ----------------------------------------------------------------- retraction
    def _increment(self, d: Any, so3: bool, name: str = "d") -> FloatArray:
        """Validate an increment in this convention (rotation part bounded)."""
        return self._run(d).increment(self, d, so3, name)

    def _retract(self, X: FloatArray, d: FloatArray) -> FloatArray:
        return self._run(X, d).retract(self, X, d)

    def _local(self, X: FloatArray, Y: FloatArray) -> FloatArray:
        return self._run(X, Y).local(self, X, Y)

    def _local_jacobian(self, X: FloatArray, Y: FloatArray) -> FloatArray:
        return self._run(X, Y).local_jacobian(self, X, Y)

    # ----------------------------------------------------------------- first-order maps
    def _to_canonical(self, X: FloatArray) -> FloatArray:
        return self._run(X).to_canonical(self, X)

    def _from_canonical(self, X: FloatArray) -> FloatArray:
        return self._run(X).from_canonical(self, X)


#: The canonical tangent (GTSAM's): right, rotation first, SE(3) exponential.
CANONICAL = Convention(
    name="canonical",
    side="right",
    order="rot_first",
    chart="se3",
    rotation="exp",
    quat_order="wxyz",
    source="liebridge canonical form = GTSAM 4.3 Pose3/Rot3 (measured in tests)",
)

__all__ = [
    "CANONICAL",
    "CHARTS",
    "DEFAULT_GROUP",
    "GROUP_NAMES",
    "ORDERS",
    "QUAT_ORDERS",
    "SIDES",
    "Convention",
    "Embed",
    "group_input",
]
