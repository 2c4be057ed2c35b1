"""The group-generic convention engine: one code path for SO(2), SE(2), Sim(3) and SE₂(3).

A group is described by a :class:`GroupSpec` (dimension, matrix size, where the rotation, the
translation-like vectors and the scale sit in the canonical tangent, and the kernel's unchecked
``exp/log/inverse/adjoint/jr_inv/jl_inv``). Every operation of a
:class:`~liebridge.conventions.Convention` of those groups is written once here, in terms of that
description:

* coupled chart (``chart`` = the group's name): ``X·Exp(P d)`` / ``Exp(P d)·X``;
* split charts (``split_body``/``split_world``): rotation ``R·ΔR`` / ``ΔR·R``, each vector
  ``t + A·u`` (body; ``A`` the linear part of ``X``: ``R``, or ``sR`` for Sim(3)) or ``t + u``
  (world), scale ``s·e^λ``;

where ``P`` permutes the convention's order into the canonical (GTSAM) order and an optional
embedding picks the group's coordinates out of a longer vector (``ros_pose2``). The first-order
maps are closed form (see ``docs/design-groups.md`` §3). SE(3)/SO(3) keep their own fast path
in :mod:`~liebridge.conventions.convention` and :mod:`~liebridge.conventions.tangent_maps`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .._validate import FloatArray
from ..lie import unchecked as U
from .rotation_coords import d_from_rotation, from_rotation, to_rotation

if TYPE_CHECKING:
    from .convention import Convention

Fn = Callable[[FloatArray], FloatArray]


@dataclass(frozen=True)
class GroupSpec:
    """What the engine needs to know about a group (canonical order = GTSAM's)."""

    name: str
    dim: int
    matrix: int
    rot: slice  # rotation coordinates in the canonical tangent
    vecs: tuple[slice, ...]  # translation-like blocks in the canonical tangent
    cols: tuple[int, ...]  # the matrix column holding each vector block
    scale: int | None  # index of the log-scale coordinate
    exp: Fn
    log: Fn
    inverse: Fn
    adjoint: Fn
    jr_inv: Fn
    jl_inv: Fn

    @property
    def rot_dim(self) -> int:
        """1 for planar rotations, 3 for spatial ones."""
        return self.rot.stop - self.rot.start

    def perm(self, order: str) -> np.ndarray:
        """Canonical index of each coordinate of a tangent in ``order``."""
        rot = list(range(self.rot.start, self.rot.stop))
        vec = [i for s in self.vecs for i in range(s.start, s.stop)]
        tail = [self.scale] if self.scale is not None else []
        return np.array((rot + vec if order == "rot_first" else vec + rot) + tail)


def _so2_jinv(w: FloatArray) -> FloatArray:
    return np.ones((*w.shape[:-1], 1, 1))


GROUPS: dict[str, GroupSpec] = {
    "so2": GroupSpec(
        "so2", 1, 2, slice(0, 1), (), (), None,
        U.so2_exp, U.so2_log, U.so2_inverse, U.so2_adjoint, _so2_jinv, _so2_jinv,
    ),
    "se2": GroupSpec(
        "se2", 3, 3, slice(2, 3), (slice(0, 2),), (2,), None,
        U.se2_exp, U.se2_log, U.se2_inverse, U.se2_adjoint, U.se2_jr_inv, U.se2_jl_inv,
    ),
    "sim3": GroupSpec(
        "sim3", 7, 4, slice(0, 3), (slice(3, 6),), (3,), 6,
        U.sim3_exp, U.sim3_log, U.sim3_inverse, U.sim3_adjoint, U.sim3_jr_inv, U.sim3_jl_inv,
    ),
    "se23": GroupSpec(
        "se23", 9, 5, slice(0, 3), (slice(3, 6), slice(6, 9)), (3, 4), None,
        U.se23_exp, U.se23_log, U.se23_inverse, U.se23_adjoint, U.se23_jr_inv, U.se23_jl_inv,
    ),
}  # fmt: skip


# ----------------------------------------------------------------------------- element pieces
def _parts(
    g: GroupSpec, X: FloatArray
) -> tuple[FloatArray, FloatArray, list[FloatArray], FloatArray]:
    """``(R, A, vectors, s)``: rotation, linear part ``A = sR``, vector columns, scale."""
    k = 2 if g.rot_dim == 1 else 3
    A = X if g.name == "so2" else X[..., :k, :k]
    s = U.sim3_scale(X) if g.scale is not None else np.ones(X.shape[:-2])
    R = A / s[..., None, None] if g.scale is not None else A
    vecs = [X[..., : A.shape[-1], c] for c in g.cols]
    return R, A, vecs, s


def _assemble(g: GroupSpec, R: FloatArray, vecs: list[FloatArray], s: FloatArray) -> FloatArray:
    if g.name == "so2":
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


def _rot_inc(g: GroupSpec, r: FloatArray, kind: str) -> FloatArray:
    return U.so2_exp(r) if g.rot_dim == 1 else to_rotation(r, kind)


def _rot_coords(g: GroupSpec, dR: FloatArray, kind: str) -> FloatArray:
    return U.so2_log(dR) if g.rot_dim == 1 else from_rotation(dR, kind)


def _mv(A: FloatArray, x: FloatArray) -> FloatArray:
    return np.einsum("...ij,...j->...i", A, x)


def _solve(A: FloatArray, x: FloatArray) -> FloatArray:
    return np.asarray(np.linalg.solve(A, x[..., None])[..., 0], dtype=np.float64)


# ----------------------------------------------------------------------------- tangent layout
def to_internal(conv: Convention, d: FloatArray) -> FloatArray:
    """Convention tangent (possibly embedded) → canonical-order tangent ``(..., dim)``."""
    g = GROUPS[conv.group]
    if conv.embed is not None:
        d = d[..., list(conv.embed.index)]
    out = np.empty(d.shape)
    out[..., g.perm(conv.order)] = d
    return out


def from_internal(conv: Convention, xi: FloatArray) -> FloatArray:
    """Canonical-order tangent → the convention's tangent (zeros outside an embedding)."""
    g = GROUPS[conv.group]
    d = xi[..., g.perm(conv.order)]
    if conv.embed is None:
        return np.asarray(d, dtype=np.float64)
    out = np.zeros((*d.shape[:-1], conv.embed.size))
    out[..., list(conv.embed.index)] = d
    return out


def selection(conv: Convention) -> FloatArray:
    """``S`` with ``ξ_canonical-order = S d`` for the layout alone (permutation and embedding)."""
    g = GROUPS[conv.group]
    n = conv.embed.size if conv.embed is not None else g.dim
    S = np.zeros((g.dim, n))
    cols = list(conv.embed.index) if conv.embed is not None else list(range(g.dim))
    S[g.perm(conv.order), cols] = 1.0
    return S


def is_coupled(conv: Convention) -> bool:
    """Whether the convention uses the group's own exponential (not a split chart)."""
    return conv.chart == conv.group


# ----------------------------------------------------------------------------- retract / local
def retract(conv: Convention, X: FloatArray, d: FloatArray) -> FloatArray:
    """``conv.retract(X, d)`` for a group of :data:`GROUPS` (validated inputs)."""
    g = GROUPS[conv.group]
    xi = to_internal(conv, d)
    right = conv.side == "right"
    if is_coupled(conv) or g.name == "so2":
        E = g.exp(xi)
        return np.asarray(X @ E if right else E @ X, dtype=np.float64)
    R, A, vecs, s = _parts(g, X)
    dR = _rot_inc(g, xi[..., g.rot], conv.rotation)
    R2 = R @ dR if right else dR @ R
    body = conv.chart == "split_body"
    new = [
        t + (_mv(A, xi[..., sl]) if body else xi[..., sl])
        for t, sl in zip(vecs, g.vecs, strict=True)
    ]
    s2 = s * np.exp(xi[..., g.scale]) if g.scale is not None else s
    return _assemble(g, R2, new, np.asarray(s2, dtype=np.float64))


def local(conv: Convention, X: FloatArray, Y: FloatArray) -> FloatArray:
    """``conv.local(X, Y)``: the ``d`` with ``retract(X, d) == Y`` (principal branch)."""
    g = GROUPS[conv.group]
    right = conv.side == "right"
    if is_coupled(conv) or g.name == "so2":
        Xi = g.inverse(X)
        return from_internal(conv, g.log(Xi @ Y if right else Y @ Xi))
    RX, AX, tX, sX = _parts(g, X)
    RY, _, tY, sY = _parts(g, Y)
    RXt = np.swapaxes(RX, -1, -2)
    shape = np.broadcast_shapes(X.shape[:-2], Y.shape[:-2])
    xi = np.zeros((*shape, g.dim))
    xi[..., g.rot] = _rot_coords(g, RXt @ RY if right else RY @ RXt, conv.rotation)
    body = conv.chart == "split_body"
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
    g = GROUPS[conv.group]
    right = conv.side == "right"
    shape = X.shape[:-2]
    if is_coupled(conv) or g.name == "so2":
        if right or g.name == "so2":
            return np.broadcast_to(np.eye(g.dim), (*shape, g.dim, g.dim)).copy()
        return g.adjoint(X) if inverse else g.adjoint(g.inverse(X))
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
    body = conv.chart == "split_body"
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
    g = GROUPS[conv.group]
    right = conv.side == "right"
    S = selection(conv)
    if is_coupled(conv) or g.name == "so2":
        Xi = g.inverse(X)
        J = g.jr_inv(g.log(Xi @ Y)) if right else g.jl_inv(g.log(Y @ Xi))
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
    blk = np.linalg.solve(AX, AY) if conv.chart == "split_body" else np.eye(AX.shape[-1])
    for sl in g.vecs:
        J[..., sl, sl] = blk
    if g.scale is not None:
        J[..., g.scale, g.scale] = 1.0
    return np.asarray(S.T @ J @ S, dtype=np.float64)
