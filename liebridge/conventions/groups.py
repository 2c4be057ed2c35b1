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

from typing import TYPE_CHECKING

import numpy as np

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
    s = scale(X) if scale is not None else np.ones(X.shape[:-2])
    R = A / s[..., None, None] if scale is not None else A
    vecs = [X[..., :k, c] for c in g.cols]
    return R, A, vecs, s


def _assemble(g: Group, R: FloatArray, vecs: list[FloatArray], s: FloatArray) -> FloatArray:
    if not g.cols:  # a rotation group: the element is the rotation
        return np.array(R, dtype=np.float64)
    k = R.shape[-1]
    shape = np.broadcast_shapes(R.shape[:-2], s.shape, *(x.shape[:-1] for x in vecs))
    out = np.zeros((*shape, g.matrix, g.matrix))
    out[..., :k, :k] = s[..., None, None] * R if g.scale is not None else R
    for c, x in zip(g.cols, vecs, strict=True):
        out[..., :k, c] = x
    for j in range(k, g.matrix):
        out[..., j, j] = 1.0
    return out


def _rot_inc(g: Group, r: FloatArray, kind: str) -> FloatArray:
    return U.so2_exp(r) if g.rot_dim == 1 else to_rotation(r, kind)


def _rot_coords(g: Group, dR: FloatArray, kind: str) -> FloatArray:
    return U.so2_log(dR) if g.rot_dim == 1 else from_rotation(dR, kind)


def _mv(A: FloatArray, x: FloatArray) -> FloatArray:
    return np.einsum("...ij,...j->...i", A, x)


def _solve(A: FloatArray, x: FloatArray) -> FloatArray:
    return np.asarray(np.linalg.solve(A, x[..., None])[..., 0], dtype=np.float64)


# ----------------------------------------------------------------------------- tangent layout
def to_internal(conv: Convention, d: FloatArray) -> FloatArray:
    """Convention tangent (possibly embedded) → canonical-order tangent ``(..., dim)``."""
    g = _rec(conv)
    if conv.embed is not None:
        d = d[..., list(conv.embed.index)]
    out = np.empty(d.shape)
    out[..., g.perm(conv.order)] = d
    return out


def from_internal(conv: Convention, xi: FloatArray) -> FloatArray:
    """Canonical-order tangent → the convention's tangent (zeros outside an embedding)."""
    g = _rec(conv)
    d = xi[..., g.perm(conv.order)]
    if conv.embed is None:
        return np.asarray(d, dtype=np.float64)
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
        return np.asarray(X @ E if right else E @ X, dtype=np.float64)
    R, A, vecs, s = _parts(g, X)
    dR = _rot_inc(g, xi[..., g.rot], conv.rotation)
    R2 = R @ dR if right else dR @ R
    body = _body(conv)
    new = [
        t + (_mv(A, xi[..., sl]) if body else xi[..., sl])
        for t, sl in zip(vecs, g.vecs, strict=True)
    ]
    s2 = s * np.exp(xi[..., g.scale]) if g.scale is not None else s
    return _assemble(g, R2, new, np.asarray(s2, dtype=np.float64))


def local(conv: Convention, X: FloatArray, Y: FloatArray) -> FloatArray:
    """``conv.local(X, Y)``: the ``d`` with ``retract(X, d) == Y`` (principal branch)."""
    g = _rec(conv)
    right = conv.side == "right"
    if is_coupled(conv):
        Xi = g.kernels.inverse(X)
        return from_internal(conv, g.kernels.log(Xi @ Y if right else Y @ Xi))
    RX, AX, tX, sX = _parts(g, X)
    RY, _, tY, sY = _parts(g, Y)
    RXt = np.swapaxes(RX, -1, -2)
    shape = np.broadcast_shapes(X.shape[:-2], Y.shape[:-2])
    xi = np.zeros((*shape, g.dim))
    xi[..., g.rot] = _rot_coords(g, RXt @ RY if right else RY @ RXt, conv.rotation)
    body = _body(conv)
    for a, b, sl in zip(tX, tY, g.vecs, strict=True):
        xi[..., sl] = _solve(AX, b - a) if body else b - a
    if g.scale is not None:
        xi[..., g.scale] = np.log(sY / sX)
    return from_internal(conv, xi)


# ----------------------------------------------------------------------------- first-order maps
def _core_to(conv: Convention, X: FloatArray, inverse: bool) -> FloatArray:
    """Return ``K`` (``inverse``: ``K⁻¹``) with ``ξ = K ξ_c``, closed form.

    ``ξ_c`` is the convention's increment in canonical order.
    """
    g = _rec(conv)
    right = conv.side == "right"
    shape = X.shape[:-2]
    if is_coupled(conv):
        if right:
            return np.broadcast_to(np.eye(g.dim), (*shape, g.dim, g.dim)).copy()
        return g.kernels.adjoint(X) if inverse else g.kernels.adjoint(g.kernels.inverse(X))
    R, A, _, _ = _parts(g, X)
    K = np.zeros((*shape, g.dim, g.dim))
    s = conv.rotation_scale
    rs = g.rot
    if g.rot_dim == 1:
        K[..., rs, rs] = 1.0 / s if inverse else s
    elif right:
        K[..., rs, rs] = np.eye(3) / s if inverse else s * np.eye(3)
    else:
        K[..., rs, rs] = R / s if inverse else s * np.swapaxes(R, -1, -2)
    body = _body(conv)
    if body:
        blk: FloatArray = np.broadcast_to(np.eye(A.shape[-1]), A.shape)
    else:
        blk = A if inverse else np.asarray(np.linalg.inv(A), dtype=np.float64)
    for sl in g.vecs:
        K[..., sl, sl] = blk
    if g.scale is not None:
        K[..., g.scale, g.scale] = 1.0
    return K


def to_canonical(conv: Convention, X: FloatArray) -> FloatArray:
    """Return ``M``, ``ξ_gtsam = M d``: the derivative of ``gtsam.local(X, conv.retract(X, d))``."""
    return np.asarray(_core_to(conv, X, False) @ selection(conv), dtype=np.float64)


def from_canonical(conv: Convention, X: FloatArray) -> FloatArray:
    """Return ``M``, ``d = M ξ_gtsam``: the inverse of :func:`to_canonical`.

    For an embedding it is a right inverse: the extra coordinates are 0.
    """
    return np.asarray(selection(conv).T @ _core_to(conv, X, True), dtype=np.float64)


def local_jacobian(conv: Convention, X: FloatArray, Y: FloatArray) -> FloatArray:
    """``∂ local(X, retract(Y, δ)) / ∂δ`` at 0 in the convention's own chart, closed form."""
    g = _rec(conv)
    right = conv.side == "right"
    S = selection(conv)
    if is_coupled(conv):
        Xi = g.kernels.inverse(X)
        J = (
            g.kernels.jr_inv(g.kernels.log(Xi @ Y))
            if right
            else g.kernels.jl_inv(g.kernels.log(Y @ Xi))
        )
        return np.asarray(S.T @ J @ S, dtype=np.float64)
    RX, AX, _, _ = _parts(g, X)
    RY, AY, _, _ = _parts(g, Y)
    shape = np.broadcast_shapes(X.shape[:-2], Y.shape[:-2])
    J = np.zeros((*shape, g.dim, g.dim))
    if g.rot_dim == 1:
        J[..., g.rot, g.rot] = 1.0
    else:
        RXt = np.swapaxes(RX, -1, -2)
        dR = RXt @ RY if right else RY @ RXt
        s = conv.rotation_scale
        J[..., g.rot, g.rot] = s * d_from_rotation(dR, conv.rotation, conv.side)
    blk = np.linalg.solve(AX, AY) if _body(conv) else np.eye(AX.shape[-1])
    for sl in g.vecs:
        J[..., sl, sl] = blk
    if g.scale is not None:
        J[..., g.scale, g.scale] = 1.0
    return np.asarray(S.T @ J @ S, dtype=np.float64)
