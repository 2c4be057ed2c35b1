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
    how ``r`` becomes a rotation: see :mod:`liebridge.conventions.rotation_coords`.
``quat_order``
    how the library stores quaternions (``wxyz`` or ``xyzw``); it does not enter the retraction.

Canonical (GTSAM) is ``right, rot_first, se3, exp``. ``local(X, retract(X, d)) == d`` within the
chart's domain (``‖ω‖ < π``; ``‖r‖ < 1`` for ``quat_vec``), and the first-order maps
:meth:`Convention.to_canonical` / :meth:`Convention.from_canonical` are closed form.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from .. import _validate as v
from .._validate import FloatArray
from ..lie import unchecked as U
from .rotation_coords import (
    FIRST_ORDER_SCALE,
    ROTATION_COORDS,
    d_from_rotation,
    from_rotation,
    to_rotation,
)

Side = Literal["right", "left"]
Order = Literal["rot_first", "trans_first"]
Chart = Literal["se3", "so3xr3_body", "so3xr3_world"]
SIDES = ("right", "left")
ORDERS = ("rot_first", "trans_first")
CHARTS = ("se3", "so3xr3_body", "so3xr3_world")
QUAT_ORDERS = ("wxyz", "xyzw")


def _check_field(name: str, value: str, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise ValueError(f"Convention.{name}: expected one of {allowed}, got {value!r}")


def _is_rotation(X: FloatArray) -> bool:
    return X.shape[-2:] == (3, 3)


def group_input(X: Any, name: str = "X") -> FloatArray:
    """Validate ``X`` as a pose ``(..., 4, 4)`` or a rotation ``(..., 3, 3)``."""
    arr = v.as_float_array(X, name)
    shape = arr.shape[-2:]
    if shape == (4, 4):
        return v.checked_pose(arr, name)
    if shape == (3, 3):
        return v.checked_rotation(arr, name)
    raise ValueError(
        f"{name}: expected a pose (..., 4, 4) or a rotation (..., 3, 3), got {arr.shape}"
    )


def _group_pair(X: Any, Y: Any) -> tuple[FloatArray, FloatArray]:
    """Validate two group elements of the same kind with broadcastable batch shapes."""
    X = group_input(X)
    Y = group_input(Y, "Y")
    if X.shape[-2:] != Y.shape[-2:]:
        raise ValueError(f"Y: shape {Y.shape} does not match X {X.shape}")
    v.batch_shape(("X", X.shape[:-2]), ("Y", Y.shape[:-2]))
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
    _key: tuple[str, str, str, str] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        _check_field("side", self.side, SIDES)
        _check_field("order", self.order, ORDERS)
        _check_field("chart", self.chart, CHARTS)
        _check_field("rotation", self.rotation, ROTATION_COORDS)
        _check_field("quat_order", self.quat_order, QUAT_ORDERS)
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
    def rotation_scale(self) -> float:
        """First-order ``dω/dr`` of the rotation coordinates (2 for half angles, else 1)."""
        return FIRST_ORDER_SCALE[self.rotation]

    def describe(self) -> str:
        """One line: name and fields."""
        return (
            f"{self.name}: side={self.side}, order={self.order}, chart={self.chart}, "
            f"rotation={self.rotation}, quat_order={self.quat_order}"
        )

    # ----------------------------------------------------------------- retraction
    def _increment(self, d: Any, rotation: bool, name: str = "d") -> FloatArray:
        """Validate an increment in this convention (rotation part bounded, see ``v.tangent``)."""
        if rotation:
            return v.tangent(d, name, 3)
        return v.tangent(d, name, 6, slice(0, 3) if self.order == "rot_first" else slice(3, 6))

    def _split(self, d: FloatArray) -> tuple[FloatArray, FloatArray]:
        if self.order == "rot_first":
            return d[..., :3], d[..., 3:]
        return d[..., 3:], d[..., :3]

    def _join(self, r: FloatArray, u: FloatArray) -> FloatArray:
        parts = (r, u) if self.order == "rot_first" else (u, r)
        return np.concatenate(np.broadcast_arrays(*parts), axis=-1)

    def _retract(self, X: FloatArray, d: FloatArray) -> FloatArray:
        if _is_rotation(X):
            dR = to_rotation(d, self.rotation)
            return np.asarray(X @ dR if self.side == "right" else dR @ X, dtype=np.float64)
        r, u = self._split(d)
        if self.chart == "se3":
            E = U.se3_exp(np.concatenate([r, u], axis=-1))
            return np.asarray(X @ E if self.side == "right" else E @ X, dtype=np.float64)
        R, t = X[..., :3, :3], X[..., :3, 3]
        dR = to_rotation(r, self.rotation)
        R2 = R @ dR if self.side == "right" else dR @ R
        du = np.einsum("...ij,...j->...i", R, u) if self.chart == "so3xr3_body" else u
        out = np.zeros(np.broadcast_shapes(X.shape, (*d.shape[:-1], 4, 4)))
        out[..., :3, :3] = R2
        out[..., :3, 3] = t + du
        out[..., 3, 3] = 1.0
        return out

    def _local(self, X: FloatArray, Y: FloatArray) -> FloatArray:
        if _is_rotation(X):
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
        X = group_input(X)
        d = self._increment(d, _is_rotation(X))
        v.batch_shape(("X", X.shape[:-2]), ("d", d.shape[:-1]))
        return v.finite_output(self._retract(X, d), f"{self.name}.retract")

    def local(self, X: Any, Y: Any) -> FloatArray:
        """Inverse of :meth:`retract`: the ``d`` with ``retract(X, d) == Y`` (principal branch)."""
        X, Y = _group_pair(X, Y)
        return v.finite_output(self._local(X, Y), f"{self.name}.local")

    def _local_jacobian(self, X: FloatArray, Y: FloatArray) -> FloatArray:
        s = self.rotation_scale
        if _is_rotation(X):
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
        X, Y = _group_pair(X, Y)
        return v.finite_output(self._local_jacobian(X, Y), f"{self.name}.local_jacobian")

    # ----------------------------------------------------------------- first-order maps
    def _to_canonical(self, X: FloatArray) -> FloatArray:
        return _own_map(self, "to", X.shape[-1] == 3)(X)

    def _from_canonical(self, X: FloatArray) -> FloatArray:
        return _own_map(self, "from", X.shape[-1] == 3)(X)

    def to_canonical(self, X: Any) -> FloatArray:
        """First-order map ``M``, ``ξ_gtsam = M d`` at ``X``; shape (..., 6, 6) or (..., 3, 3).

        It is the derivative at ``d = 0`` of ``GTSAM.local(X, self.retract(X, d))``.
        """
        return v.finite_output(self._to_canonical(group_input(X)), f"{self.name}.to_canonical")

    def from_canonical(self, X: Any) -> FloatArray:
        """Inverse of :meth:`to_canonical` (closed form, no matrix inversion)."""
        out = self._from_canonical(group_input(X))
        return v.finite_output(out, f"{self.name}.from_canonical")


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


# --------------------------------------------------------------------- first-order maps as grids
# Every first-order map of the model is, 3×3 block by block, a combination of 0, I, R, Rᵀ, hat(t)·R
# (in Ad_X) and −Rᵀ·hat(t) = (hat(t)·R)ᵀ (in Ad_{X⁻¹}) with constant coefficients (the rotation
# scale), the blocks placed by the order: a *grid* of blocks, each a tuple of (primitive,
# coefficient) terms. The grid is the one description of the math; it is evaluated two ways:
#
# * small batches (one pose in a factor callback): as one product with a constant table. A pose map
#   is linear in the 48 products F(X) = (t, 1) ⊗ vec([R; 0]) (the last column of X is (t, 1): F
#   holds t_i·R_jk and R_jk, never t_i·t_j, which could overflow) and a constant; a rotation map in
#   vec(R) and a constant. So G(X) = F(X) @ K + K₀ with K, K₀ built once from the grid: a handful
#   of numpy calls.
# * large batches: block by block (views of R, one hat(t)·R), memory-bound instead of a dense
#   product that is mostly zeros.
#
# Composing with a constant map (a permutation, a scale) is done on the grid, once per pair.

_EPS = np.zeros((3, 3, 3))
_EPS[0, 1, 2] = _EPS[1, 2, 0] = _EPS[2, 0, 1] = 1.0
_EPS[0, 2, 1] = _EPS[2, 1, 0] = _EPS[1, 0, 2] = -1.0
_EYE3 = np.eye(3)
#: ``vec(hat(t)) = t @ _HAT`` (row-major)
_HAT = np.zeros((3, 9))
_HAT[2, 1] = _HAT[0, 5] = _HAT[1, 6] = -1.0
_HAT[1, 2] = _HAT[2, 3] = _HAT[0, 7] = 1.0
#: Largest batch (number of matrices) evaluated with the table product.
_TABLE_MAX_BATCH = 16

_Term = tuple[str, float]  # (primitive, coefficient); primitives: I R Rt tR mRtt
_Block = tuple[_Term, ...]  # a sum of terms; () is the zero block
_Grid = tuple[tuple[_Block, ...], ...]


def _block_entries(prim: str, r: int, c: int, rotation: bool) -> list[tuple[int, float]]:
    """Features and weights of entry ``(r, c)`` of a 3×3 block ``prim``."""
    one = 9 if rotation else 48  # the constant feature (the last)

    def lin(j: int, k: int) -> int:  # R_jk (pose: 1·R_jk)
        return 3 * j + k if rotation else 36 + 3 * j + k

    if prim == "I":
        return [(one, 1.0)] if r == c else []
    if prim == "R":
        return [(lin(r, c), 1.0)]
    if prim == "Rt":
        return [(lin(c, r), 1.0)]
    ks = range(3)
    if prim == "tR":  # (hat(t)·R)_rc = Σ_lk −ε_rlk t_k R_lc
        return [(12 * k + 3 * m + c, -_EPS[r, m, k]) for m in ks for k in ks if _EPS[r, m, k]]
    if prim == "mRtt":  # (−Rᵀ·hat(t))_rc = Σ_lk ε_lck t_k R_lr
        return [(12 * k + 3 * m + r, _EPS[m, c, k]) for m in ks for k in ks if _EPS[m, c, k]]
    raise AssertionError(prim)


def _grid_table(grid: _Grid, rotation: bool) -> FloatArray:
    """Build the table ``(features, n, n)`` of a grid."""
    n = 3 * len(grid)
    K = np.zeros((10 if rotation else 49, n, n))
    for bi, row in enumerate(grid):
        for bj, block in enumerate(row):
            for prim, coef in block:
                for r in range(3):
                    for c in range(3):
                        for f, w in _block_entries(prim, r, c, rotation):
                            K[f, 3 * bi + r, 3 * bj + c] += coef * w
    return K


def _hat_t_R(X: FloatArray) -> FloatArray:
    """``hat(t)·R`` of poses; ``vec(hat(t)) = t @ _HAT`` (one small product, then one more)."""
    t = X[..., :3, 3]
    return np.asarray((t @ _HAT).reshape((*t.shape[:-1], 3, 3)) @ X[..., :3, :3])


class _GridMap:
    """A first-order map ``X ↦ G(X)`` given by a grid (see the comment above)."""

    __slots__ = ("const", "grid", "kind", "n", "rotation", "table", "table_max_size")
    const: FloatArray | None
    table_max_size: int
    grid: _Grid
    kind: str
    n: int
    rotation: bool
    table: FloatArray

    def __init__(self, grid: _Grid, rotation: bool) -> None:
        self.grid = grid
        self.rotation = rotation
        self.table_max_size = _TABLE_MAX_BATCH * (9 if rotation else 16)
        K = _grid_table(grid, rotation)
        self.n = n = K.shape[-1]
        one = K.shape[0] - 1  # the constant feature
        used = np.flatnonzero(np.abs(K).reshape(K.shape[0], n * n).max(axis=1))
        self.const = K[one].copy() if K[one].any() else None
        if (used == one).all():  # also when nothing is used (a zero map)
            self.kind = "const"
            self.const = K[one].copy()
            self.table = np.zeros((0, n * n))
        elif rotation:  # vec(R) @ K (+ K₀)
            self.kind = "lin"
            self.table = K[:9].reshape(9, n * n).copy()
        elif used.min() >= 36:  # vec(X) @ K: R_jk is X_jk and the constant enters through X₃₃ = 1
            self.kind = "lin"
            K16 = np.zeros((4, 4, n * n))
            K16[:3, :3] = K[36:45].reshape(3, 3, n * n)
            K16[3, 3] = K[one].reshape(n * n)
            self.table = K16.reshape(16, n * n)
            self.const = None
        else:  # ((t, 1) ⊗ vec([R; 0])) @ K (+ K₀)
            self.kind = "bilin"
            self.table = K[:48].reshape(48, n * n).copy()

    @property
    def is_constant(self) -> bool:
        """Whether ``G`` does not depend on ``X``."""
        return self.kind == "const"

    def __call__(self, X: FloatArray) -> FloatArray:
        b = X.shape[:-2]
        n = self.n
        if self.kind == "const":
            out = np.empty((*b, n, n))
            out[...] = self.const
            return out
        if X.size > self.table_max_size:
            return self._blockwise(X)
        if self.kind == "bilin":  # X[..., :, 3:] is the column (t, 1), X[..., :, :3] is [R; 0]
            F = X[..., 3:, None] * X[..., None, :, :3]  # (..., 4, 4, 3), no copy of X
            G: FloatArray = (F.reshape((*b, 48)) @ self.table).reshape((*b, n, n))
        else:
            G = (X.reshape((*b, X.shape[-1] * X.shape[-1])) @ self.table).reshape((*b, n, n))
        if self.const is not None:
            G += self.const
        return G

    def _blockwise(self, X: FloatArray) -> FloatArray:
        out = np.empty((*X.shape[:-2], self.n, self.n))
        R = X if self.rotation else X[..., :3, :3]
        tR: FloatArray | None = None
        for bi, row in enumerate(self.grid):
            for bj, block in enumerate(row):
                dst = out[..., 3 * bi : 3 * bi + 3, 3 * bj : 3 * bj + 3]
                if not block:
                    dst[...] = 0.0
                for k, (prim, coef) in enumerate(block):
                    if prim == "I":
                        src: FloatArray = coef * _EYE3
                    else:
                        if prim == "R":
                            src = R
                        elif prim == "Rt":
                            src = R.swapaxes(-1, -2)
                        else:
                            tR = _hat_t_R(X) if tR is None else tR
                            src = tR if prim == "tR" else tR.swapaxes(-1, -2)
                        if coef != 1.0:
                            src = coef * src
                    if k == 0:
                        dst[...] = src
                    else:
                        dst += src
        return out


class _ProductMap:
    """``G(X) = A(X) @ B(X)`` for two maps that both depend on ``X``."""

    __slots__ = ("A", "B")

    def __init__(self, A: _GridMap, B: _GridMap) -> None:
        self.A, self.B = A, B

    def __call__(self, X: FloatArray) -> FloatArray:
        return np.asarray(self.A(X) @ self.B(X), dtype=np.float64)


def _add_term(terms: dict[str, float], prim: str, coef: float) -> None:
    terms[prim] = terms.get(prim, 0.0) + coef


def _compose(A: _GridMap, B: _GridMap) -> _GridMap | _ProductMap:
    """``X ↦ A(X) @ B(X)``, one grid when either factor is constant (``c·I`` blocks)."""
    if not (A.is_constant or B.is_constant):
        return _ProductMap(A, B)
    nb = len(A.grid)
    grid = []
    for i in range(nb):
        row = []
        for j in range(nb):
            terms: dict[str, float] = {}
            for k in range(nb):
                for pa, ca in A.grid[i][k]:
                    for pb, cb in B.grid[k][j]:
                        if pa == "I":
                            _add_term(terms, pb, ca * cb)
                        elif pb == "I":
                            _add_term(terms, pa, ca * cb)
                        else:  # cannot happen: one factor is constant
                            raise AssertionError((pa, pb))
            row.append(tuple((p, c) for p, c in terms.items() if c != 0.0))
        grid.append(tuple(row))
    return _GridMap(tuple(grid), A.rotation)


def _own_grid(conv: Convention, direction: str, rotation: bool) -> _Grid:
    """Grid of ``conv``'s map to (``"to"``) or from (``"from"``) the canonical tangent.

    ``to``: ``ξ = G d`` (rows ``(ω, v)``, columns the convention's ``(r, u)`` in its order);
    ``from``: ``d = G ξ``. Closed forms: side ``left`` brings ``Ad_{X⁻¹}`` / ``Ad_X`` for the SE(3)
    exponential and ``Rᵀ`` / ``R`` on the rotation block of the decoupled charts; a world-frame
    translation brings ``Rᵀ`` / ``R`` on the translation block; the rotation scale ``s`` multiplies
    the rotation columns (``to``) or divides the rotation rows (``from``); ``trans_first`` swaps the
    blocks.
    """
    to = direction == "to"
    s = conv.rotation_scale
    left = conv.side == "left"
    Rx = "Rt" if to else "R"
    if rotation:
        return (((((Rx if left else "I"), s if to else 1.0 / s),),),)
    eye: _Block = (("I", 1.0),)
    g: list[list[_Block]]
    if conv.chart == "se3":
        if left:
            g = [[((Rx, 1.0),), ()], [((("mRtt" if to else "tR"), 1.0),), ((Rx, 1.0),)]]
        else:
            g = [[eye, ()], [(), eye]]
    else:
        world = conv.chart == "so3xr3_world"
        g = [[((Rx, 1.0),) if left else eye, ()], [(), ((Rx, 1.0),) if world else eye]]
    if to:  # scale the rotation columns, then order the columns
        g = [[tuple((p, c * s) for p, c in row[0]), row[1]] for row in g]
        if conv.order == "trans_first":
            g = [[row[1], row[0]] for row in g]
    else:  # scale the rotation rows, then order the rows
        g[0] = [tuple((p, c / s) for p, c in block) for block in g[0]]
        if conv.order == "trans_first":
            g = [g[1], g[0]]
    return tuple(tuple(row) for row in g)


_Key = tuple[str, str, str, str]
_OWN_MAPS: dict[tuple[_Key, str, bool], _GridMap] = {}
_PAIR_MAPS: dict[tuple[_Key, _Key, bool], _GridMap | _ProductMap] = {}


def _own_map(conv: Convention, direction: str, rotation: bool) -> _GridMap:
    key = (conv._key, direction, rotation)
    m = _OWN_MAPS.get(key)
    if m is None:
        m = _OWN_MAPS[key] = _GridMap(_own_grid(conv, direction, rotation), rotation)
    return m


def pair_map(src: Convention, dst: Convention, rotation: bool) -> _GridMap | _ProductMap:
    """Return the map ``X ↦ dst.from_canonical(X) @ src.to_canonical(X)``, built once.

    Identical fields give the identity; a constant factor is folded into the other's grid, so
    most pairs cost one evaluation.
    """
    key = (src._key, dst._key, rotation)
    m = _PAIR_MAPS.get(key)
    if m is None:
        if src._key == dst._key:
            eye: _Block = (("I", 1.0),)
            grid: _Grid = ((eye,),) if rotation else ((eye, ()), ((), eye))
            m = _GridMap(grid, rotation)
        else:
            m = _compose(_own_map(dst, "from", rotation), _own_map(src, "to", rotation))
        _PAIR_MAPS[key] = m
    return m
