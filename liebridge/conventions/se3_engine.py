"""SE(3) and SO(3)'s registered fast implementation of the record-driven convention formulas.

The same maps as :class:`~liebridge.conventions.engine.Engine` (a test holds them equal on every
SE(3) and SO(3) preset), evaluated with what only these groups have: the closed-form tangent-map
grids of :mod:`~liebridge.conventions.tangent_maps` (and the optional compiled pass built on
them), the absolute Euler-angle coordinates, and an SE(3) convention acting on a bare rotation
``(..., 3, 3)`` as its SO(3) part (a convention of ``se3`` accepts both, as before groups
existed).
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from ..lie import Group, se3, so3
from ..lie import unchecked as U
from .engine import RECORD_ENGINE, Engine, register_fast
from .rotation_coords import (
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

if TYPE_CHECKING:
    from .convention import Convention


def _is_so3(X: FloatArray) -> bool:
    return X.shape[-2:] == (3, 3)


def group_input(X: Any, name: str = "X") -> FloatArray:
    """Validate ``X`` as a pose ``(..., 4, 4)`` or a rotation ``(..., 3, 3)``."""
    X = arrays.unwrap(X, name)
    arr = X if arrays.is_foreign(X) else validate.as_float_array(X, name)
    shape = tuple(arr.shape[-2:])
    if shape == (4, 4):
        return validate.checked_pose(arr, name)
    if shape == (3, 3):
        return validate.checked_rotation(arr, name)
    raise ValueError(
        f"{name}: expected a pose (..., 4, 4) or a rotation (..., 3, 3), got {arr.shape}"
    )


def _shape(X: Any) -> tuple[int, ...]:
    X = arrays.unwrap(X, "X")
    return tuple(X.shape) if arrays.is_foreign(X) else validate.as_float_array(X, "X").shape


def _split(conv: Convention, d: FloatArray) -> tuple[FloatArray, FloatArray]:
    if conv.order == "rot_first":
        return d[..., :3], d[..., 3:]
    return d[..., 3:], d[..., :3]


def _join(conv: Convention, r: FloatArray, u: FloatArray) -> FloatArray:
    parts = (r, u) if conv.order == "rot_first" else (u, r)
    return np.concatenate(np.broadcast_arrays(*parts), axis=-1)


class SE3Engine(Engine):
    """The fast implementation for ``se3`` (poses, or rotations as their SO(3) part) and ``so3``.

    Charts: ``se3`` (the SE(3) exponential), ``so3xr3_body`` (``t + R·u``) and ``so3xr3_world``
    (``t + u``), the record's split charts.
    """

    euler = True
    embed = False
    rotations_3d = True

    def __init__(self, group: Group) -> None:
        self.group = group
        self.rotation_only = not group.vecs
        self._tensors = SE3TensorEngine(self)

    def check(self, conv: Convention, g: Group) -> None:
        """SE(3)'s own rules: no embedding (the other groups use it)."""
        if conv.embed is not None:
            raise ValueError(f"Convention {conv.name!r}: embed is for the other groups")

    def dim(self, conv: Convention, X: Any = None) -> int:
        """6 for a pose, 3 for a rotation (an SE(3) convention given a rotation: 3)."""
        if self.rotation_only:
            return 3
        if X is not None and _shape(X)[-2:] == (3, 3):
            return 3
        return 6

    def element(self, conv: Convention, X: Any, name: str) -> FloatArray:
        """Validate a pose or a rotation (``se3``), a rotation (``so3``)."""
        if self.rotation_only:
            return validate.rotation(X, name)
        return group_input(X, name)

    def pair(self, conv: Convention, X: Any, Y: Any) -> tuple[FloatArray, FloatArray]:
        """Two elements of the same kind with broadcastable batch shapes."""
        A = self.element(conv, X, "X")
        B = self.element(conv, Y, "Y")
        if A.shape[-2:] != B.shape[-2:]:
            raise ValueError(f"Y: shape {B.shape} does not match X {A.shape}")
        validate.batch_shape(("X", A.shape[:-2]), ("Y", B.shape[:-2]))
        return A, B

    def increment(self, conv: Convention, d: Any, so3: bool, name: str) -> FloatArray:
        """Validate an increment, its rotation part bounded (``validate.tangent``)."""
        if self.rotation_only or so3:
            return validate.tangent(d, name, 3)
        return validate.tangent(
            d, name, 6, slice(0, 3) if conv.order == "rot_first" else slice(3, 6)
        )

    def retract(self, conv: Convention, X: FloatArray, d: FloatArray) -> FloatArray:
        """``X·Exp(d)`` / ``Exp(d)·X`` (or the split update), see the Convention docstring."""
        if conv.is_euler:  # one array-generic definition (SE3TensorEngine's)
            return self._tensors.retract(conv, X, d)
        right = conv.side == "right"
        if _is_so3(X):
            dR = to_rotation(d, conv.rotation)
            return np.asarray(X @ dR if right else dR @ X, dtype=np.float64)
        r, u = _split(conv, d)
        frame = self.group.split_frame(conv.chart)
        if frame is None:
            E = U.se3_exp(np.concatenate([r, u], axis=-1))
            return np.asarray(X @ E if right else E @ X, dtype=np.float64)
        R, t = X[..., :3, :3], X[..., :3, 3]
        dR = to_rotation(r, conv.rotation)
        R2 = R @ dR if right else dR @ R
        du = np.einsum("...ij,...j->...i", R, u) if frame == "body" else u
        out = np.zeros(np.broadcast_shapes(X.shape, (*d.shape[:-1], 4, 4)))
        out[..., :3, :3] = R2
        out[..., :3, 3] = t + du
        out[..., 3, 3] = 1.0
        return out

    def local(self, conv: Convention, X: FloatArray, Y: FloatArray) -> FloatArray:
        """Inverse of :meth:`retract` (principal branch)."""
        if conv.is_euler:
            return self._tensors.local(conv, X, Y)
        right = conv.side == "right"
        if _is_so3(X):
            Xt = np.swapaxes(X, -1, -2)
            return from_rotation(Xt @ Y if right else Y @ Xt, conv.rotation)
        frame = self.group.split_frame(conv.chart)
        if frame is None:
            Xi = U.se3_inverse(X)
            xi = U.se3_log(Xi @ Y if right else Y @ Xi)
            return _join(conv, xi[..., :3], xi[..., 3:])
        R, t = X[..., :3, :3], X[..., :3, 3]
        Rt = np.swapaxes(R, -1, -2)
        RY, tY = Y[..., :3, :3], Y[..., :3, 3]
        r = from_rotation(Rt @ RY if right else RY @ Rt, conv.rotation)
        dt = tY - t
        u = np.einsum("...ij,...j->...i", Rt, dt) if frame == "body" else dt
        return _join(conv, r, u)

    def local_jacobian(self, conv: Convention, X: FloatArray, Y: FloatArray) -> FloatArray:
        """``∂ local(X, retract(Y, δ)) / ∂δ`` at 0, closed form."""
        s = conv.rotation_scale
        right = conv.side == "right"
        frame = self.group.split_frame(conv.chart)
        if conv.is_euler:  # local(X, retract(Y, δ)) = e(Y) + δ − e(X): the identity (blocks)
            return self._tensors.local_jacobian(conv, X, Y)
        if _is_so3(X):
            Xt = np.swapaxes(X, -1, -2)
            dR = Xt @ Y if right else Y @ Xt
            return np.asarray(s * d_from_rotation(dR, conv.rotation, conv.side), dtype=np.float64)
        if frame is None:
            if right:
                J = U.se3_jl_inv(-U.se3_log(U.se3_inverse(X) @ Y))  # Jr⁻¹(ξ) = Jl⁻¹(−ξ)
            else:
                J = U.se3_jl_inv(U.se3_log(Y @ U.se3_inverse(X)))
        else:
            RX, RY = X[..., :3, :3], Y[..., :3, :3]
            RXt = np.swapaxes(RX, -1, -2)
            dR = RXt @ RY if right else RY @ RXt
            J = np.zeros((*np.broadcast_shapes(X.shape, Y.shape)[:-2], 6, 6))
            J[..., :3, :3] = s * d_from_rotation(dR, conv.rotation, conv.side)
            J[..., 3:, 3:] = RXt @ RY if frame == "body" else np.eye(3)
        if conv.order == "trans_first":
            J = np.concatenate([J[..., 3:, :], J[..., :3, :]], axis=-2)
            J = np.concatenate([J[..., :, 3:], J[..., :, :3]], axis=-1)
        return np.asarray(J, dtype=np.float64)

    def for_tensors(self) -> Engine:
        """:class:`SE3TensorEngine`: this group's conventions on torch/JAX arrays."""
        return self._tensors

    # ----------------------------------------------------------------- first-order maps
    @staticmethod
    def _euler_base(conv: Convention) -> tuple[Convention, slice]:
        """Return the rotation-vector twin (right, ``exp``) and where its rotation entries sit."""
        base = replace(conv, name=f"{conv.name}_exp", side="right", rotation="exp")
        return base, slice(0, 3) if conv.order == "rot_first" else slice(3, 6)

    def to_canonical(self, conv: Convention, X: FloatArray) -> FloatArray:
        """Closed-form grid (Euler: the rotation-vector twin's, times ``W⁻¹``)."""
        if conv.is_euler:
            return self._tensors.to_canonical(conv, X)
        return canonical_tangent_map(conv, "to", X.shape[-1] == 3)(X)

    def from_canonical(self, conv: Convention, X: FloatArray) -> FloatArray:
        """Inverse of :meth:`to_canonical` (closed form, no matrix inversion)."""
        if conv.is_euler:
            return self._tensors.from_canonical(conv, X)
        return canonical_tangent_map(conv, "from", X.shape[-1] == 3)(X)


def _so3_twin(conv: Convention) -> Convention:
    """Return the SO(3) convention an SE(3) one is on a bare rotation (same side, coordinates)."""
    twin = _TWINS.get(conv._key)
    if twin is None:
        twin = replace(conv, name=f"{conv.name}_so3", group="so3", stores="pose")
        _TWINS[conv._key] = twin
    return twin


_TWINS: dict[tuple[str, str, str, str], Convention] = {}


class SE3TensorEngine(Engine):
    """SE(3)/SO(3) conventions on torch and JAX arrays (and the Euler-angle maps on every array).

    The record-driven formulas (array-generic) for retractions and local coordinates, the
    closed-form grids of :mod:`~liebridge.conventions.tangent_maps` for the first-order maps (the
    same maps, block by block: no dense product, no permutation pass), and, as on numpy, an
    SE(3) convention given a rotation ``(..., 3, 3)`` acting as its SO(3) part.
    """

    euler = True
    embed = False
    rotations_3d = True

    def __init__(self, fast: SE3Engine) -> None:
        self.fast = fast

    def check(self, conv: Convention, g: Group) -> None:
        """SE(3)'s own rules (:meth:`SE3Engine.check`)."""
        self.fast.check(conv, g)

    def dim(self, conv: Convention, X: Any = None) -> int:
        """6 for a pose, 3 for a rotation."""
        return self.fast.dim(conv, X)

    def element(self, conv: Convention, X: Any, name: str) -> FloatArray:
        """Validate a pose or a rotation on its device (:func:`group_input`)."""
        return self.fast.element(conv, X, name)

    def pair(self, conv: Convention, X: Any, Y: Any) -> tuple[FloatArray, FloatArray]:
        """Two elements of the same kind with broadcastable batch shapes."""
        return self.fast.pair(conv, X, Y)

    def increment(self, conv: Convention, d: Any, so3: bool, name: str) -> FloatArray:
        """Validate an increment (:meth:`SE3Engine.increment`)."""
        return self.fast.increment(conv, d, so3, name)

    def _conv(self, conv: Convention, X: FloatArray) -> Convention:
        return _so3_twin(conv) if _is_so3(X) and not self.fast.rotation_only else conv

    def retract(self, conv: Convention, X: FloatArray, d: FloatArray) -> FloatArray:
        """Retract by the record-driven formula (Euler angles: ``E(e(R) + r)``, as numpy's)."""
        if conv.is_euler:
            if _is_so3(X):
                return euler_retract(X, d, conv.rotation)
            r, u = _split(conv, d)
            R, t = X[..., :3, :3], X[..., :3, 3]
            du = arrays.matvec(R, u) if self.fast.group.split_frame(conv.chart) == "body" else u
            return U.se3_assemble(euler_retract(R, r, conv.rotation), t + du)
        return RECORD_ENGINE.retract(self._conv(conv, X), X, d)

    def local(self, conv: Convention, X: FloatArray, Y: FloatArray) -> FloatArray:
        """Return the record-driven local coordinates (Euler angles: ``e(R_Y) − e(R_X)``)."""
        if conv.is_euler:
            if _is_so3(X):
                return euler_local(X, Y, conv.rotation)
            RX, dt = X[..., :3, :3], Y[..., :3, 3] - X[..., :3, 3]
            r = euler_local(RX, Y[..., :3, :3], conv.rotation)
            body = self.fast.group.split_frame(conv.chart) == "body"
            u = arrays.matvec(arrays.mT(RX), dt) if body else dt
            xp = arrays.namespace(r, u)
            batch = tuple(np.broadcast_shapes(tuple(r.shape[:-1]), tuple(u.shape[:-1])))
            r, u = xp.broadcast_to(r, (*batch, 3)), xp.broadcast_to(u, (*batch, 3))
            return arrays.concat([r, u] if conv.order == "rot_first" else [u, r], axis=-1)
        return RECORD_ENGINE.local(self._conv(conv, X), X, Y)

    def local_jacobian(self, conv: Convention, X: FloatArray, Y: FloatArray) -> FloatArray:
        """Return the record-driven ``∂ local(X, retract(Y, δ)) / ∂δ`` (Euler: ``I``, blocks)."""
        if conv.is_euler:
            matrix_to_euler(Y[..., :3, :3], conv.rotation, "Y")  # gimbal lock raises
            batch = tuple(np.broadcast_shapes(tuple(X.shape[:-2]), tuple(Y.shape[:-2])))
            ref = X if tuple(X.shape[:-2]) == batch else Y
            eye = arrays.eye(3, ref, batch)
            if _is_so3(X):
                return eye * 1.0
            body = self.fast.group.split_frame(conv.chart) == "body"
            tb = arrays.mT(X[..., :3, :3]) @ Y[..., :3, :3] if body else eye
            zero = arrays.zeros((*batch, 3, 3), ref)
            grid = (
                [[eye, zero], [zero, tb]]
                if conv.order == "rot_first"
                else [[tb, zero], [zero, eye]]
            )
            return arrays.blocks(grid)
        return RECORD_ENGINE.local_jacobian(self._conv(conv, X), X, Y)

    def _euler_D(self, conv: Convention, X: FloatArray, inverse: bool) -> FloatArray:
        """:meth:`SE3Engine._euler_D` on tensors: ``W⁻¹`` (``W``) on the rotation entries."""
        e = matrix_to_euler(X[..., :3, :3], conv.rotation, "X")
        B = (
            euler_rate_map(e, conv.rotation, "X")
            if inverse
            else euler_rate_map_inv(e, conv.rotation)
        )
        if _is_so3(X):
            return B
        batch = tuple(B.shape[:-2])
        eye, zero = arrays.eye(3, B, batch), arrays.zeros((*batch, 3, 3), B)
        grid = [[B, zero], [zero, eye]] if conv.order == "rot_first" else [[eye, zero], [zero, B]]
        return arrays.blocks(grid)

    def to_canonical(self, conv: Convention, X: FloatArray) -> FloatArray:
        """Return the closed-form grid's map (Euler: the rotation-vector twin's, times ``W⁻¹``)."""
        if conv.is_euler:
            base, _ = SE3Engine._euler_base(conv)
            M = canonical_tangent_map(base, "to", _is_so3(X))(X)
            return M @ self._euler_D(conv, X, False)
        return canonical_tangent_map(conv, "to", _is_so3(X))(X)

    def from_canonical(self, conv: Convention, X: FloatArray) -> FloatArray:
        """Inverse of :meth:`to_canonical`."""
        if conv.is_euler:
            base, _ = SE3Engine._euler_base(conv)
            M = canonical_tangent_map(base, "from", _is_so3(X))(X)
            return self._euler_D(conv, X, True) @ M
        return canonical_tangent_map(conv, "from", _is_so3(X))(X)


register_fast(se3.GROUP, SE3Engine(se3.GROUP))
register_fast(so3.GROUP, SE3Engine(so3.GROUP))
