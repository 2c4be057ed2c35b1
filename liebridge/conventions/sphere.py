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
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..lie import s2

SPHERE_BASES = ("gtsam", "mtk_x", "mtk_y", "mtk_z")
#: Relative tolerance on ``‖g‖ = length`` of an element.
LENGTH_RTOL = 1e-6


def _mv(A: FloatArray, x: FloatArray) -> FloatArray:
    return np.asarray(np.einsum("...ij,...j->...i", A, x), dtype=np.float64)


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
        return np.asarray(-np.cross(n[..., :, None], B, axis=-2), dtype=np.float64)

    def _unit(self, X: FloatArray) -> FloatArray:
        g = X[..., :3, 3]
        return np.asarray(g / np.linalg.norm(g, axis=-1, keepdims=True), dtype=np.float64)

    # ----------------------------------------------------------------- chart
    def _increment(self, d: Any, so3: bool, name: str = "d") -> FloatArray:
        return validate.vector(d, name, 2)

    def _retract(self, X: FloatArray, d: FloatArray) -> FloatArray:
        n = self._unit(X)
        m = s2.exp(n, _mv(self._frame(n), d))
        out = np.zeros((*np.broadcast_shapes(X.shape[:-2], d.shape[:-1]), 4, 4))
        out[..., :, :] = np.eye(4)
        out[..., :3, 3] = self.length * m
        return out

    def _local(self, X: FloatArray, Y: FloatArray) -> FloatArray:
        n, m = self._unit(X), self._unit(Y)
        E = self._frame(n)
        return _mv(np.swapaxes(E, -1, -2), s2.log(n, m))

    def _to_canonical(self, X: FloatArray) -> FloatArray:
        n = self._unit(X)
        return np.asarray(np.swapaxes(s2.unit3_basis(n), -1, -2) @ self._frame(n), np.float64)

    def _from_canonical(self, X: FloatArray) -> FloatArray:
        n = self._unit(X)
        return np.asarray(np.swapaxes(self._frame(n), -1, -2) @ s2.unit3_basis(n), np.float64)

    def _local_jacobian(self, X: FloatArray, Y: FloatArray) -> FloatArray:
        n, m = self._unit(X), self._unit(Y)
        D = s2.dlog(n, m)
        return np.asarray(
            np.swapaxes(self._frame(n), -1, -2) @ D @ self._frame(m), dtype=np.float64
        )

    # public, validated versions (a Sphere on its own, outside a bundle)
    def retract(self, g: Any, d: Any) -> FloatArray:
        """Perturb stored vectors ``g`` ``(..., 3)`` by ``d`` ``(..., 2)``; returns ``(..., 3)``."""
        X = _block(self.vector(g))
        d = validate.vector(d, "d", 2)
        validate.batch_shape(("g", X.shape[:-2]), ("d", d.shape[:-1]))
        return np.asarray(self._retract(X, d)[..., :3, 3], dtype=np.float64)

    def local(self, g: Any, h: Any) -> FloatArray:
        """Inverse of :meth:`retract`: ``d`` ``(..., 2)`` with ``retract(g, d) = h``."""
        X, Y = _block(self.vector(g)), _block(self.vector(h, "h"))
        validate.batch_shape(("g", X.shape[:-2]), ("h", Y.shape[:-2]))
        return self._local(X, Y)


def _block(g: FloatArray) -> FloatArray:
    X = np.zeros((*g.shape[:-1], 4, 4))
    X[..., :, :] = np.eye(4)
    X[..., :3, 3] = g
    return X
