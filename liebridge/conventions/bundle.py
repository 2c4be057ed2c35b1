"""Product states (bundles): an ordered list of blocks, each with its own convention.

A :class:`Bundle` is a chart of a product group (:class:`~liebridge.conventions.chart.Chart`):
each block is a convention of one group (e.g. ``gtsam`` for a pose, a rotation convention), a
navigation chart (``gtsam_navstate`` for (R, p, v)), a plain vector (:class:`Vector`, e.g. an
IMU bias, perturbed additively) or a direction of fixed length
(:class:`~liebridge.conventions.sphere.Sphere`, S²: FAST-LIO's gravity, stored like a vector,
tangent of 2). The tangent is the concatenation of the blocks' tangents, optionally reordered by
``order`` (a permutation: entry ``k`` of the bundle's tangent is entry ``order[k]`` of the
concatenation). :meth:`Bundle.sub`, :meth:`Bundle.marginal` and :meth:`Bundle.sub_element` carry
some of the blocks into a smaller bundle.

An element is one block-diagonal matrix ``(..., N, N)``: each group block as its own matrix, a
vector ``b`` (or a sphere's ``g``) as ``[[I, b], [0, 1]]``; :meth:`Bundle.assemble` and
:meth:`Bundle.split` build and read it. So a bundle goes through every conversion
(``tangent_map``, ``convert_covariance`` linear and unscented, ``convert_information``,
``convert_jacobian``, ``check.monte_carlo_covariance``) on the same code path as a single group.
Two bundles convert into each other when their blocks are of the same groups in the same order.
The canonical tangent of a bundle is the concatenation of its blocks' canonical (GTSAM) tangents.

A bundle runs on numpy, torch and JAX arrays (the caller's array type, device and dtype,
differentiable) where each of its blocks does: vectors and spheres always, a convention or a
navigation chart where its pose convention does (the group blocks call their conventions' own
array-generic retractions and maps; nothing is copied). The element and the maps are assembled
from the blocks' results by stacking (``arrays.blocks``), never written in place; the tangent
order is a gather. Checks run on the device (block structure: one reduction; each block: its
own validator); numpy's message is worded from a host copy only when a check fails.

>>> from liebridge.conventions import get
>>> nav15 = Bundle.of("gtsam_combined_like", [("nav", get("gtsam_navstate")),
...                   ("b_a", Vector(3)), ("b_g", Vector(3))])
>>> nav15.dim()
15
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from .chart import Chart
from .convention import Convention
from .navstate import (
    NavChart,
    _block_diagonal,
    _broadcast_concat,
    _from_concat_any,
    _to_concat_any,
)
from .sphere import Sphere
from .tangent_order import perm_matrix


@dataclass(frozen=True)
class Vector:
    """A plain vector block (biases, ...): ``b + d``, stored as ``[[I, b], [0, 1]]``."""

    n: int

    def __post_init__(self) -> None:
        if not (isinstance(self.n, int) and self.n >= 1):
            raise ValueError(f"Vector: n must be a positive int, got {self.n!r}")

    @property
    def group(self) -> str:
        """``r<n>``: the translation group of ℝⁿ."""
        return f"r{self.n}"


Block = Convention | NavChart | Vector | Sphere
#: Blocks stored as ``[[I, x], [0, 1]]`` (their part is the vector ``x``).
_VECTOR_LIKE = (Vector, Sphere)


def _tdim(b: Block) -> int:
    return b.n if isinstance(b, Vector) else b.dim()


def _mdim(b: Block) -> int:
    return b.n + 1 if isinstance(b, _VECTOR_LIKE) else b.record.matrix


def _vector_block(x: Any) -> Any:
    """``[[I, x], [0, 1]]`` ``(..., k+1, k+1)`` of torch/JAX vectors ``x`` ``(..., k)``."""
    xp = arrays.namespace(x)
    batch, k = tuple(x.shape[:-1]), int(x.shape[-1])
    top = arrays.concat([arrays.eye(k, x, batch), x[..., :, None]], -1)
    bottom = xp.broadcast_to(arrays.like(np.eye(k + 1)[k:], x), (*batch, 1, k + 1))
    return arrays.concat([top, bottom], -2)


@dataclass(frozen=True)
class Bundle(Chart):
    """A product-state chart; build it with :meth:`Bundle.of`. See the module docstring.

    A chart of its own (:class:`~liebridge.conventions.chart.Chart`), not a convention of one
    group: it has blocks and a tangent order, no side, order or rotation coordinates of its own
    (each block has its own). ``group`` names the product, ``"bundle[se23,r3,r3]"``.
    """

    name: str
    blocks: tuple[tuple[str, Block], ...]
    perm: tuple[int, ...] | None = None
    source: str = ""
    notes: str = field(default="", compare=False, repr=False)
    group: str = field(init=False, default="", compare=False)
    _key: tuple[str, str, str, str] = field(
        init=False, repr=False, compare=False, default=("",) * 4
    )
    _tslices: tuple[slice, ...] = field(init=False, repr=False, compare=False, default=())
    _mslices: tuple[slice, ...] = field(init=False, repr=False, compare=False, default=())
    _generic: bool = field(init=False, repr=False, compare=False, default=False)

    @classmethod
    def of(
        cls,
        name: str,
        blocks: list[tuple[str, Block]],
        order: list[int] | None = None,
        source: str = "",
        notes: str = "",
    ) -> Bundle:
        """Build a bundle from named blocks (and an optional tangent permutation ``order``)."""
        return cls(
            name=name,
            blocks=tuple(blocks),
            perm=tuple(order) if order is not None else None,
            source=source,
            notes=notes,
        )

    def __post_init__(self) -> None:
        if not self.blocks:
            raise ValueError(f"Bundle {self.name!r}: needs at least one block")
        names = [n for n, _ in self.blocks]
        if len(set(names)) != len(names):
            raise ValueError(f"Bundle {self.name!r}: block names must be distinct, got {names}")
        for n, b in self.blocks:
            if not isinstance(b, Convention | NavChart | Vector | Sphere):
                raise TypeError(
                    f"Bundle {self.name!r}: block {n!r} must be a Convention, NavChart, Vector "
                    "or Sphere"
                )
            if isinstance(b, Chart) and b.embed is not None:
                raise ValueError(f"Bundle {self.name!r}: block {n!r} has an embedding")
        t = m = 0
        ts, ms = [], []
        for _, b in self.blocks:
            ts.append(slice(t, t + _tdim(b)))
            ms.append(slice(m, m + _mdim(b)))
            t, m = t + _tdim(b), m + _mdim(b)
        if self.perm is not None and sorted(self.perm) != list(range(t)):
            raise ValueError(f"Bundle {self.name!r}: order must be a permutation of range({t})")
        sig = ",".join(b.group for _, b in self.blocks)
        object.__setattr__(self, "group", f"bundle[{sig}]")
        object.__setattr__(self, "_tslices", tuple(ts))
        object.__setattr__(self, "_mslices", tuple(ms))
        object.__setattr__(self, "_key", (self.name, self.group, "bundle", str(self.perm)))
        generic = all(isinstance(b, _VECTOR_LIKE) or b._array_api for _, b in self.blocks)
        object.__setattr__(self, "_generic", generic)

    # ----------------------------------------------------------------- layout
    @property
    def matrix_size(self) -> int:
        """Size ``N`` of the block-diagonal element."""
        return self._mslices[-1].stop

    def dim(self, X: Any = None) -> int:
        """Length of the bundle's tangent."""
        return self._tslices[-1].stop

    def describe(self) -> str:
        """One line: name and blocks."""
        parts = ", ".join(
            f"{n}: {b.group if isinstance(b, Vector) else b.name}" for n, b in self.blocks
        )
        return f"{self.name} (bundle): {parts}" + (f", order={self.perm}" if self.perm else "")

    @property
    def _array_api(self) -> bool:
        """Whether this bundle runs on torch/JAX arrays: where every block does."""
        return self._generic  # (read on every call: computed once, in __post_init__)

    def _template(self) -> tuple[FloatArray, FloatArray]:
        """Return ``(fixed, value)``: the entries every element has (off-block, vector blocks)."""
        N = self.matrix_size
        fixed, value = np.ones((N, N)), np.zeros((N, N))
        for (_, b), ms in zip(self.blocks, self._mslices, strict=True):
            fixed[ms, ms] = 0.0
            if isinstance(b, Vector):
                a, k = ms.start, b.n
                fixed[a : a + k, a : a + k] = 1.0
                value[a : a + k, a : a + k] = np.eye(k)
                fixed[a + k, ms] = 1.0
                value[a + k, a + k] = 1.0
        return fixed, value

    def _P(self) -> FloatArray:
        """``P`` with ``d_concatenated = P d``."""
        return perm_matrix(self.dim(), self.perm)

    def _to_concat(self, d: FloatArray) -> FloatArray:
        return _to_concat_any(d, self.perm)

    def _from_concat(self, c: FloatArray) -> FloatArray:
        return _from_concat_any(c, self.perm)

    # ----------------------------------------------------------------- elements
    def assemble(self, **parts: Any) -> FloatArray:
        """Build the block-diagonal element from its parts by block name (vectors ``(..., n)``)."""
        missing = [n for n, _ in self.blocks if n not in parts]
        extra = sorted(set(parts) - {n for n, _ in self.blocks})
        if missing or extra:
            raise ValueError(f"{self.name}.assemble: missing {missing}, unknown {extra}")
        if arrays.any_foreign(*parts.values()):
            return self._assemble_generic(parts)
        arrs = {n: validate.as_float_array(parts[n], n) for n, _ in self.blocks}
        batch = validate.batch_shape(
            *(
                (n, a.shape[:-1] if isinstance(b, _VECTOR_LIKE) else a.shape[:-2])
                for (n, b), a in zip(self.blocks, arrs.values(), strict=True)
            )
        )
        N = self.matrix_size
        X = np.zeros((*batch, N, N))
        for (n, b), ms in zip(self.blocks, self._mslices, strict=True):
            if isinstance(b, _VECTOR_LIKE):
                x = (
                    b.vector(arrs[n], n)
                    if isinstance(b, Sphere)
                    else validate.vector(arrs[n], n, b.n)
                )
                X[..., ms.start : ms.start + b.n, ms.start : ms.start + b.n] = np.eye(b.n)
                X[..., ms.start : ms.start + b.n, ms.stop - 1] = x
                X[..., ms.stop - 1, ms.stop - 1] = 1.0
            else:
                X[..., ms, ms] = b.element(arrs[n], n)
        return X

    def _assemble_generic(self, parts: dict[str, Any]) -> Any:
        """:meth:`assemble` on torch/JAX arrays: the blocks stacked, not written."""
        names = [n for n, _ in self.blocks]
        arrs = dict(zip(names, arrays.common(*(parts[n] for n in names)), strict=True))
        diag = []
        for n, b in self.blocks:
            if isinstance(b, Sphere):
                diag.append(_vector_block(b.vector(arrs[n], n)))
            elif isinstance(b, Vector):
                diag.append(_vector_block(validate.vector(arrs[n], n, b.n)))
            else:
                diag.append(b.element(arrs[n], n))
        batch = validate.batch_shape(
            *((n, tuple(a.shape[:-2])) for (n, _), a in zip(self.blocks, diag, strict=True))
        )
        return _block_diagonal(diag, batch)

    def split(self, X: Any) -> dict[str, FloatArray]:
        """Return the parts of an element by block name (inverse of :meth:`assemble`)."""
        X = self.element(X)
        out = {}
        for (n, b), ms in zip(self.blocks, self._mslices, strict=True):
            blk = X[..., ms, ms]
            part = blk[..., :-1, -1] if isinstance(b, _VECTOR_LIKE) else blk
            # a new array, never a view of the caller's
            out[n] = 1.0 * part if arrays.is_foreign(part) else np.array(part)
        return out

    def element(self, X: Any, name: str = "X") -> FloatArray:
        """Validate a block-diagonal element: zero off the blocks, each block in its group."""
        N = self.matrix_size
        arr = validate.square(X, name, N)
        if arrays.is_foreign(arr):
            xp = arrays.namespace(arr)
            fixed, value = self._template()
            dev = (arr - arrays.like(value, arr)) * arrays.like(fixed, arr)
            if arrays.all_true(xp.all(dev == 0.0)) is False:  # numpy words the first violation
                self.element(arrays.to_numpy(arr).astype(np.float64), name)
            for (n, b), ms in zip(self.blocks, self._mslices, strict=True):
                if not isinstance(b, Vector):
                    b.element(arr[..., ms, ms], f"{name} (block {n!r})")
            return arr
        mask = np.ones((N, N), dtype=bool)
        for ms in self._mslices:
            mask[ms, ms] = False
        off = arr[..., mask] != 0
        if off.any():
            i = tuple(int(k) for k in np.argwhere(off.any(axis=-1))[0]) if off.ndim > 1 else ()
            raise ValueError(
                f"{name}: not a {self.name} element at batch index {i}: nonzero entries off its "
                "diagonal blocks (a bundle element is block diagonal; build it with .assemble)"
            )
        for (n, b), ms in zip(self.blocks, self._mslices, strict=True):
            sub = arr[..., ms, ms]
            what = f"{name} (block {n!r})"
            if isinstance(b, Vector):
                k = b.n
                ok = (sub[..., :k, :k] == np.eye(k)).all(axis=(-1, -2)) & (
                    sub[..., k, :] == np.eye(k + 1)[k]
                ).all(axis=-1)
                if not ok.all():
                    i = tuple(int(j) for j in np.argwhere(~ok)[0]) if ok.ndim else ()
                    raise ValueError(
                        f"{what}: not a vector block [[I, b], [0, 1]] at batch index {i}"
                    )
            else:
                b.element(sub, what)
        return arr

    # ----------------------------------------------------------------- retraction
    def _increment(self, d: Any, so3: bool, name: str = "d") -> FloatArray:
        arr = validate.vector(d, name, self.dim())
        c = self._to_concat(arr)
        for (n, b), ts in zip(self.blocks, self._tslices, strict=True):
            if isinstance(b, Chart):
                b._increment(c[..., ts], False, f"{name} (block {n!r})")
        return arr

    def _retract(self, X: FloatArray, d: FloatArray) -> FloatArray:
        c = self._to_concat(d)
        if arrays.any_foreign(X, c):
            diag = []
            for (_, b), ts, ms in zip(self.blocks, self._tslices, self._mslices, strict=True):
                sub = X[..., ms, ms]
                if isinstance(b, Vector):
                    diag.append(_vector_block(sub[..., :-1, -1] + c[..., ts]))
                else:
                    diag.append(b._retract(sub, c[..., ts]))
            batch = tuple(np.broadcast_shapes(tuple(X.shape[:-2]), tuple(d.shape[:-1])))
            return _block_diagonal(diag, batch)
        N = self.matrix_size
        out = np.zeros((*np.broadcast_shapes(X.shape[:-2], d.shape[:-1]), N, N))
        for (_, b), ts, ms in zip(self.blocks, self._tslices, self._mslices, strict=True):
            sub = X[..., ms, ms]
            if isinstance(b, Vector):
                out[..., ms, ms] = sub
                out[..., ms.start : ms.stop - 1, ms.stop - 1] = sub[..., :-1, -1] + c[..., ts]
            else:
                out[..., ms, ms] = b._retract(sub, c[..., ts])
        return out

    def _local(self, X: FloatArray, Y: FloatArray) -> FloatArray:
        parts = []
        for (_, b), ms in zip(self.blocks, self._mslices, strict=True):
            A, B = X[..., ms, ms], Y[..., ms, ms]
            if isinstance(b, Vector):
                parts.append(B[..., :-1, -1] - A[..., :-1, -1])
            else:
                parts.append(b._local(A, B))
        if arrays.any_foreign(*parts):
            return self._from_concat(_broadcast_concat(parts))
        batch = np.broadcast_shapes(*(p.shape[:-1] for p in parts))
        parts = [np.broadcast_to(p, (*batch, p.shape[-1])) for p in parts]
        return self._from_concat(np.concatenate(parts, axis=-1))

    def _blockdiag(self, X: FloatArray, f: str, Y: FloatArray | None = None) -> FloatArray:
        n = self.dim()
        batch = X.shape[:-2] if Y is None else np.broadcast_shapes(X.shape[:-2], Y.shape[:-2])
        if arrays.any_foreign(X) or (Y is not None and arrays.is_foreign(Y)):
            diag = []
            for (_, b), ms in zip(self.blocks, self._mslices, strict=True):
                if isinstance(b, Vector):
                    diag.append(arrays.eye(b.n, X))
                elif Y is None:
                    diag.append(getattr(b, f)(X[..., ms, ms]))
                else:
                    diag.append(b._local_jacobian(X[..., ms, ms], Y[..., ms, ms]))
            return _block_diagonal(diag, tuple(batch))
        out = np.zeros((*batch, n, n))
        for (_, b), ts, ms in zip(self.blocks, self._tslices, self._mslices, strict=True):
            if isinstance(b, Vector):
                out[..., ts, ts] = np.eye(b.n)
            elif Y is None:
                out[..., ts, ts] = getattr(b, f)(X[..., ms, ms])
            else:
                out[..., ts, ts] = b._local_jacobian(X[..., ms, ms], Y[..., ms, ms])
        return out

    def _to_canonical(self, X: FloatArray) -> FloatArray:
        M = self._blockdiag(X, "_to_canonical")
        if arrays.is_foreign(M):  # M·P: its columns, gathered
            return M if self.perm is None else M[..., :, list(self.perm)]
        return np.asarray(M @ self._P(), dtype=np.float64)

    def _from_canonical(self, X: FloatArray) -> FloatArray:
        M = self._blockdiag(X, "_from_canonical")
        if arrays.is_foreign(M):  # Pᵀ·M: its rows, gathered
            return M if self.perm is None else M[..., list(self.perm), :]
        return np.asarray(self._P().T @ M, dtype=np.float64)

    def _local_jacobian(self, X: FloatArray, Y: FloatArray) -> FloatArray:
        if arrays.any_foreign(X, Y):
            J = self._blockdiag(X, "", Y)
            if self.perm is None:
                return J
            p = list(self.perm)
            return J[..., p, :][..., :, p]
        P = self._P()
        return np.asarray(P.T @ self._blockdiag(X, "", Y) @ P, dtype=np.float64)

    def _pair(self, X: Any, Y: Any) -> tuple[FloatArray, FloatArray]:
        A, B = self.element(X), self.element(Y, "Y")
        validate.batch_shape(("X", A.shape[:-2]), ("Y", B.shape[:-2]))
        return A, B

    def exactly_linear_to(self, other: Bundle, linear: Any) -> bool:
        """Whether every block pair is exactly linear (``linear(a, b)`` per convention pair)."""
        # S² charts here are all the geodesic exponential in orthonormal bases: linear (a
        # 2×2 rotation) between any two of them, below an angle of π
        return all(
            isinstance(a, _VECTOR_LIKE) or linear(a, b)
            for (_, a), (_, b) in zip(self.blocks, other.blocks, strict=True)
        )

    # ----------------------------------------------------------------- sub-states
    def _keep(self, keep: Sequence[str]) -> tuple[list[int], list[int]]:
        """Kept block indices (bundle order) and kept tangent entries (this bundle's order)."""
        names = [n for n, _ in self.blocks]
        unknown = [k for k in keep if k not in names]
        if unknown or not keep or len(set(keep)) != len(keep):
            raise ValueError(
                f"{self.name}: keep must name distinct blocks of {names}, got {list(keep)}"
            )
        blocks = [i for i, n in enumerate(names) if n in keep]
        concat = {j for i in blocks for j in range(*self._tslices[i].indices(self.dim()))}
        order = self.perm if self.perm is not None else tuple(range(self.dim()))
        return blocks, [k for k, c in enumerate(order) if c in concat]

    def sub(
        self, keep: Sequence[str], name: str | None = None, source: str = "", notes: str = ""
    ) -> Bundle:
        """Return the bundle of the blocks named in ``keep``, with this bundle's charts and order.

        Its tangent is the entries of this bundle's tangent that belong to the kept blocks, in
        the order they have here; its blocks keep this bundle's block order. With
        :meth:`marginal` and :meth:`sub_element` it carries part of a larger state (FAST-LIO's
        IMU part of its 23-dimensional state) into any bundle of the same blocks.
        """
        blocks, entries = self._keep(keep)
        kept = [self.blocks[i] for i in blocks]
        order = self.perm if self.perm is not None else tuple(range(self.dim()))
        # renumber the kept concatenated entries 0..m-1 in concatenation order
        cat = sorted(order[k] for k in entries)
        rank = {c: r for r, c in enumerate(cat)}
        perm = [rank[order[k]] for k in entries]
        return Bundle.of(
            name or f"{self.name}[{','.join(n for n, _ in kept)}]",
            kept,
            order=None if perm == list(range(len(perm))) else perm,
            source=source or self.source,
            notes=notes,
        )

    def marginal(self, cov: Any, keep: Sequence[str]) -> FloatArray:
        """Covariance ``(..., m, m)`` of the kept blocks' tangent (in :meth:`sub`'s order).

        Exact, not an approximation: each block of a bundle is retracted by its own entries
        only, so the kept blocks' perturbation is the kept entries of the tangent, and the
        marginal of a Gaussian is its sub-matrix. False: the marginal needs a Schur complement
        (that is the *conditional* covariance, or the marginal of an information matrix).
        """
        _, entries = self._keep(keep)
        arr = validate.covariance(cov, "cov", self.dim())
        out = arr[..., entries, :][..., :, entries]
        return out if arrays.is_foreign(out) else np.asarray(out, dtype=np.float64)

    def sub_element(self, X: Any, keep: Sequence[str]) -> FloatArray:
        """Return the element of :meth:`sub` (the kept diagonal blocks of ``X``)."""
        blocks, _ = self._keep(keep)
        arr = self.element(X)
        idx = [j for i in blocks for j in range(*self._mslices[i].indices(self.matrix_size))]
        out = arr[..., idx, :][..., :, idx]
        return out if arrays.is_foreign(out) else np.asarray(out, dtype=np.float64)
