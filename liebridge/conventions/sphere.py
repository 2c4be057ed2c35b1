"""An S² block of a :class:`~liebridge.conventions.Bundle`: a 3-vector of fixed length (gravity).

A :class:`Sphere` is the chart of a direction stored as a 3-vector ``g`` of fixed norm ``length``
(FAST-LIO's gravity, MTK's ``S2<double, 98090, 10000, 1>``: ``length = 98090/10000 = 9.809``).
Its tangent has 2 entries (radians); in a bundle element it sits like a vector block,
``[[I, g], [0, 1]]`` (4×4), with ``‖g‖ = length`` checked (relative tolerance 1e-6).

With ``n = g/length``, every chart here is the sphere's geodesic exponential read in an
orthonormal basis ``E(n)`` (3×2) of the tangent plane (see :mod:`liebridge.lie.s2`):

``retract(g, δ) = length · exp(n, E(n) δ)``, ``local(g, h) = E(n)ᵀ log(n, h/length)``.

``basis`` picks ``E``:

* ``"gtsam"``: GTSAM's ``Unit3`` (``E = Unit3::basis()``; ``Unit3.retract``/``localCoordinates``
  of the direction): the canonical tangent of S² in liebridge, what ``to_canonical`` maps to;
* ``"mtk_x"``, ``"mtk_y"``, ``"mtk_z"``: MTK/IKFoM's ``S2`` with ``S2_typ`` 1, 2, 3:
  ``boxplus(δ)`` is ``g ← Exp(B δ)·g`` with ``B = S2_Bx`` (IKFoM_toolkit/mtk/types/S2.hpp), i.e.
  ``E = −[n]ₓ B``; ``boxminus`` is ``θ/sin θ · Bᵀ (n × h/length)``, the same chart's inverse.

Any two of these charts differ by a 2×2 rotation (or reflection) at each point: conversions
between them are exactly linear (for angles below π). The defining identity of MTK's chart:
``retract(g, δ) = Exp(B δ)·g``. False: ``retract(g, δ) = normalize(g + length·B δ)·length``
(``B δ`` is the rotation axis, perpendicular to the motion, not the direction of motion).

Every method runs on numpy, torch and JAX arrays (the caller's array type, device and dtype,
differentiable): the bases and the geodesic maps are :mod:`liebridge.lie.s2`'s, and the checks
(``‖g‖ = length``, the block's constant entries) are one reduction on the device, numpy's
message worded from a host copy only when one fails.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from ..lie import s2

SPHERE_BASES = ("gtsam", "mtk_x", "mtk_y", "mtk_z")
#: Relative tolerance on ``‖g‖ = length`` of an element.
LENGTH_RTOL = 1e-6


def _mv(A: FloatArray, x: FloatArray) -> FloatArray:
    if arrays.any_foreign(A, x):
        return arrays.matvec(A, x)
    return np.asarray(np.einsum("...ij,...j->...i", A, x), dtype=np.float64)


def _f64(x: Any) -> Any:
    """Return a numpy result as float64, a torch/JAX one as it is."""
    return x if arrays.is_foreign(x) else np.asarray(x, dtype=np.float64)


@dataclass(frozen=True)
class Sphere:
    """An S² block: a 3-vector of norm ``length``, tangent of 2, chart ``basis`` (module doc)."""

    length: float = 1.0
    basis: str = "gtsam"
    name: str = ""

    def __post_init__(self) -> None:
        validate.option(self.basis, "basis", SPHERE_BASES)
        if not (isinstance(self.length, int | float) and np.isfinite(self.length)):
            raise ValueError(f"Sphere: length must be a finite number, got {self.length!r}")
        if self.length <= 0:
            raise ValueError(f"Sphere: length must be positive, got {self.length!r}")
        if not self.name:
            object.__setattr__(self, "name", f"s2_{self.basis}")

    @property
    def group(self) -> str:
        """``s2(r=<length>)``: bundles convert into each other when their spheres agree."""
        return f"s2(r={float(self.length)!r})"

    @property
    def n(self) -> int:
        """3: the stored vector's length (the element block is 4×4)."""
        return 3

    def dim(self, X: Any = None) -> int:
        """2: the tangent of S²."""
        return 2

    def describe(self) -> str:
        """One line: basis and length."""
        what = "GTSAM Unit3 basis" if self.basis == "gtsam" else f"MTK S2_Bx, S2_typ {self._axis}"
        return f"{self.name} (S² of radius {self.length:g}): geodesic exp in the {what}"

    @property
    def _axis(self) -> int:
        return {"mtk_x": 1, "mtk_y": 2, "mtk_z": 3}[self.basis]

    # ----------------------------------------------------------------- elements
    def vector(self, g: Any, name: str = "g") -> FloatArray:
        """Validate stored vectors ``(..., 3)`` of norm ``length`` (relative tolerance 1e-6)."""
        arr = validate.vector(g, name, 3)
        if arrays.is_foreign(arr):
            xp = arrays.namespace(arr)
            tol = max(LENGTH_RTOL, 64.0 * arrays.eps(arr))
            err = xp.abs(xp.sqrt(arrays.dot(arr, arr)) / self.length - 1.0)
            if arrays.all_true(err <= tol) is False:
                self.vector(arrays.to_numpy(arr).astype(np.float64), name)
            return arr
        err = np.abs(np.linalg.norm(arr, axis=-1) / self.length - 1.0)
        bad = err > LENGTH_RTOL
        if bad.any():
            i = validate.batch_index(bad)
            raise ValueError(
                f"{name}: not on the sphere of radius {self.length:g} at batch index {i}: "
                f"‖g‖ = {float(np.linalg.norm(arr[i])):.9g} (relative tolerance {LENGTH_RTOL:g})"
            )
        return arr

    def element(self, X: Any, name: str = "X") -> FloatArray:
        """Validate ``[[I, g], [0, 1]]`` blocks ``(..., 4, 4)`` with ``‖g‖ = length``."""
        arr = validate.square(X, name, 4)
        if arrays.is_foreign(arr):
            xp = arrays.namespace(arr)
            fixed = arrays.like(_FIXED, arr)
            dev = (arr - arrays.like(np.eye(4), arr)) * fixed  # 0 where the entries are right
            if arrays.all_true(xp.all(dev == 0.0)) is False:
                self.element(arrays.to_numpy(arr).astype(np.float64), name)  # words the error
            self.vector(arr[..., :3, 3], name)
            return arr
        ok = (arr[..., :3, :3] == np.eye(3)).all(axis=(-1, -2)) & (
            arr[..., 3, :] == np.eye(4)[3]
        ).all(axis=-1)
        if not ok.all():
            i = tuple(int(j) for j in np.argwhere(~ok)[0]) if ok.ndim else ()
            raise ValueError(f"{name}: not an S² block [[I, g], [0, 1]] at batch index {i}")
        self.vector(arr[..., :3, 3], name)
        return arr

    def _frame(self, n: FloatArray) -> FloatArray:
        """``E(n)``, ``(..., 3, 2)``: the orthonormal basis the chart reads tangents in."""
        if self.basis == "gtsam":
            return s2.unit3_basis(n)
        B = s2.mtk_basis(n, self._axis, self.length)
        if arrays.is_foreign(n):  # −[n]ₓ B, column by column
            xp = arrays.namespace(n)
            return -arrays.mT(xp.linalg.cross(n[..., None, :], arrays.mT(B)))
        return np.asarray(-np.cross(n[..., :, None], B, axis=-2), dtype=np.float64)

    def _unit(self, X: FloatArray) -> FloatArray:
        g = X[..., :3, 3]
        if arrays.is_foreign(g):  # ‖g‖ = length > 0: no guard needed
            return g / arrays.namespace(g).sqrt(arrays.dot(g, g))[..., None]
        return np.asarray(g / np.linalg.norm(g, axis=-1, keepdims=True), dtype=np.float64)

    # ----------------------------------------------------------------- chart
    def _increment(self, d: Any, so3: bool, name: str = "d") -> FloatArray:
        return validate.vector(d, name, 2)

    def _retract(self, X: FloatArray, d: FloatArray) -> FloatArray:
        n = self._unit(X)
        m = s2.exp(n, _mv(self._frame(n), d))
        if arrays.is_foreign(m):
            return _block(self.length * m)
        out = np.zeros((*np.broadcast_shapes(X.shape[:-2], d.shape[:-1]), 4, 4))
        out[..., :, :] = np.eye(4)
        out[..., :3, 3] = self.length * m
        return out

    def _local(self, X: FloatArray, Y: FloatArray) -> FloatArray:
        n, m = self._unit(X), self._unit(Y)
        E = self._frame(n)
        return _mv(arrays.mT(E) if arrays.is_foreign(E) else np.swapaxes(E, -1, -2), s2.log(n, m))

    def _to_canonical(self, X: FloatArray) -> FloatArray:
        n = self._unit(X)
        if arrays.is_foreign(n):
            return arrays.mT(s2.unit3_basis(n)) @ self._frame(n)
        return np.asarray(np.swapaxes(s2.unit3_basis(n), -1, -2) @ self._frame(n), np.float64)

    def _from_canonical(self, X: FloatArray) -> FloatArray:
        n = self._unit(X)
        if arrays.is_foreign(n):
            return arrays.mT(self._frame(n)) @ s2.unit3_basis(n)
        return np.asarray(np.swapaxes(self._frame(n), -1, -2) @ s2.unit3_basis(n), np.float64)

    def _local_jacobian(self, X: FloatArray, Y: FloatArray) -> FloatArray:
        n, m = self._unit(X), self._unit(Y)
        D = s2.dlog(n, m)
        if arrays.is_foreign(D):
            return arrays.mT(self._frame(n)) @ D @ self._frame(m)
        return np.asarray(
            np.swapaxes(self._frame(n), -1, -2) @ D @ self._frame(m), dtype=np.float64
        )

    # public, validated versions (a Sphere on its own, outside a bundle)
    def retract(self, g: Any, d: Any) -> FloatArray:
        """Perturb stored vectors ``g`` ``(..., 3)`` by ``d`` ``(..., 2)``; returns ``(..., 3)``."""
        g, d = arrays.common(g, d)
        X = _block(self.vector(g))
        d = validate.vector(d, "d", 2)
        validate.batch_shape(("g", X.shape[:-2]), ("d", d.shape[:-1]))
        return _f64(self._retract(X, d)[..., :3, 3])

    def local(self, g: Any, h: Any) -> FloatArray:
        """Inverse of :meth:`retract`: ``d`` ``(..., 2)`` with ``retract(g, d) = h``."""
        g, h = arrays.common(g, h)
        X, Y = _block(self.vector(g)), _block(self.vector(h, "h"))
        validate.batch_shape(("g", X.shape[:-2]), ("h", Y.shape[:-2]))
        return self._local(X, Y)


#: The constant entries of an S² block ``[[I, g], [0, 1]]`` (1 where fixed).
_FIXED = np.ones((4, 4))
_FIXED[:3, 3] = 0.0


def _block(g: FloatArray) -> FloatArray:
    """``[[I, g], [0, 1]]`` ``(..., 4, 4)`` of vectors ``g`` ``(..., 3)`` (any array type)."""
    if arrays.is_foreign(g):
        xp = arrays.namespace(g)
        batch = tuple(g.shape[:-1])
        top = arrays.concat([arrays.eye(3, g, batch), g[..., :, None]], -1)
        bottom = xp.broadcast_to(arrays.like(np.eye(4)[3:], g), (*batch, 1, 4))
        return arrays.concat([top, bottom], -2)
    X = np.zeros((*g.shape[:-1], 4, 4))
    X[..., :, :] = np.eye(4)
    X[..., :3, 3] = g
    return X
