"""One engine for every group: a convention's maths read from its group record.

:class:`~liebridge.conventions.Convention` runs every operation through the engine of its group:
the :class:`Engine` below, written once in terms of the group record
(:class:`liebridge.lie.Group`: dimension, matrix size, rotation, vector and scale slots, unchecked
kernels), for every registered group, a user's included. A group may register a **fast
implementation** of the same formulas (:func:`register_fast`): SE(3) and SO(3) do, with their
closed-form tangent-map grids, Euler coordinates and the optional compiled pass
(:mod:`~liebridge.conventions.se3_engine`); a test holds the fast and the record-driven results
equal on every SE(3) preset.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .. import _validate as validate
from .._validate import FloatArray
from ..lie import Group
from ..lie import group as group_record
from . import groups as G

if TYPE_CHECKING:
    from .convention import Convention


class Engine:
    """The record-driven engine (every group): what a convention does, in terms of its group.

    Each method takes the convention first; inputs of the ``retract``/``local``/... methods are
    validated already (the :class:`~liebridge.conventions.Convention` methods validate, then
    call these).
    """

    #: Whether absolute Euler-angle rotation coordinates are implemented.
    euler = False
    #: Whether a convention may store its tangent inside a longer vector (``Embed``).
    embed = True
    #: Whether conventions act on bare 3-D rotations too (SE(3) and SO(3) conventions then convert
    #: into each other on rotations), with the closed-form tangent-map grids.
    rotations_3d = False

    def for_tensors(self) -> Engine:
        """Return the engine of this group's conventions on torch/JAX arrays (the record's)."""
        return RECORD_ENGINE

    def check(self, conv: Convention, g: Group) -> None:
        """Raise ``ValueError`` for field combinations this engine cannot run."""
        if conv.embed is not None and len(conv.embed.index) != g.dim:
            raise ValueError(
                f"Convention {conv.name!r}: embed.index has {len(conv.embed.index)} entries, "
                f"the {g.name} tangent {g.dim}"
            )

    def dim(self, conv: Convention, X: Any = None) -> int:
        """Length of the convention's tangent."""
        return conv.embed.size if conv.embed is not None else group_record(conv.group).dim

    def element(self, conv: Convention, X: Any, name: str) -> FloatArray:
        """Validate ``X`` as an element of the convention's group."""
        return group_record(conv.group).element(X, name)

    def pair(self, conv: Convention, X: Any, Y: Any) -> tuple[FloatArray, FloatArray]:
        """Validate two elements with broadcastable batch shapes."""
        A, B = conv.element(X), conv.element(Y, "Y")
        validate.batch_shape(("X", A.shape[:-2]), ("Y", B.shape[:-2]))
        return A, B

    def increment(self, conv: Convention, d: Any, so3: bool, name: str) -> FloatArray:
        """Validate an increment in the convention's tangent (rotation part bounded).

        ``so3``: the element it will perturb is ``(..., 3, 3)`` (an SE(3) convention then takes a
        rotation increment; other groups ignore it).
        """
        g = group_record(conv.group)
        arr = validate.vector(d, name, conv.dim())
        if g.rot is not None or g.tangent_check is not None:
            xi = G.to_internal(conv, arr)
            if g.rot is not None:
                validate.tangent(xi, name, g.dim, g.rot)
            if g.tangent_check is not None:
                g.tangent_check(xi, name)
        return arr

    def retract(self, conv: Convention, X: FloatArray, d: FloatArray) -> FloatArray:
        """``conv.retract(X, d)``."""
        return G.retract(conv, X, d)

    def local(self, conv: Convention, X: FloatArray, Y: FloatArray) -> FloatArray:
        """``conv.local(X, Y)``."""
        return G.local(conv, X, Y)

    def local_jacobian(self, conv: Convention, X: FloatArray, Y: FloatArray) -> FloatArray:
        """``∂ local(X, retract(Y, δ)) / ∂δ`` at 0."""
        return G.local_jacobian(conv, X, Y)

    def to_canonical(self, conv: Convention, X: FloatArray) -> FloatArray:
        """``M`` with ``ξ_canonical = M d``."""
        return G.to_canonical(conv, X)

    def from_canonical(self, conv: Convention, X: FloatArray) -> FloatArray:
        """``M`` with ``d = M ξ_canonical``."""
        return G.from_canonical(conv, X)


#: The record-driven engine, shared by every group without a fast implementation.
RECORD_ENGINE = Engine()
_FAST: dict[str, Engine] = {}


def register_fast(group: Group, engine: Engine) -> None:
    """Register ``engine`` as ``group``'s fast implementation of the record-driven formulas."""
    _FAST[group.name] = engine


def convertible(a: str, b: str) -> bool:
    """Whether tangents of conventions of groups ``a`` and ``b`` convert into each other."""
    return a == b or (engine_for(a).rotations_3d and engine_for(b).rotations_3d)


def engine_for(group: str | Group) -> Engine:
    """Return the engine that runs conventions of ``group``."""
    name = group.name if isinstance(group, Group) else group
    return _FAST.get(name, RECORD_ENGINE)
