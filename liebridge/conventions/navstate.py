"""Charts of the navigation state ``(R, p, v)`` built from a pose convention and a velocity frame.

VIO/LIO systems perturb the rotation and position of the IMU the way one of the SE(3)
conventions does (right or left, rotation vector or Cayley, position increment in the body or
the world frame), and the velocity separately: added in the world frame (OpenVINS, VINS, Basalt,
ORB-SLAM3, a GTSAM graph's ``Vector3`` velocity key) or rotated into it from the body frame
(GTSAM's ``NavState``). A :class:`NavChart` is that pair, as a convention of SE₂(3): its elements
are liebridge's extended-pose matrices

``X = [[R, p, v], [0, 1, 0], [0, 0, 1]]``  (5×5, ``R = R_world_body``, ``p``, ``v`` in world),

its tangent is ``(pose tangent in the pose convention's order, δv)`` (9), and

``retract(X, (d, δv)) = (pose.retract((R, p), d), v + R·δv)`` (``velocity="body"``, ``R`` the
rotation before the update) or ``v + δv`` (``velocity="world"``).

So every such chart converts to and from GTSAM's ``NavState`` chart and manif's ``SE_2_3``
(:func:`liebridge.conventions.tangent_map`, ``convert_covariance``), and bundles of one with two
bias vectors (``openvins``, ``vins``, ``gtsam_imu_keys``, ... in
:mod:`liebridge.conventions.presets`) convert as whole 15-dimensional states.

The first-order map to GTSAM's SE₂(3) tangent ``(θ, ρ, ν)`` (right, ``X·Exp(ξ)``) is
block diagonal: the pose convention's own map to ``(ω, v)`` (to first order ``X·Exp(ξ)`` moves
``(R, p)`` as the SE(3) ``X·Exp(ω, v)`` does) and ``I`` (body velocity) or ``Rᵀ`` (world).

A :class:`NavChart` runs on numpy, torch and JAX arrays (the caller's array type, device and
dtype, differentiable) wherever its pose convention does: its pose part is the pose
convention's own retraction and maps (the array-generic SE(3) engine), the velocity part and the
assembly of the 5×5 element and the 9×9 maps are stacked, never written in place. A pose
convention with rotation coordinates that run on numpy only (Cayley: ``openvins``, ``vins``)
refuses tensors in ``retract``/``local``/``local_jacobian`` as that convention does; its first-order
maps (``to_canonical``, ``tangent_map``, ``convert_covariance``) need no rotation coordinates and
run on tensors.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from ..lie import se3, se23
from .chart import Chart
from .convention import Convention
from .tangent_order import from_concatenated, perm_matrix, to_concatenated

VelocityFrame = Literal["body", "world"]


def _pose(X: FloatArray) -> FloatArray:
    """Return the SE(3) part ``[[R, p], [0, 1]]`` of extended poses (a view)."""
    return X[..., :4, :4]


def _mv(A: FloatArray, x: FloatArray) -> FloatArray:
    if arrays.any_foreign(A, x):
        return arrays.matvec(A, x)
    return np.einsum("...ij,...j->...i", A, x)


# the tangent permutations on any array type (numpy: tangent_order's, the same maps); these
# belong to tangent_order.py, whose numpy functions write in place
def _to_concat_any(d: Any, perm: tuple[int, ...] | None) -> Any:
    """Return the concatenated tangent of ``d`` (``d_concatenated[perm] = d``), any array type."""
    if perm is None:
        return d
    if arrays.is_foreign(d):  # out[perm] = d  ⇔  out = d[perm⁻¹]: a gather, not a write
        return d[..., [int(i) for i in np.argsort(perm)]]
    return to_concatenated(d, perm)


def _from_concat_any(c: Any, perm: tuple[int, ...] | None) -> Any:
    """Return the state's tangent of a concatenated tangent ``c``, any array type."""
    if perm is None or not arrays.is_foreign(c):
        return from_concatenated(c, perm)
    return c[..., list(perm)]


def _broadcast_concat(parts: list[Any]) -> Any:
    """Concatenate ``(..., n_i)`` parts along the last axis after broadcasting their batches."""
    xp = arrays.namespace(*parts)
    batch = tuple(np.broadcast_shapes(*(tuple(p.shape[:-1]) for p in parts)))
    return arrays.concat([xp.broadcast_to(p, (*batch, p.shape[-1])) for p in parts], -1)


def _block_diagonal(diag: list[Any], batch: tuple[int, ...]) -> Any:
    """Return the block diagonal ``(*batch, N, N)`` of torch/JAX blocks (stacked)."""
    ref = diag[0]
    grid = [
        [
            b if i == j else arrays.zeros((int(b.shape[-2]), int(c.shape[-1])), ref)
            for j, c in enumerate(diag)
        ]
        for i, b in enumerate(diag)
    ]
    M = arrays.blocks(grid)
    return arrays.namespace(ref).broadcast_to(M, (*batch, *M.shape[-2:]))


@dataclass(frozen=True)
class NavChart(Chart):
    """A navigation-state chart: an SE(3) ``pose`` convention and a ``velocity`` frame.

    A chart of its own (:class:`~liebridge.conventions.chart.Chart`) on SE₂(3) elements: its
    side, order and rotation coordinates are its ``pose`` convention's (``nav.pose.side``), its
    velocity increment is in the ``velocity`` frame. Build it with :meth:`NavChart.of`; see the
    module docstring for the retraction.
    """

    name: str
    pose: Convention
    velocity: str = "world"
    perm: tuple[int, ...] | None = None
    source: str = ""
    notes: str = field(default="", compare=False, repr=False)
    group: str = field(init=False, default="", compare=False)
    _key: tuple[str, str, str, str] = field(init=False, repr=False, compare=False)
    _generic: bool = field(init=False, repr=False, compare=False, default=False)

    @classmethod
    def of(
        cls,
        name: str,
        pose: Convention,
        velocity: VelocityFrame,
        source: str = "",
        notes: str = "",
        order: list[int] | None = None,
    ) -> NavChart:
        """Build the chart (``pose`` an SE(3) convention, ``velocity`` ``"body"``/``"world"``).

        ``order``: an optional tangent permutation, entry ``k`` of this chart's tangent is entry
        ``order[k]`` of ``(pose tangent, δv)`` (MOLA's ``(θ, v, p)``: ``[0, 1, 2, 6, 7, 8, 3, 4,
        5]`` with a rotation-first pose).
        """
        return cls(
            name=name,
            pose=pose,
            velocity=velocity,
            perm=tuple(order) if order is not None else None,
            source=source,
            notes=notes,
        )

    def __post_init__(self) -> None:
        object.__setattr__(self, "group", se23.GROUP.name)
        p = self.pose
        if not isinstance(p, Convention) or p.record is not se3.GROUP or p.is_euler:
            raise ValueError(
                f"NavChart {self.name!r}: pose must be an SE(3) convention with increment "
                f"coordinates (not Euler angles), got {p!r}"
            )
        validate.option(self.velocity, "velocity", ("body", "world"))
        if self.perm is not None and sorted(self.perm) != list(range(9)):
            raise ValueError(f"NavChart {self.name!r}: order must be a permutation of range(9)")
        perm = "" if self.perm is None else f"@{self.perm}"
        object.__setattr__(
            self,
            "_key",
            (f"nav:{p.side}", p.order, f"{p.chart}+v_{self.velocity}{perm}", p.rotation),
        )
        object.__setattr__(self, "_generic", p._array_api)

    @property
    def _p(self) -> Convention:
        return self.pose

    def element(self, X: Any, name: str = "X") -> FloatArray:
        """Validate an extended pose ``(..., 5, 5)`` (the SE₂(3) record's validator)."""
        return se23.GROUP.element(X, name)

    def dim(self, X: Any = None) -> int:
        """9: the pose tangent (6, in the pose convention's order) then ``δv`` (3)."""
        return 9

    def describe(self) -> str:
        """One line: name, pose convention, velocity frame."""
        return (
            f"{self.name} (se23 navigation chart): pose {self._p.describe()}; "
            f"velocity increment in the {self.velocity} frame"
            + (f"; tangent order {list(self.perm)} of (pose, δv)" if self.perm else "")
        )

    def _to_concat(self, d: FloatArray) -> FloatArray:
        return to_concatenated(d, self.perm)

    def _P(self) -> FloatArray:
        """``P`` with ``d_(pose, δv) = P d``."""
        return perm_matrix(9, self.perm)

    # ----------------------------------------------------------------- retraction
    def _increment(self, d: Any, so3: bool, name: str = "d") -> FloatArray:
        arr = validate.vector(d, name, 9)
        self._p._increment(_to_concat_any(arr, self.perm)[..., :6], False, name)
        return arr

    @property
    def _array_api(self) -> bool:
        """Whether this chart runs on torch/JAX arrays: where its pose convention does."""
        return self._generic  # (read on every call: computed once, in __post_init__)

    def _retract(self, X: FloatArray, d: FloatArray) -> FloatArray:
        d = _to_concat_any(d, self.perm)
        T2 = self._p._retract(_pose(X), d[..., :6])
        dv = d[..., 6:]
        v = X[..., :3, 4]
        v2 = v + (_mv(X[..., :3, :3], dv) if self.velocity == "body" else dv)
        if arrays.any_foreign(T2, v2):
            xp = arrays.namespace(T2, v2)
            batch = tuple(np.broadcast_shapes(tuple(T2.shape[:-2]), tuple(v2.shape[:-1])))
            top = arrays.concat(
                [
                    xp.broadcast_to(T2[..., :3, :], (*batch, 3, 4)),
                    xp.broadcast_to(v2, (*batch, 3))[..., None],
                ],
                -1,
            )
            bottom = xp.broadcast_to(arrays.like(np.eye(5)[3:], top), (*batch, 2, 5))
            return arrays.concat([top, bottom], -2)
        out = np.zeros((*np.broadcast_shapes(X.shape[:-2], d.shape[:-1]), 5, 5))
        out[..., :4, :4] = T2
        out[..., :3, 4] = v2
        out[..., 4, 4] = 1.0
        return out

    def _local(self, X: FloatArray, Y: FloatArray) -> FloatArray:
        d = self._p._local(_pose(X), _pose(Y))
        dv = Y[..., :3, 4] - X[..., :3, 4]
        if self.velocity == "body":
            dv = _mv(arrays.mT(X[..., :3, :3]), dv)
        if arrays.any_foreign(d, dv):
            return _from_concat_any(_broadcast_concat([d, dv]), self.perm)
        batch = np.broadcast_shapes(d.shape[:-1], dv.shape[:-1])
        parts = [np.broadcast_to(d, (*batch, 6)), np.broadcast_to(dv, (*batch, 3))]
        return from_concatenated(np.concatenate(parts, axis=-1), self.perm)

    # ----------------------------------------------------------------- first-order maps
    def _blocks(self, X: FloatArray, A: FloatArray, vel: FloatArray) -> FloatArray:
        if arrays.any_foreign(A, vel):
            batch = tuple(np.broadcast_shapes(tuple(A.shape[:-2]), tuple(vel.shape[:-2])))
            return _block_diagonal([A, vel], batch)
        out = np.zeros((*np.broadcast_shapes(A.shape[:-2], vel.shape[:-2]), 9, 9))
        out[..., :6, :6] = A
        out[..., 6:, 6:] = vel
        return out

    def _eye3(self, R: FloatArray, batch: tuple[int, ...]) -> FloatArray:
        if arrays.is_foreign(R):
            return arrays.eye(3, R, batch)
        return np.broadcast_to(np.eye(3), (*batch, 3, 3))

    def _to_canonical(self, X: FloatArray) -> FloatArray:
        R = X[..., :3, :3]
        vel = self._eye3(R, tuple(R.shape[:-2])) if self.velocity == "body" else arrays.mT(R)
        M = self._blocks(X, self._p._to_canonical(_pose(X)), vel)
        if self.perm is None:
            return M
        if arrays.is_foreign(M):  # M·P: its columns, gathered
            return M[..., :, list(self.perm)]
        return np.asarray(M @ self._P(), dtype=np.float64)

    def _from_canonical(self, X: FloatArray) -> FloatArray:
        R = X[..., :3, :3]
        vel = self._eye3(R, tuple(R.shape[:-2])) if self.velocity == "body" else R
        M = self._blocks(X, self._p._from_canonical(_pose(X)), vel)
        if self.perm is None:
            return M
        if arrays.is_foreign(M):  # Pᵀ·M: its rows, gathered
            return M[..., list(self.perm), :]
        return np.asarray(self._P().T @ M, dtype=np.float64)

    def _local_jacobian(self, X: FloatArray, Y: FloatArray) -> FloatArray:
        A = self._p._local_jacobian(_pose(X), _pose(Y))
        if self.velocity == "body":
            vel = arrays.mT(X[..., :3, :3]) @ Y[..., :3, :3]
        else:
            vel = self._eye3(A, tuple(A.shape[:-2]))
        J = self._blocks(X, A, vel)
        if self.perm is None:
            return J
        if arrays.is_foreign(J):
            p = list(self.perm)
            return J[..., p, :][..., :, p]
        P = self._P()
        return np.asarray(P.T @ J @ P, dtype=np.float64)


def nav_state(R_world_body: Any, p_world: Any, v_world: Any) -> FloatArray:
    """Assemble extended poses ``(..., 5, 5)`` from ``R_world_body``, position and velocity.

    ``R_world_body`` rotates body (IMU) coordinates into the world frame; from an OpenVINS JPL
    ``q_GtoI`` it is ``quaternion.to_matrix(q_GtoI, order="jpl").T``. torch/JAX arguments give
    an array of their type (numpy ones beside them are moved to it), stacked, differentiable.
    """
    if arrays.any_foreign(R_world_body, p_world, v_world):
        R_world_body, p_world, v_world = arrays.common(R_world_body, p_world, v_world)
    R = validate.rotation(R_world_body, "R_world_body")
    p = validate.vector(p_world, "p_world", 3)
    v = validate.vector(v_world, "v_world", 3)
    shape = validate.batch_shape(
        ("R_world_body", R.shape[:-2]), ("p_world", p.shape[:-1]), ("v_world", v.shape[:-1])
    )
    if arrays.any_foreign(R, p, v):
        xp = arrays.namespace(R, p, v)
        cols = [xp.broadcast_to(R, (*shape, 3, 3))]
        cols += [xp.broadcast_to(x, (*shape, 3))[..., None] for x in (p, v)]
        bottom = xp.broadcast_to(arrays.like(np.eye(5)[3:], R), (*shape, 2, 5))
        return arrays.concat([arrays.concat(cols, -1), bottom], -2)
    X = np.zeros((*shape, 5, 5))
    X[..., :3, :3] = R
    X[..., :3, 3] = p
    X[..., :3, 4] = v
    X[..., 3, 3] = X[..., 4, 4] = 1.0
    return X


def _pose_part(c: Chart) -> Convention | None:
    """Return the SE(3) chart a navigation chart moves ``(R, p)`` by (None: coupled SE₂(3))."""
    if isinstance(c, NavChart):
        return c._p
    if (
        not isinstance(c, Convention)
        or c.record is not se23.GROUP
        or c.chart == se23.GROUP.coupled_chart
    ):
        return None
    return Convention(
        name=f"{c.name}_pose",
        side=c.side,
        order="rot_first",
        chart=se3.GROUP.charts[1 if se23.GROUP.split_frame(c.chart) == "body" else 2],
        rotation=c.rotation,
        quat_order=c.quat_order,
    )


def nav_exactly_linear(a: Chart, b: Chart, linear: Callable[[Any, Any], bool]) -> bool:
    """Whether two SE₂(3) charts, one at least a :class:`NavChart`, convert exactly linearly.

    The velocity increment (body ``R·δv`` or world ``δv``) is always linear; the pose parts
    decide (``linear`` is :func:`~liebridge.conventions.is_exactly_linear` on SE(3)). A
    ``NavChart`` field ``chart`` names only the velocity frame: comparing it alone would call a
    coupled-SE(3) pose (``gtsam_imu_keys``) exactly linear to a split one (false).
    """
    pa, pb = _pose_part(a), _pose_part(b)
    if pa is None or pb is None:
        return False
    return bool(linear(pa, pb))
