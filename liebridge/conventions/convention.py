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
    which Lie group the elements belong to: ``so2``, ``se2``, ``so3``, ``se3``, ``sim3``,
    ``se23`` (default ``se3``, which also accepts a ``(..., 3, 3)`` rotation as its SO(3) part, as
    before groups existed). Each group has its own canonical tangent (GTSAM's) and its charts:
    the coupled one named after the group (``se2``, ``se3``, ``sim3``, ``se23``) and the split
    ones ``split_body``/``split_world`` (SE(3) spells them ``so3xr3_body``/``so3xr3_world``).
    See ``docs/design-groups.md``.
``embed``
    optional :class:`Embed`: the tangent is a longer vector holding the group's coordinates at
    fixed entries (``ros_pose2``: SE(2)'s ``(x, y, yaw)`` at entries 0, 1, 5 of ROS's 6-vector).

Canonical (GTSAM) is ``right, rot_first, se3, exp``. ``local(X, retract(X, d)) == d`` within the
chart's domain (``‖ω‖ < π``; ``‖r‖ < 1`` for ``quat_vec``), and the first-order maps
:meth:`Convention.to_canonical` / :meth:`Convention.from_canonical` are closed form.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..lie import unchecked as U
from . import groups as G
from .rotation_coords import (
    EULER_COORDS,
    FIRST_ORDER_SCALE,
    ROTATION_COORDS,
    d_from_rotation,
    euler_local,
    euler_rate_map,
    euler_rate_map_inv,
    euler_retract,
    from_rotation,
    matrix_to_euler,
    to_rotation,
)
from .tangent_maps import canonical_tangent_map

GROUP_NAMES = ("so2", "se2", "so3", "se3", "sim3", "se23")
#: Charts of each group: coupled (the group's exponential) first, then the split ones.
GROUP_CHARTS: dict[str, tuple[str, ...]] = {
    "so2": ("so2",),
    "se2": ("se2", "split_body", "split_world"),
    "so3": ("se3", "so3xr3_body", "so3xr3_world"),
    "se3": ("se3", "so3xr3_body", "so3xr3_world"),
    "sim3": ("sim3", "split_body", "split_world"),
    "se23": ("se23", "split_body", "split_world"),
}
#: Tangent dimension and matrix size of each group.
GROUP_DIMS: dict[str, tuple[int, int]] = {
    "so2": (1, 2),
    "se2": (3, 3),
    "so3": (3, 3),
    "se3": (6, 4),
    "sim3": (7, 4),
    "se23": (9, 5),
}
_SE3_SPLIT_ALIASES = {"split_body": "so3xr3_body", "split_world": "so3xr3_world"}


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
Order = Literal["rot_first", "trans_first"]
Chart = Literal[
    "se3", "so3xr3_body", "so3xr3_world", "so2", "se2", "sim3", "se23", "split_body", "split_world"
]
SIDES = ("right", "left")
ORDERS = ("rot_first", "trans_first")
CHARTS = ("se3", "so3xr3_body", "so3xr3_world")
QUAT_ORDERS = ("wxyz", "xyzw", "jpl")


def _check_field(name: str, value: str, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise ValueError(f"Convention.{name}: expected one of {allowed}, got {value!r}")


def _is_so3(X: FloatArray) -> bool:
    return X.shape[-2:] == (3, 3)


def group_input(X: Any, name: str = "X") -> FloatArray:
    """Validate ``X`` as a pose ``(..., 4, 4)`` or a rotation ``(..., 3, 3)``."""
    arr = validate.as_float_array(X, name)
    shape = arr.shape[-2:]
    if shape == (4, 4):
        return validate.checked_pose(arr, name)
    if shape == (3, 3):
        return validate.checked_rotation(arr, name)
    raise ValueError(
        f"{name}: expected a pose (..., 4, 4) or a rotation (..., 3, 3), got {arr.shape}"
    )


def _group_pair(X: Any, Y: Any) -> tuple[FloatArray, FloatArray]:
    """Validate two group elements of the same kind with broadcastable batch shapes."""
    X = group_input(X)
    Y = group_input(Y, "Y")
    if X.shape[-2:] != Y.shape[-2:]:
        raise ValueError(f"Y: shape {Y.shape} does not match X {X.shape}")
    validate.batch_shape(("X", X.shape[:-2]), ("Y", Y.shape[:-2]))
    return X, Y


@dataclass(frozen=True)
class Convention:
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
    """

    name: str
    side: Side
    order: Order
    chart: Chart
    rotation: str
    quat_order: str
    source: str = ""
    notes: str = field(default="", compare=False, repr=False)
    group: str = "se3"
    embed: Embed | None = None
    _key: tuple[str, str, str, str] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        _check_field("group", self.group, GROUP_NAMES)
        _check_field("side", self.side, SIDES)
        _check_field("order", self.order, ORDERS)
        if self.group in ("se3", "so3") and self.chart in _SE3_SPLIT_ALIASES:
            object.__setattr__(self, "chart", _SE3_SPLIT_ALIASES[self.chart])
        _check_field("chart", self.chart, GROUP_CHARTS[self.group])
        _check_field("rotation", self.rotation, ROTATION_COORDS)
        _check_field("quat_order", self.quat_order, QUAT_ORDERS)
        if self.rotation in EULER_COORDS and self.group not in ("se3", "so3"):
            raise ValueError(
                f"Convention {self.name!r}: Euler-angle coordinates ({self.rotation!r}) are "
                f"implemented for SO(3)/SE(3) conventions, not {self.group}"
            )
        if self.group in ("so2", "se2") and self.rotation != "exp":
            raise ValueError(
                f"Convention {self.name!r}: a planar rotation has one coordinate, the angle: "
                f"rotation must be 'exp', not {self.rotation!r}"
            )
        if self.embed is not None:
            if self.group in ("se3", "so3"):
                raise ValueError(f"Convention {self.name!r}: embed is for the other groups")
            if len(self.embed.index) != GROUP_DIMS[self.group][0]:
                raise ValueError(
                    f"Convention {self.name!r}: embed.index has {len(self.embed.index)} entries, "
                    f"the {self.group} tangent {GROUP_DIMS[self.group][0]}"
                )
        if self.group not in ("se3", "so3"):
            object.__setattr__(self, "_key", (self.side, self.order, self.chart, self.rotation))
            return
        if self.chart == "se3" and self.rotation != "exp":
            raise ValueError(
                f"Convention {self.name!r}: chart 'se3' is the SE(3) exponential of a twist whose "
                f"rotation part is a rotation vector, so it needs rotation='exp', not "
                f"{self.rotation!r}; a library that builds the rotation another way perturbs "
                f"rotation and translation separately (chart 'so3xr3_body' or 'so3xr3_world')"
            )
        # the retraction-determining fields, kept as one tuple: the key of the map caches below
        object.__setattr__(self, "_key", (self.side, self.order, self.chart, self.rotation))

    # ----------------------------------------------------------------- descriptors
    @property
    def fields(self) -> tuple[str, str, str, str]:
        """``(side, order, chart, rotation)``: what a retraction determines (not ``quat_order``)."""
        return self._key

    @property
    def is_euler(self) -> bool:
        """Whether the rotation coordinates are absolute Euler angles (``euler_zyx``/``_rpy``)."""
        return self.rotation in EULER_COORDS

    @property
    def generic(self) -> bool:
        """Whether this convention runs on the group-generic engine (not SE(3)/SO(3))."""
        return self.group not in ("se3", "so3")

    def dim(self, X: Any = None) -> int:
        """Length of this convention's tangent (at ``X``, for an SE(3) one given a rotation: 3)."""
        if self.embed is not None:
            return self.embed.size
        if (
            self.group == "se3"
            and X is not None
            and validate.as_float_array(X, "X").shape[-2:] == (3, 3)
        ):
            return 3
        return GROUP_DIMS[self.group][0]

    def element(self, X: Any, name: str = "X") -> FloatArray:
        """Validate ``X`` as an element of this convention's group (see ``_validate``)."""
        if self.group == "se3":
            return group_input(X, name)
        if self.group == "so3":
            return validate.rotation(X, name)
        check = {
            "so2": validate.rotation2,
            "se2": validate.pose2,
            "sim3": validate.similarity,
            "se23": validate.extended_pose,
        }[self.group]
        return check(X, name)

    @property
    def rotation_scale(self) -> float:
        """First-order ``dω/dr`` of the rotation coordinates (2 for half angles, else 1)."""
        return FIRST_ORDER_SCALE[self.rotation]

    def describe(self) -> str:
        """One line: name and fields."""
        head = f"{self.name}: " if self.group == "se3" else f"{self.name} ({self.group}): "
        tail = f", embed={self.embed.index} in {self.embed.size}" if self.embed else ""
        return (
            f"{head}side={self.side}, order={self.order}, chart={self.chart}, "
            f"rotation={self.rotation}, quat_order={self.quat_order}{tail}"
        )

    def _pair(self, X: Any, Y: Any) -> tuple[FloatArray, FloatArray]:
        if self.group == "se3":
            return _group_pair(X, Y)
        A, B = self.element(X), self.element(Y, "Y")
        validate.batch_shape(("X", A.shape[:-2]), ("Y", B.shape[:-2]))
        return A, B

    # ----------------------------------------------------------------- retraction
    def _increment(self, d: Any, so3: bool, name: str = "d") -> FloatArray:
        """Validate an increment in this convention (rotation part bounded)."""
        if self.generic:
            arr = validate.vector(d, name, self.dim())
            validate.tangent(
                G.to_internal(self, arr), name, GROUP_DIMS[self.group][0], G.GROUPS[self.group].rot
            )
            return arr
        if so3 or self.group == "so3":
            return validate.tangent(d, name, 3)
        return validate.tangent(
            d, name, 6, slice(0, 3) if self.order == "rot_first" else slice(3, 6)
        )

    def _split(self, d: FloatArray) -> tuple[FloatArray, FloatArray]:
        if self.order == "rot_first":
            return d[..., :3], d[..., 3:]
        return d[..., 3:], d[..., :3]

    def _join(self, r: FloatArray, u: FloatArray) -> FloatArray:
        parts = (r, u) if self.order == "rot_first" else (u, r)
        return np.concatenate(np.broadcast_arrays(*parts), axis=-1)

    def _retract(self, X: FloatArray, d: FloatArray) -> FloatArray:
        if self.generic:
            return G.retract(self, X, d)
        if _is_so3(X):
            if self.is_euler:
                return euler_retract(X, d, self.rotation)
            dR = to_rotation(d, self.rotation)
            return np.asarray(X @ dR if self.side == "right" else dR @ X, dtype=np.float64)
        r, u = self._split(d)
        if self.chart == "se3":
            E = U.se3_exp(np.concatenate([r, u], axis=-1))
            return np.asarray(X @ E if self.side == "right" else E @ X, dtype=np.float64)
        R, t = X[..., :3, :3], X[..., :3, 3]
        if self.is_euler:
            R2 = euler_retract(R, r, self.rotation)
        else:
            dR = to_rotation(r, self.rotation)
            R2 = R @ dR if self.side == "right" else dR @ R
        du = np.einsum("...ij,...j->...i", R, u) if self.chart == "so3xr3_body" else u
        out = np.zeros(np.broadcast_shapes(X.shape, (*d.shape[:-1], 4, 4)))
        out[..., :3, :3] = R2
        out[..., :3, 3] = t + du
        out[..., 3, 3] = 1.0
        return out

    def _local(self, X: FloatArray, Y: FloatArray) -> FloatArray:
        if self.generic:
            return G.local(self, X, Y)
        if _is_so3(X):
            if self.is_euler:
                return euler_local(X, Y, self.rotation)
            Xt = np.swapaxes(X, -1, -2)
            dR = Xt @ Y if self.side == "right" else Y @ Xt
            return from_rotation(dR, self.rotation)
        if self.chart == "se3":
            Xi = U.se3_inverse(X)
            D = Xi @ Y if self.side == "right" else Y @ Xi
            xi = U.se3_log(D)
            return self._join(xi[..., :3], xi[..., 3:])
        R, t = X[..., :3, :3], X[..., :3, 3]
        Rt = np.swapaxes(R, -1, -2)
        RY, tY = Y[..., :3, :3], Y[..., :3, 3]
        if self.is_euler:
            r = euler_local(R, RY, self.rotation)
        else:
            dR = Rt @ RY if self.side == "right" else RY @ Rt
            r = from_rotation(dR, self.rotation)
        dt = tY - t
        u = np.einsum("...ij,...j->...i", Rt, dt) if self.chart == "so3xr3_body" else dt
        return self._join(r, u)

    def retract(self, X: Any, d: Any) -> FloatArray:
        """Perturb ``X`` by ``d`` in this convention (broadcast over leading dimensions).

        Parameters
        ----------
        X : array_like, shape (..., 4, 4) or (..., 3, 3)
            Pose or rotation.
        d : array_like, shape (..., 6) or (..., 3)
            Tangent in this convention's order and rotation coordinates.

        Returns
        -------
        ndarray, same kind as ``X``
        """
        X = self.element(X)
        d = self._increment(d, _is_so3(X))
        validate.batch_shape(("X", X.shape[:-2]), ("d", d.shape[:-1]))
        return validate.finite_output(self._retract(X, d), f"{self.name}.retract")

    def local(self, X: Any, Y: Any) -> FloatArray:
        """Inverse of :meth:`retract`: the ``d`` with ``retract(X, d) == Y`` (principal branch)."""
        X, Y = self._pair(X, Y)
        return validate.finite_output(self._local(X, Y), f"{self.name}.local")

    def _local_jacobian(self, X: FloatArray, Y: FloatArray) -> FloatArray:
        if self.generic:
            return G.local_jacobian(self, X, Y)
        s = self.rotation_scale
        if self.is_euler:  # local(X, retract(Y, δ)) = e(Y) + δ − e(X): the identity
            shape = np.broadcast_shapes(X.shape[:-2], Y.shape[:-2])
            matrix_to_euler(Y[..., :3, :3], self.rotation, "Y")  # gimbal lock raises
            n = 3 if _is_so3(X) else 6
            J = np.zeros((*shape, n, n))
            J[..., :, :] = np.eye(n)
            if n == 6:
                RX, RY = X[..., :3, :3], Y[..., :3, :3]
                tb = np.swapaxes(RX, -1, -2) @ RY if self.chart == "so3xr3_body" else np.eye(3)
                k = slice(3, 6) if self.order == "rot_first" else slice(0, 3)
                J[..., k, k] = tb
            return J
        if _is_so3(X):
            Xt = np.swapaxes(X, -1, -2)
            dR = Xt @ Y if self.side == "right" else Y @ Xt
            return np.asarray(s * d_from_rotation(dR, self.rotation, self.side), dtype=np.float64)
        if self.chart == "se3":
            if self.side == "right":
                J = U.se3_jl_inv(-U.se3_log(U.se3_inverse(X) @ Y))  # Jr⁻¹(ξ) = Jl⁻¹(−ξ)
            else:
                J = U.se3_jl_inv(U.se3_log(Y @ U.se3_inverse(X)))
        else:
            RX, RY = X[..., :3, :3], Y[..., :3, :3]
            RXt = np.swapaxes(RX, -1, -2)
            dR = RXt @ RY if self.side == "right" else RY @ RXt
            J = np.zeros((*np.broadcast_shapes(X.shape, Y.shape)[:-2], 6, 6))
            J[..., :3, :3] = s * d_from_rotation(dR, self.rotation, self.side)
            J[..., 3:, 3:] = RXt @ RY if self.chart == "so3xr3_body" else np.eye(3)
        if self.order == "trans_first":
            J = np.concatenate([J[..., 3:, :], J[..., :3, :]], axis=-2)
            J = np.concatenate([J[..., :, 3:], J[..., :, :3]], axis=-1)
        return np.asarray(J, dtype=np.float64)

    def local_jacobian(self, X: Any, Y: Any) -> FloatArray:
        """Differentiate ``local(X, ·)`` at ``Y`` in this convention's own chart.

        Returns ``J = ∂ local(X, retract(Y, δ)) / ∂δ |_{δ=0}``, ``(..., 6, 6)`` (or 3×3), closed
        form. For ``se3``/right this is ``Jr⁻¹(local(X, Y))`` (reordered), for ``se3``/left
        ``Jl⁻¹``; for the decoupled charts it is block diagonal (rotation block from
        :func:`~liebridge.conventions.rotation_coords.d_from_rotation`, translation block
        ``R_Xᵀ R_Y`` in the body frame, ``I`` in the world frame). To differentiate with respect
        to GTSAM's perturbation of ``Y`` instead, multiply by ``tangent_map(Y, "gtsam", self)``.
        False: ``J = I`` (true only at ``Y = X``: the textbook approximation that moves optima).
        """
        X, Y = self._pair(X, Y)
        return validate.finite_output(self._local_jacobian(X, Y), f"{self.name}.local_jacobian")

    # ----------------------------------------------------------------- first-order maps
    def _euler_base(self) -> tuple[Convention, slice]:
        """Return the rotation-vector twin (right, ``exp``) and where its rotation entries sit."""
        base = Convention(
            name=f"{self.name}_exp", side="right", order=self.order, chart=self.chart,
            rotation="exp", quat_order=self.quat_order,
        )  # fmt: skip
        return base, slice(0, 3) if self.order == "rot_first" else slice(3, 6)

    def _euler_D(self, X: FloatArray, inverse: bool) -> FloatArray:
        """Return ``D``: ``W⁻¹`` (``inverse``: ``W``) on the rotation entries, else ``I``."""
        R = X[..., :3, :3]
        e = matrix_to_euler(R, self.rotation, "X")
        if inverse:
            B = euler_rate_map(e, self.rotation, "X")
        else:
            B = euler_rate_map_inv(e, self.rotation)
        if _is_so3(X):
            return B
        _, k = self._euler_base()
        D = np.zeros((*X.shape[:-2], 6, 6))
        D[..., :, :] = np.eye(6)
        D[..., k, k] = B
        return D

    def _to_canonical(self, X: FloatArray) -> FloatArray:
        if self.generic:
            return G.to_canonical(self, X)
        if self.is_euler:  # ω_body = W⁻¹(e) r; the rest as the rotation-vector twin
            base, _ = self._euler_base()
            M = canonical_tangent_map(base, "to", X.shape[-1] == 3)(X)
            return np.asarray(M @ self._euler_D(X, False), dtype=np.float64)
        return canonical_tangent_map(self, "to", X.shape[-1] == 3)(X)

    def _from_canonical(self, X: FloatArray) -> FloatArray:
        if self.generic:
            return G.from_canonical(self, X)
        if self.is_euler:
            base, _ = self._euler_base()
            M = canonical_tangent_map(base, "from", X.shape[-1] == 3)(X)
            return np.asarray(self._euler_D(X, True) @ M, dtype=np.float64)
        return canonical_tangent_map(self, "from", X.shape[-1] == 3)(X)

    def to_canonical(self, X: Any) -> FloatArray:
        """First-order map ``M``, ``ξ_gtsam = M d`` at ``X``; shape (..., 6, 6) or (..., 3, 3).

        It is the derivative at ``d = 0`` of ``GTSAM.local(X, self.retract(X, d))``.
        """
        return validate.finite_output(
            self._to_canonical(self.element(X)), f"{self.name}.to_canonical"
        )

    def from_canonical(self, X: Any) -> FloatArray:
        """Inverse of :meth:`to_canonical` (closed form, no matrix inversion)."""
        out = self._from_canonical(self.element(X))
        return validate.finite_output(out, f"{self.name}.from_canonical")


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
