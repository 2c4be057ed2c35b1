"""What every chart is: the small protocol conversions, checks and factors rely on.

A **chart** says how a tangent vector ``d`` perturbs an element ``X`` of a group (or of a
product of groups) and back: ``retract(X, d)``, ``local(X, Y)`` with
``local(X, retract(X, d)) == d``, the closed-form derivative ``local_jacobian`` and the
first-order maps to and from the canonical tangent (GTSAM's): ``to_canonical`` (``ξ = M d``),
``from_canonical``. Three kinds implement it, none a special case of another:

* :class:`~liebridge.conventions.Convention` — one group's convention (side, order, chart,
  rotation coordinates), read from the group record;
* :class:`~liebridge.conventions.Bundle` — a product state: blocks, each a convention, a vector or
  a direction;
* :class:`~liebridge.conventions.NavChart` — a navigation state: an SE(3) pose convention and a
  velocity frame.

The validated public methods are written once, here (validate → unchecked formula → finite
output); each kind supplies ``dim``, ``element``, ``describe`` and the unchecked ``_increment``,
``_retract``, ``_local``, ``_local_jacobian``, ``_to_canonical``, ``_from_canonical``
(:mod:`liebridge.conventions.unchecked` calls those).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING, Any

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from ..lie import Group
from ..lie import group as group_record
from .engine import Engine, engine_for

if TYPE_CHECKING:
    from .convention import Embed


class Chart(ABC):
    """Base of every chart kind (see the module docstring). Not instantiated by itself."""

    name: str
    group: str
    source: str
    notes: str
    _key: tuple[str, str, str, str]

    #: A chart stores its tangent inside a longer vector only as a Convention with ``embed``.
    embed: Embed | None = None

    # ----------------------------------------------------------------- what each kind supplies
    @abstractmethod
    def dim(self, X: Any = None) -> int:
        """Length of the tangent (at ``X``, where it depends on the element's kind)."""
        ...

    @abstractmethod
    def element(self, X: Any, name: str = "X") -> FloatArray:
        """Validate ``X`` as an element this chart perturbs."""
        ...

    @abstractmethod
    def describe(self) -> str:
        """One line: the name and what the chart is."""
        ...

    @abstractmethod
    def _increment(self, d: Any, so3: bool, name: str = "d") -> FloatArray: ...

    @abstractmethod
    def _retract(self, X: FloatArray, d: FloatArray) -> FloatArray: ...

    @abstractmethod
    def _local(self, X: FloatArray, Y: FloatArray) -> FloatArray: ...

    @abstractmethod
    def _local_jacobian(self, X: FloatArray, Y: FloatArray) -> FloatArray: ...

    @abstractmethod
    def _to_canonical(self, X: FloatArray) -> FloatArray: ...

    @abstractmethod
    def _from_canonical(self, X: FloatArray) -> FloatArray: ...

    # ----------------------------------------------------------------- shared descriptors
    @property
    def fields(self) -> tuple[str, ...]:
        """Return the key of this retraction (a Convention's ``(side, order, chart, rotation)``)."""
        return self._key

    @property
    def is_euler(self) -> bool:
        """Whether the rotation coordinates are absolute Euler angles (a Convention's may be)."""
        return False

    @property
    def record(self) -> Group:
        """The group record of ``group`` (``ValueError`` for a product that is not a group)."""
        return group_record(self.group)

    @property
    def _engine(self) -> Engine:
        return engine_for(self.group)

    @property
    def _array_api(self) -> bool:
        """Whether this chart runs on torch/JAX arrays (a Convention of an array-API group).

        Bundles and navigation states run on numpy.
        """
        return False

    def _inputs(self, *xs: Any) -> tuple[Any, ...]:
        """Return the arguments in one array type.

        The first torch/JAX array's where this chart runs on it, else host numpy copies
        (``arrays.host``: a tensor that requires grad is refused).
        """
        xs = arrays.common(*xs)
        if not arrays.any_foreign(*xs) or self._array_api:  # numpy first: no property lookup
            return xs
        return tuple(arrays.host(x, self.name) for x in xs)

    def _pair(self, X: Any, Y: Any) -> tuple[FloatArray, FloatArray]:
        A, B = self.element(X), self.element(Y, "Y")
        validate.batch_shape(("X", A.shape[:-2]), ("Y", B.shape[:-2]))
        return A, B

    # ----------------------------------------------------------------- the validated maps
    def retract(self, X: Any, d: Any) -> FloatArray:
        """Perturb ``X`` by ``d`` in this chart (broadcast over leading dimensions).

        Parameters
        ----------
        X : array_like, shape (..., m, m)
            Element (an SE(3) convention also takes a rotation (..., 3, 3)).
        d : array_like, shape (..., n)
            Tangent in this chart's order and coordinates.

        Returns
        -------
        ndarray, same kind as ``X``
        """
        X, d = self._inputs(X, d)
        X = self.element(X)
        d = self._increment(d, tuple(X.shape[-2:]) == (3, 3))
        validate.batch_shape(("X", X.shape[:-2]), ("d", d.shape[:-1]))
        return validate.finite_output(self._retract(X, d), f"{self.name}.retract")

    def local(self, X: Any, Y: Any) -> FloatArray:
        """Inverse of :meth:`retract`: the ``d`` with ``retract(X, d) == Y`` (principal branch)."""
        X, Y = self._pair(*self._inputs(X, Y))
        return validate.finite_output(self._local(X, Y), f"{self.name}.local")

    def local_jacobian(self, X: Any, Y: Any) -> FloatArray:
        """Differentiate ``local(X, ·)`` at ``Y`` in this chart's own coordinates.

        Returns ``J = ∂ local(X, retract(Y, δ)) / ∂δ |_{δ=0}``, ``(..., n, n)``, closed
        form. For a coupled chart on the right this is ``Jr⁻¹(local(X, Y))`` (reordered), on the
        left ``Jl⁻¹``; for the split charts it is block diagonal (rotation block from
        :func:`~liebridge.conventions.rotation_coords.d_from_rotation`, vector blocks
        ``A_X⁻¹ A_Y`` in the body frame, ``I`` in the world frame). To differentiate with respect
        to GTSAM's perturbation of ``Y`` instead, multiply by ``tangent_map(Y, "gtsam", self)``.
        False: ``J = I`` (true only at ``Y = X``: the textbook approximation that moves optima).
        """
        X, Y = self._pair(*self._inputs(X, Y))
        return validate.finite_output(self._local_jacobian(X, Y), f"{self.name}.local_jacobian")

    def to_canonical(self, X: Any) -> FloatArray:
        """First-order map ``M``, ``ξ_canonical = M d`` at ``X``.

        It is the derivative at ``d = 0`` of ``canonical.local(X, self.retract(X, d))`` (GTSAM's
        chart of the group: ``X·Exp(ξ)``).
        """
        return validate.finite_output(
            self._to_canonical(self.element(*self._inputs(X))), f"{self.name}.to_canonical"
        )

    def from_canonical(self, X: Any) -> FloatArray:
        """Inverse of :meth:`to_canonical` (closed form, no matrix inversion)."""
        out = self._from_canonical(self.element(*self._inputs(X)))
        return validate.finite_output(out, f"{self.name}.from_canonical")
