"""Tangent maps between conventions, in closed form: ``δ_dst = M(X) δ_src``.

A convention's tangent map to GTSAM's (canonical) tangent and back is, 3×3 block by block, a
combination of ``0, I, R, Rᵀ, hat(t)·R`` (in ``Ad_X``) and ``−Rᵀ·hat(t)`` (in ``Ad_{X⁻¹}``) with
constant coefficients (the rotation scale), the blocks placed by the order. This module builds
those maps once per convention (:func:`canonical_tangent_map`) and per pair
(:func:`pair_tangent_map`) and evaluates them batched; :func:`liebridge.conventions.tangent_map`
is the validated public entry point.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .. import arrays
from .._validate import FloatArray

if TYPE_CHECKING:
    from .convention import Convention

# --------------------------------------------------------------------- tangent maps as grids
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


def _block_entries(prim: str, r: int, c: int, so3: bool) -> list[tuple[int, float]]:
    """Features and weights of entry ``(r, c)`` of a 3×3 block ``prim``."""
    one = 9 if so3 else 48  # the constant feature (the last)

    def lin(j: int, k: int) -> int:  # R_jk (pose: 1·R_jk)
        return 3 * j + k if so3 else 36 + 3 * j + k

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


def _grid_table(grid: _Grid, so3: bool) -> FloatArray:
    """Build the table ``(features, n, n)`` of a grid."""
    n = 3 * len(grid)
    K = np.zeros((10 if so3 else 49, n, n))
    for bi, row in enumerate(grid):
        for bj, block in enumerate(row):
            for prim, coef in block:
                for r in range(3):
                    for c in range(3):
                        for f, w in _block_entries(prim, r, c, so3):
                            K[f, 3 * bi + r, 3 * bj + c] += coef * w
    return K


def _hat_t_R(X: FloatArray) -> FloatArray:
    """``hat(t)·R`` of poses; ``vec(hat(t)) = t @ _HAT`` (one small product, then one more).

    torch/JAX: column ``j`` is ``t × R[:, j]`` (the same products and sums, one cross product
    instead of assembling ``hat(t)`` and a batched 3×3 product).
    """
    t = X[..., :3, 3]
    if arrays.is_foreign(X):
        xp = arrays.namespace(X)
        Rt = arrays.mT(X[..., :3, :3])
        return arrays.mT(xp.linalg.cross(xp.broadcast_to(t[..., None, :], Rt.shape), Rt))
    return np.asarray((t @ _HAT).reshape((*t.shape[:-1], 3, 3)) @ X[..., :3, :3])


class _GridMap:
    """A tangent map ``X ↦ G(X)`` given by a grid (see the comment above)."""

    __slots__ = ("const", "grid", "kind", "n", "so3", "table", "table_max_size")
    const: FloatArray | None
    table_max_size: int
    grid: _Grid
    kind: str
    n: int
    so3: bool
    table: FloatArray

    def __init__(self, grid: _Grid, so3: bool) -> None:
        self.grid = grid
        self.so3 = so3
        self.table_max_size = _TABLE_MAX_BATCH * (9 if so3 else 16)
        K = _grid_table(grid, so3)
        self.n = n = K.shape[-1]
        one = K.shape[0] - 1  # the constant feature
        used = np.flatnonzero(np.abs(K).reshape(K.shape[0], n * n).max(axis=1))
        self.const = K[one].copy() if K[one].any() else None
        if (used == one).all():  # also when nothing is used (a zero map)
            self.kind = "const"
            self.const = K[one].copy()
            self.table = np.zeros((0, n * n))
        elif so3:  # vec(R) @ K (+ K₀)
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
        if arrays.is_foreign(X):
            return self._blocks_of(X)
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
        R = X if self.so3 else X[..., :3, :3]
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

    def _blocks_of(self, X: FloatArray) -> FloatArray:
        """:meth:`_blockwise` for torch/JAX: the blocks, then one assembly (no in-place write)."""
        b = tuple(X.shape[:-2])
        R = X if self.so3 else X[..., :3, :3]
        tR: FloatArray | None = None
        grid = []
        for row in self.grid:
            out_row = []
            for block in row:
                acc: FloatArray | None = None
                for prim, coef in block:
                    if prim == "I":
                        src: FloatArray = coef * arrays.eye(3, X, b)
                    else:
                        if prim == "R":
                            src = R
                        elif prim == "Rt":
                            src = arrays.mT(R)
                        else:
                            tR = _hat_t_R(X) if tR is None else tR
                            src = tR if prim == "tR" else arrays.mT(tR)
                        if coef != 1.0:
                            src = coef * src
                    acc = src if acc is None else acc + src
                out_row.append(arrays.zeros((*b, 3, 3), X) if acc is None else acc)
            grid.append(out_row)
        return arrays.blocks(grid)


class _ProductMap:
    """``G(X) = A(X) @ B(X)`` for two maps that both depend on ``X``."""

    __slots__ = ("A", "B")

    def __init__(self, A: _GridMap, B: _GridMap) -> None:
        self.A, self.B = A, B

    def __call__(self, X: FloatArray) -> FloatArray:
        M = self.A(X) @ self.B(X)
        return M if arrays.is_foreign(M) else np.asarray(M, dtype=np.float64)


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
    return _GridMap(tuple(grid), A.so3)


def _own_grid(conv: Convention, direction: str, so3: bool) -> _Grid:
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
    if so3:
        return (((((Rx if left else "I"), s if to else 1.0 / s),),),)
    eye: _Block = (("I", 1.0),)
    g: list[list[_Block]]
    frame = conv.record.split_frame(conv.chart)
    if frame is None:  # the SE(3) exponential
        if left:
            g = [[((Rx, 1.0),), ()], [((("mRtt" if to else "tR"), 1.0),), ((Rx, 1.0),)]]
        else:
            g = [[eye, ()], [(), eye]]
    else:
        world = frame == "world"
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


def canonical_tangent_map(conv: Convention, direction: str, so3: bool) -> _GridMap:
    """``conv``'s tangent map to (``"to"``: ``ξ = M d``) or from (``"from"``) GTSAM's (cached)."""
    key = (conv._key, direction, so3)
    m = _OWN_MAPS.get(key)
    if m is None:
        m = _OWN_MAPS[key] = _GridMap(_own_grid(conv, direction, so3), so3)
    return m


def pair_tangent_map(src: Convention, dst: Convention, so3: bool) -> _GridMap | _ProductMap:
    """Return the map ``X ↦ dst.from_canonical(X) @ src.to_canonical(X)``, built once.

    Identical fields give the identity; a constant factor is folded into the other's grid, so
    most pairs cost one evaluation.
    """
    key = (src._key, dst._key, so3)
    m = _PAIR_MAPS.get(key)
    if m is None:
        if src._key == dst._key:
            eye: _Block = (("I", 1.0),)
            grid: _Grid = ((eye,),) if so3 else ((eye, ()), ((), eye))
            m = _GridMap(grid, so3)
        else:
            m = _compose(
                canonical_tangent_map(dst, "from", so3), canonical_tangent_map(src, "to", so3)
            )
        _PAIR_MAPS[key] = m
    return m


#: Order of the primitives in :func:`pair_map_coefficients` (and in ``_convert_ext.c``).
PRIMITIVES = ("I", "R", "Rt", "tR", "mRtt")


def _grid_coefficients(m: _GridMap) -> FloatArray:
    """Return a grid as an array ``(blocks, blocks, 5)``: coefficients of :data:`PRIMITIVES`."""
    nb = len(m.grid)
    C = np.zeros((nb, nb, len(PRIMITIVES)))
    for bi, row in enumerate(m.grid):
        for bj, block in enumerate(row):
            for prim, coef in block:
                C[bi, bj, PRIMITIVES.index(prim)] += coef
    return C


def pair_map_coefficients(src: Convention, dst: Convention, so3: bool) -> tuple[FloatArray, ...]:
    """Return the pair map of :func:`pair_tangent_map` as coefficient grids (compiled kernel).

    Block ``(i, j)`` (3×3) of ``M`` is ``Σ_p C[i, j, p] · P_p(X)`` over the primitives
    ``I, R, Rᵀ, hat(t)·R, −Rᵀ·hat(t)`` (:data:`PRIMITIVES`). One grid, or two (``M = M₁(X) ·
    M₂(X)``) when neither factor is constant. ``_convert_ext.c`` evaluates them element by
    element.
    """
    m = pair_tangent_map(src, dst, so3)
    if isinstance(m, _ProductMap):
        return (_grid_coefficients(m.A), _grid_coefficients(m.B))
    return (_grid_coefficients(m),)
