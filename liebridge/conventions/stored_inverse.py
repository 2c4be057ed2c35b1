"""A convention whose library stores the inverse of liebridge's element: ``stores="inverse"``.

Some libraries keep the inverse of the pose a user names: DPVO and DROID-SLAM hold
**world→camera** poses ``T_cam_world`` in lietorch, while liebridge's element is
``X = T_world_cam``. Their update acts on ``Y = X⁻¹``; on ``X`` it reads

``retract_X(d) = inv(retract_Y(inv(X), d))``, ``local_X(A, B) = local_Y(A⁻¹, B⁻¹)``,

with ``retract_Y``/``local_Y`` the convention's own fields (side, order, chart, rotation) applied to
the stored element. For lietorch's left update ``Exp(δ)·Y`` this is ``X·Exp(−P·d)`` (``P`` puts
lietorch's (τ, φ) into GTSAM's (ω, v)): a right update with the sign flipped. The first-order maps
follow: with ``M_Y`` the stored element's map to GTSAM's tangent (``ξ = M_Y d`` at ``Y``),

``to_canonical(X) = −Ad_Y · M_Y(Y)``, ``from_canonical(X) = −M_Y⁻¹(Y) · Ad_X``

(from ``Exp(−M_Y d)·Y⁻¹ = X·Exp(−Ad_{X⁻¹} M_Y d)``; held by central finite differences through
``retract`` for every group in ``tests/test_stored_inverse.py``). False: ``M_X = M_Y`` or
``M_X = Ad_X·M_Y`` — the sign is part of the map: a world→camera increment moves the camera
the other way.

Only the coupled chart (the group's exponential) is accepted: there the inverse is again a group
chart, exactly linear with every other coupled chart, so the conversions stay exact; no library
found stores an inverse under a split chart. The closed-form tangent-map grids and the compiled
pass describe stored poses, so this engine reports ``rotations_3d = False`` and the conversions
take the numpy path (the group's own engine still decides which groups convert into which).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .. import arrays
from .._validate import FloatArray
from ..lie import Group
from ..lie import group as group_record
from .engine import Engine

if TYPE_CHECKING:
    from .convention import Convention

#: The values of ``Convention.stores``.
STORES = ("pose", "inverse")


def _parts(conv: Convention, X: FloatArray) -> tuple[Group, bool]:
    """Return ``X``'s group record and whether ``X`` is a bare rotation of an SE(3) convention."""
    g = group_record(conv.group)
    return g, X.shape[-1] != g.matrix


def _out(A: Any) -> Any:
    """Return numpy results as float64 arrays, torch/JAX arrays as they are (graph kept)."""
    return A if arrays.is_foreign(A) else np.asarray(A, dtype=np.float64)


def _inverse(conv: Convention, X: FloatArray) -> FloatArray:
    g, bare = _parts(conv, X)
    if bare:  # an SE(3) convention given a rotation (..., 3, 3)
        return _out(arrays.mT(X))
    return _out(g.kernels.inverse(X))


def _adjoint(conv: Convention, X: FloatArray) -> FloatArray:
    """``Ad_X`` in the group's canonical (GTSAM) order; a bare rotation's is ``R``."""
    g, bare = _parts(conv, X)
    if bare:
        return _out(X)
    return _out(g.kernels.adjoint(X))


class InverseEngine(Engine):
    """Run a convention on the stored inverse ``Y = X⁻¹`` through its group's engine ``base``.

    See the module docstring for the maps. Validation (elements, increments, dimensions) is the
    base engine's: the stored inverse is an element of the same group, the increment the same
    tangent.
    """

    rotations_3d = False  # the closed-form grids describe stored poses (module docstring)

    def __init__(self, base: Engine) -> None:
        self.base = base
        self.embed = base.embed
        self.euler = base.euler  # refused by check() anyway: Euler coordinates are split charts

    def check(self, conv: Convention, g: Group) -> None:
        """Apply the base engine's rules, and accept the coupled chart only."""
        self.base.check(conv, g)
        if conv.chart != g.coupled_chart:
            raise ValueError(
                f"Convention {conv.name!r}: stores='inverse' is supported with the coupled chart "
                f"{g.coupled_chart!r} (the group's exponential), not {conv.chart!r}"
            )

    def dim(self, conv: Convention, X: Any = None) -> int:
        """Return the base engine's tangent length."""
        return self.base.dim(conv, X)

    def element(self, conv: Convention, X: Any, name: str) -> FloatArray:
        """Validate ``X`` (liebridge's element, not the stored inverse) as the base does."""
        return self.base.element(conv, X, name)

    def pair(self, conv: Convention, X: Any, Y: Any) -> tuple[FloatArray, FloatArray]:
        """Two elements, as the base engine validates them."""
        return self.base.pair(conv, X, Y)

    def increment(self, conv: Convention, d: Any, so3: bool, name: str) -> FloatArray:
        """Validate an increment of the stored element's tangent as the base engine does."""
        return self.base.increment(conv, d, so3, name)

    def retract(self, conv: Convention, X: FloatArray, d: FloatArray) -> FloatArray:
        """``inv(retract_Y(X⁻¹, d))``."""
        return _inverse(conv, self.base.retract(conv, _inverse(conv, X), d))

    def local(self, conv: Convention, X: FloatArray, Y: FloatArray) -> FloatArray:
        """``local_Y(X⁻¹, Y⁻¹)``."""
        return self.base.local(conv, _inverse(conv, X), _inverse(conv, Y))

    def local_jacobian(self, conv: Convention, X: FloatArray, Y: FloatArray) -> FloatArray:
        """Return ``∂ local(X⁻¹, retract(Y⁻¹, δ)) / ∂δ`` of the stored elements (the same map)."""
        return self.base.local_jacobian(conv, _inverse(conv, X), _inverse(conv, Y))

    def to_canonical(self, conv: Convention, X: FloatArray) -> FloatArray:
        """``−Ad_Y · M_Y(Y)`` with ``Y = X⁻¹``."""
        Y = _inverse(conv, X)
        return _out(-(_adjoint(conv, Y) @ self.base.to_canonical(conv, Y)))

    def from_canonical(self, conv: Convention, X: FloatArray) -> FloatArray:
        """``−M_Y⁻¹(Y) · Ad_X`` with ``Y = X⁻¹`` (no matrix inversion)."""
        Y = _inverse(conv, X)
        return _out(-(self.base.from_canonical(conv, Y) @ _adjoint(conv, X)))


_INVERSE: dict[int, InverseEngine] = {}


def engine_storing(base: Engine, stores: str) -> Engine:
    """Return the engine of a convention that stores ``stores`` (``base`` itself for a pose).

    One :class:`InverseEngine` per base engine (so an unpickled convention has the same engine).
    """
    if stores == "pose":
        return base
    eng = _INVERSE.get(id(base))
    if eng is None or eng.base is not base:
        eng = _INVERSE[id(base)] = InverseEngine(base)
    return eng


__all__ = ["STORES", "InverseEngine", "engine_storing"]
