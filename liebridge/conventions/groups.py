"""The record-driven convention formulas: one code path for every registered group.

A group is described by its record (:class:`liebridge.lie.Group`: dimension, matrix size, where
the rotation, the translation-like vectors and the scale sit in the canonical tangent, and the
unchecked kernels). Every operation of a :class:`~liebridge.conventions.Convention` is written
once here, in terms of that record:

* coupled chart (``chart`` = the group's name): ``X·Exp(P d)`` / ``Exp(P d)·X``;
* split charts (``split_body``/``split_world``): rotation ``R·ΔR`` / ``ΔR·R``, each vector
  ``t + A·u`` (body; ``A`` the linear part of ``X``: ``R``, or ``sR`` for Sim(3)) or ``t + u``
  (world), scale ``s·e^λ``;

where ``P`` permutes the convention's order into the canonical (GTSAM) order and an optional
embedding picks the group's coordinates out of a longer vector (``ros_pose2``). The first-order
maps are closed form (see ``docs/design-groups.md`` §3). SE(3)/SO(3) register a fast
implementation of the same formulas (:mod:`~liebridge.conventions.se3_engine`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .. import arrays
from .._validate import FloatArray
from ..lie import Group
from ..lie import group as group_record
from ..lie import unchecked as U
from .rotation_coords import d_from_rotation, from_rotation, to_rotation

if TYPE_CHECKING:
    from .convention import Convention


def _rec(conv: Convention) -> Group:
    return group_record(conv.group)


# ----------------------------------------------------------------------------- element pieces
def _parts(g: Group, X: FloatArray) -> tuple[FloatArray, FloatArray, list[FloatArray], FloatArray]:
    """``(R, A, vectors, s)``: rotation, linear part ``A = sR``, vector columns, scale.

    The linear part is the top-left ``k × k`` block, ``k = matrix − len(cols)`` (the whole matrix
    for a rotation group); a group without rotation has ``R = A = I``.
    """
    k = g.matrix - len(g.cols)
    A = X[..., :k, :k]
    scale = g.kernels.scale
    s = scale(X) if scale is not None else 1.0 + 0.0 * X[..., 0, 0]
    R = A / s[..., None, None] if scale is not None else A
    vecs = [X[..., :k, c] for c in g.cols]
    return R, A, vecs, s


def _assemble(g: Group, R: FloatArray, vecs: list[FloatArray], s: FloatArray) -> FloatArray:
    if not g.cols:  # a rotation group: the element is the rotation
        return R * 1.0 if arrays.is_foreign(R) else np.array(R, dtype=np.float64)
    k = R.shape[-1]
    A = s[..., None, None] * R if g.scale is not None else R
    if arrays.any_foreign(R, *vecs):  # the columns in order, then the constant rows
        xp = arrays.namespace(R, *vecs)
        if list(g.cols) != list(range(k, g.matrix)):
            raise TypeError(f"{g.name}: vector columns out of order run on numpy arrays only")
        top = xp.concat(
            [A] + [xp.broadcast_to(x[..., None], (*A.shape[:-1], 1)) for x in vecs], axis=-1
        )
        bottom = arrays.like(np.eye(g.matrix)[k:], top)
        batch = tuple(top.shape[:-2])
        return xp.concat([top, xp.broadcast_to(bottom, (*batch, *bottom.shape))], axis=-2)
    shape = np.broadcast_shapes(R.shape[:-2], np.shape(s), *(x.shape[:-1] for x in vecs))
    out = np.zeros((*shape, g.matrix, g.matrix))
    out[..., :k, :k] = A
    for c, x in zip(g.cols, vecs, strict=True):
        out[..., :k, c] = x
    for j in range(k, g.matrix):
        out[..., j, j] = 1.0
    return out


def _block_diag(g: Group, blocks: dict[int, FloatArray | float], ref: FloatArray) -> FloatArray:
    """Return the ``dim × dim`` block-diagonal matrix of the canonical tangent's slots.

    ``blocks`` maps each slot's start (rotation, vectors, scale) to its block (a number for a
    1-wide slot); the batch shape is ``ref``'s (an element).
    """
    slots = sorted(_slots(g), key=lambda sl: sl.start)
    batch = tuple(ref.shape[:-2])
    if not arrays.is_foreign(ref):
        J = np.zeros((*batch, g.dim, g.dim))
        for sl in slots:
            J[..., sl, sl] = blocks[sl.start]  # (a 1-wide slot: a number or a batch)
        return J
    xp = arrays.namespace(ref)
    grid = []
    for si in slots:
        row = []
        for sj in slots:
            ni, nj = si.stop - si.start, sj.stop - sj.start
            if si is sj:
                b: Any = blocks[si.start]
                b = arrays.like(b, ref) if not arrays.is_foreign(b) else b
                b = (
                    xp.broadcast_to(b, (*batch, ni, nj))
                    if b.ndim >= 2
                    else b * arrays.eye(ni, ref, batch)
                )
            else:
                b = arrays.zeros((*batch, ni, nj), ref)
            row.append(b)
        grid.append(row)
    return arrays.blocks(grid)


def _slots(g: Group) -> list[slice]:
    """Return the canonical tangent's slots: rotation, each vector, scale (where present)."""
    out = [g.rot] if g.rot is not None else []
    out += list(g.vecs)
    if g.scale is not None:
        out.append(slice(g.scale, g.scale + 1))
    return out


def _concat_slots(g: Group, parts: dict[int, FloatArray]) -> FloatArray:
    """Concatenate per-slot tangent parts (keyed by slot start) in canonical order."""
    xp = arrays.namespace(*parts.values())
    ordered = [parts[k] for k in sorted(parts)]
    if xp is np:
        return np.concatenate(np.broadcast_arrays(*ordered), axis=-1)
    batch = tuple(np.broadcast_shapes(*(tuple(p.shape[:-1]) for p in ordered)))
    return xp.concat([xp.broadcast_to(p, (*batch, p.shape[-1])) for p in ordered], axis=-1)


def _rot_inc(g: Group, r: FloatArray, kind: str) -> FloatArray:
    return U.so2_exp(r) if g.rot_dim == 1 else to_rotation(r, kind)


def _rot_coords(g: Group, dR: FloatArray, kind: str) -> FloatArray:
    return U.so2_log(dR) if g.rot_dim == 1 else from_rotation(dR, kind)


def _mv(A: FloatArray, x: FloatArray) -> FloatArray:
    return arrays.matvec(A, x)


def _solve(A: FloatArray, x: FloatArray) -> FloatArray:
    xp = arrays.namespace(A, x)
    if xp is np:
        return np.asarray(np.linalg.solve(A, x[..., None])[..., 0], dtype=np.float64)
    return xp.linalg.solve(A, x[..., None])[..., 0]


def _out(x: FloatArray) -> FloatArray:
    """Return a numpy result as float64, a torch/JAX result as it is."""
    return x if arrays.is_foreign(x) else np.asarray(x, dtype=np.float64)


# ----------------------------------------------------------------------------- tangent layout
def to_internal(conv: Convention, d: FloatArray) -> FloatArray:
    """Convention tangent (possibly embedded) → canonical-order tangent ``(..., dim)``."""
    g = _rec(conv)
    if conv.embed is not None:
        d = d[..., list(conv.embed.index)]
    if arrays.is_foreign(d):  # out[perm] = d  ⇔  out = d[perm⁻¹]
        return d[..., [int(i) for i in np.argsort(g.perm(conv.order))]]
    out = np.empty(d.shape)
    out[..., g.perm(conv.order)] = d
    return out


def from_internal(conv: Convention, xi: FloatArray) -> FloatArray:
    """Canonical-order tangent → the convention's tangent (zeros outside an embedding)."""
    g = _rec(conv)
    d = xi[..., [int(i) for i in g.perm(conv.order)]]
    if conv.embed is None:
        return _out(d)
    if arrays.is_foreign(d):  # a zero column appended, then gathered: no in-place write
        where = {j: k for k, j in enumerate(conv.embed.index)}
        ext = arrays.concat([d, arrays.zeros((*d.shape[:-1], 1), d)], -1)
        return ext[..., [where.get(j, len(where)) for j in range(conv.embed.size)]]
    out = np.zeros((*d.shape[:-1], conv.embed.size))
    out[..., list(conv.embed.index)] = d
    return out


def selection(conv: Convention) -> FloatArray:
    """``S`` with ``ξ_canonical-order = S d`` for the layout alone (permutation and embedding)."""
    g = _rec(conv)
    n = conv.embed.size if conv.embed is not None else g.dim
    S = np.zeros((g.dim, n))
    cols = list(conv.embed.index) if conv.embed is not None else list(range(g.dim))
    S[g.perm(conv.order), cols] = 1.0
    return S


def is_coupled(conv: Convention) -> bool:
    """Whether the convention uses the group's own exponential (not a split chart)."""
    return conv.chart == _rec(conv).coupled_chart


def _body(conv: Convention) -> bool:
    """Whether a split chart adds its vector increments in the body frame."""
    return _rec(conv).split_frame(conv.chart) == "body"


# ----------------------------------------------------------------------------- retract / local
def retract(conv: Convention, X: FloatArray, d: FloatArray) -> FloatArray:
    """``conv.retract(X, d)`` for any registered group (validated inputs)."""
    g = _rec(conv)
    xi = to_internal(conv, d)
    right = conv.side == "right"
    if is_coupled(conv):
        E = g.kernels.exp(xi)
        return _out(X @ E if right else E @ X)
    R, A, vecs, s = _parts(g, X)
    dR = _rot_inc(g, xi[..., g.rot], conv.rotation)
    R2 = R @ dR if right else dR @ R
    body = _body(conv)
    new = [
        t + (_mv(A, xi[..., sl]) if body else xi[..., sl])
        for t, sl in zip(vecs, g.vecs, strict=True)
    ]
    s2 = s * arrays.namespace(xi).exp(xi[..., g.scale]) if g.scale is not None else s
    return _assemble(g, R2, new, _out(s2))


def local(conv: Convention, X: FloatArray, Y: FloatArray) -> FloatArray:
    """``conv.local(X, Y)``: the ``d`` with ``retract(X, d) == Y`` (principal branch)."""
    g = _rec(conv)
    right = conv.side == "right"
    if is_coupled(conv):
        Xi = g.kernels.inverse(X)
        return from_internal(conv, g.kernels.log(Xi @ Y if right else Y @ Xi))
    RX, AX, tX, sX = _parts(g, X)
    RY, _, tY, sY = _parts(g, Y)
    RXt = arrays.mT(RX)
    parts: dict[int, FloatArray] = {}
    if g.rot is not None:
        parts[g.rot.start] = _rot_coords(g, RXt @ RY if right else RY @ RXt, conv.rotation)
    body = _body(conv)
    for a, b, sl in zip(tX, tY, g.vecs, strict=True):
        parts[sl.start] = _solve(AX, b - a) if body else b - a
    if g.scale is not None:
        parts[g.scale] = arrays.namespace(sY).log(sY / sX)[..., None]
    return from_internal(conv, _concat_slots(g, parts))


# ----------------------------------------------------------------------------- first-order maps
def _core_to(conv: Convention, X: FloatArray, inverse: bool) -> FloatArray:
    """Return ``K`` (``inverse``: ``K⁻¹``) with ``ξ = K ξ_c``, closed form.

    ``ξ_c`` is the convention's increment in canonical order.
    """
    g = _rec(conv)
    right = conv.side == "right"
    shape = tuple(X.shape[:-2])
    if is_coupled(conv):
        if right:
            return _out(arrays.eye(g.dim, X, shape) * 1.0)
        return g.kernels.adjoint(X) if inverse else g.kernels.adjoint(g.kernels.inverse(X))
    R, A, _, _ = _parts(g, X)
    s = conv.rotation_scale
    blocks: dict[int, FloatArray | float] = {}
    if g.rot is not None:
        if g.rot_dim == 1:
            blocks[g.rot.start] = 1.0 / s if inverse else s
        elif right:
            blocks[g.rot.start] = arrays.eye(3, X) * (1.0 / s if inverse else s)
        else:
            blocks[g.rot.start] = R / s if inverse else s * arrays.mT(R)
    if _body(conv):
        blk: FloatArray = arrays.eye(A.shape[-1], X, tuple(A.shape[:-2]))
    elif inverse:
        blk = A
    else:
        xp = arrays.namespace(A)
        blk = np.asarray(np.linalg.inv(A), dtype=np.float64) if xp is np else xp.linalg.inv(A)
    for sl in g.vecs:
        blocks[sl.start] = blk
    if g.scale is not None:
        blocks[g.scale] = 1.0
    return _block_diag(g, blocks, X)


def to_canonical(conv: Convention, X: FloatArray) -> FloatArray:
    """Return ``M``, ``ξ_gtsam = M d``: the derivative of ``gtsam.local(X, conv.retract(X, d))``."""
    K = _core_to(conv, X, False)
    if conv.embed is None:  # K·S with S a permutation: its columns, gathered
        return _out(K[..., :, [int(i) for i in _rec(conv).perm(conv.order)]])
    return _out(K @ _selection_like(conv, X))


def from_canonical(conv: Convention, X: FloatArray) -> FloatArray:
    """Return ``M``, ``d = M ξ_gtsam``: the inverse of :func:`to_canonical`.

    For an embedding it is a right inverse: the extra coordinates are 0.
    """
    K = _core_to(conv, X, True)
    if conv.embed is None:  # Sᵀ·K: its rows, gathered
        return _out(K[..., [int(i) for i in _rec(conv).perm(conv.order)], :])
    return _out(arrays.mT(_selection_like(conv, X)) @ K)


def is_canonical(conv: Convention) -> bool:
    """Whether ``conv``'s tangent is the canonical one (its maps to and from it are ``I``)."""
    g = _rec(conv)
    return (
        conv.stores == "pose"
        and is_coupled(conv)
        and conv.side == "right"
        and conv.embed is None
        and conv.rotation_scale == 1.0
        and [int(i) for i in g.perm(conv.order)] == list(range(g.dim))
    )


def _selection_like(conv: Convention, X: FloatArray) -> FloatArray:
    """:func:`selection` in ``X``'s array type."""
    S = selection(conv)
    return arrays.like(S, X) if arrays.is_foreign(X) else S


def local_jacobian(conv: Convention, X: FloatArray, Y: FloatArray) -> FloatArray:
    """``∂ local(X, retract(Y, δ)) / ∂δ`` at 0 in the convention's own chart, closed form."""
    g = _rec(conv)
    right = conv.side == "right"
    S = _selection_like(conv, X)
    St = arrays.mT(S)
    if is_coupled(conv):
        Xi = g.kernels.inverse(X)
        J = (
            g.kernels.jr_inv(g.kernels.log(Xi @ Y))
            if right
            else g.kernels.jl_inv(g.kernels.log(Y @ Xi))
        )
        return _out(St @ J @ S)
    RX, AX, _, _ = _parts(g, X)
    RY, AY, _, _ = _parts(g, Y)
    xp = arrays.namespace(X, Y)
    ref = X if X.ndim >= Y.ndim else Y
    blocks: dict[int, FloatArray | float] = {}
    if g.rot is not None:
        if g.rot_dim == 1:
            blocks[g.rot.start] = 1.0
        else:
            RXt = arrays.mT(RX)
            dR = RXt @ RY if right else RY @ RXt
            blocks[g.rot.start] = conv.rotation_scale * d_from_rotation(
                dR, conv.rotation, conv.side
            )
    blk: Any
    if _body(conv):
        blk = np.linalg.solve(AX, AY) if xp is np else xp.linalg.solve(AX, AY)
    else:
        blk = arrays.eye(AX.shape[-1], ref)
    for sl in g.vecs:
        blocks[sl.start] = blk
    if g.scale is not None:
        blocks[g.scale] = 1.0
    shape = tuple(np.broadcast_shapes(tuple(X.shape[:-2]), tuple(Y.shape[:-2])))
    ref = (
        ref
        if tuple(ref.shape[:-2]) == shape
        else ref[..., :1, :1] * arrays.zeros((*shape, 1, 1), ref)
    )
    return _out(St @ _block_diag(g, blocks, ref) @ S)
