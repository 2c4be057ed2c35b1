"""The group record: a Lie group declared once, read by every layer.

A :class:`Group` says everything the rest of liebridge needs to know about a matrix Lie group:
its name, tangent dimension and matrix size, where the rotation, the translation-like vectors and
the log-scale sit in its **canonical tangent** (GTSAM's order for the groups GTSAM has), the
element validator, the unchecked kernels (:class:`Kernels`), the names of its charts and a probe
element. Each shipped group registers its record once, at the bottom of ``lie/<group>.py``; a user
registers their own with :func:`register`. After that the conventions
(``Convention(group=...)``), the conversions, detection, the numerical checks and the factors work
for it without any edit to liebridge.

The record's methods are the validated public kernels (validate → unchecked kernel → finite
output), so every group has the same functions under the same names::

    >>> from liebridge import lie
    >>> g = lie.group("se2")
    >>> X = g.exp([1.0, 2.0, 0.5])            # (vx, vy, ω): GTSAM Pose2 order
    >>> bool(abs(g.log(X) - [1.0, 2.0, 0.5]).max() < 1e-12)
    True

Conventions of a record, stated once here:

* an element is a ``(..., matrix, matrix)`` array acting on homogeneous column vectors;
* ``exp``/``log`` are the group's own exponential and principal logarithm in the canonical order;
* ``jr(ξ)``: ``Exp(ξ + δ) ≈ Exp(ξ)·Exp(jr(ξ) δ)``; ``jl(ξ)``: ``Exp(ξ + δ) ≈ Exp(jl(ξ) δ)·Exp(ξ)``;
* ``adjoint(X)``: ``X·Exp(ξ)·X⁻¹ = Exp(Ad_X ξ)`` (tempting and false: ``Exp(ξ)·X = X·Exp(Ad_X ξ)``,
  which needs ``Ad_{X⁻¹}``);
* ``interpolate(X0, X1, τ) = X0·Exp(τ·Log(X0⁻¹X1))`` (``τ = 0`` gives ``X0``, ``τ = 1`` ``X1``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray

Unary = Callable[[FloatArray], FloatArray]
Binary = Callable[[FloatArray, FloatArray], FloatArray]
Check = Callable[[Any, str], FloatArray]

#: The names of the kernels every group has (:class:`Kernels`), in the order of its fields.
KERNEL_NAMES = (
    "exp",
    "log",
    "inverse",
    "compose",
    "act",
    "adjoint",
    "jr",
    "jl",
    "jr_inv",
    "jl_inv",
    "interpolate",
)


@dataclass(frozen=True)
class Kernels:
    """A group's kernels **without validation**: float64 arrays of the right trailing shape in.

    ``exp``, ``log``, ``inverse``, ``adjoint``, ``jr_inv`` and ``jl_inv`` are required. The others
    default to the matrix-group formulas: ``compose`` the matrix product, ``act`` ``A x + b``
    (top-left block and last column), ``jr``/``jl`` the matrix inverses of ``jr_inv``/``jl_inv``,
    ``interpolate`` the geodesic ``X0·Exp(τ·Log(X0⁻¹X1))``. ``scale`` (required when the group
    has a log-scale coordinate) returns the scale ``s`` of an element ``(..., )``.
    """

    exp: Unary
    log: Unary
    inverse: Unary
    adjoint: Unary
    jr_inv: Unary
    jl_inv: Unary
    jr: Unary | None = None
    jl: Unary | None = None
    compose: Binary | None = None
    act: Binary | None = None
    interpolate: Callable[[FloatArray, FloatArray, FloatArray], FloatArray] | None = None
    scale: Unary | None = None


def _inv(A: Any) -> Any:
    xp = arrays.namespace(A)
    return np.linalg.inv(A) if xp is np else xp.linalg.inv(A)


def _mv(A: FloatArray, x: FloatArray) -> FloatArray:
    return arrays.matvec(A, x)


@dataclass(frozen=True, eq=False)
class Group:
    """A matrix Lie group as data (see the module docstring).

    Parameters
    ----------
    name : str
        Registry name (``"se3"``), the value of ``Convention.group``.
    dim, matrix : int
        Tangent dimension and matrix size.
    rot : slice or None
        The rotation coordinates in the canonical tangent (``None``: no rotation, e.g. the
        translation group).
    vecs : tuple of slice
        The translation-like blocks of the canonical tangent (SE₂(3): position and velocity).
    cols : tuple of int
        The matrix column holding each block of ``vecs``.
    scale : int or None
        Index of the log-scale coordinate (Sim(3)), or ``None``.
    element : callable ``(X, name) -> ndarray``
        The element validator: raises ``ValueError`` naming ``name``, the batch index and the size
        of the violation; returns a float64 array.
    kernels : Kernels
        The unchecked kernels.
    charts : tuple of str
        Chart names: the coupled chart (the group's exponential) first, then the split ones
        (rotation and vectors perturbed separately, vector increment in the body frame, then in
        the world frame). Default ``(name, "split_body", "split_world")`` for a group with a
        rotation and vectors, ``(name,)`` otherwise.
    probe : ndarray, optional
        A generic element (no symmetry) that detection and the checks perturb.
    label : str
        Display name (``"SE(3)"``); default the upper-case name.
    tangent_doc : str
        The canonical tangent's coordinates in words (``"(ω, v)"``).
    note : str
        One line for tables (``"extended pose / navigation state"``).
    chart_aliases : dict
        Other spellings of chart names (SE(3)'s ``split_body`` is ``so3xr3_body``).
    array_api : bool
        Whether the kernels are written against the array API (:mod:`liebridge.arrays`), so that
        they, and the conventions of the group, run on torch and JAX arrays. ``False``: torch/JAX
        inputs are copied to the host and the results are numpy (a traced array or a tensor that
        requires grad is refused with ``TypeError``).
    """

    name: str
    dim: int
    matrix: int
    rot: slice | None
    vecs: tuple[slice, ...]
    cols: tuple[int, ...]
    scale: int | None
    element: Check
    kernels: Kernels
    charts: tuple[str, ...] = ()
    probe: FloatArray | None = None
    label: str = ""
    tangent_doc: str = ""
    note: str = ""
    chart_aliases: dict[str, str] = field(default_factory=dict)
    array_api: bool = False

    def __post_init__(self) -> None:
        if not (isinstance(self.name, str) and self.name.isidentifier()):
            raise ValueError(f"Group.name: expected an identifier, got {self.name!r}")
        for f in ("dim", "matrix"):
            v = getattr(self, f)
            if not (isinstance(v, int) and v >= 1):
                raise ValueError(f"Group {self.name!r}: {f} must be a positive int, got {v!r}")
        if not isinstance(self.kernels, Kernels):
            raise TypeError(f"Group {self.name!r}: kernels must be a Kernels record")
        if len(self.vecs) != len(self.cols):
            raise ValueError(f"Group {self.name!r}: vecs and cols must have the same length")
        covered = [i for s in self._blocks() for i in range(s.start, s.stop)]
        covered += [] if self.scale is None else [self.scale]
        if sorted(covered) != list(range(self.dim)):
            raise ValueError(
                f"Group {self.name!r}: rot, vecs and scale must cover range({self.dim}) once, "
                f"got {sorted(covered)}"
            )
        if self.scale is not None and self.kernels.scale is None:
            raise ValueError(f"Group {self.name!r}: a scale coordinate needs a scale kernel")
        if not self.charts:
            split = self.vecs or self.scale is not None
            charts = (
                (self.name, "split_body", "split_world") if split and self.rot else (self.name,)
            )
            object.__setattr__(self, "charts", charts)
        if not self.label:
            object.__setattr__(self, "label", self.name.upper())

    def _blocks(self) -> list[slice]:
        return ([self.rot] if self.rot is not None else []) + list(self.vecs)

    # ----------------------------------------------------------------- layout
    @property
    def rot_dim(self) -> int:
        """Number of rotation coordinates: 0 (none), 1 (planar) or 3 (spatial)."""
        return 0 if self.rot is None else self.rot.stop - self.rot.start

    @property
    def coupled_chart(self) -> str:
        """The name of the chart that uses the group's own exponential."""
        return self.charts[0]

    def chart(self, name: str) -> str:
        """Return the registered spelling of chart ``name`` (aliases resolved), else raise."""
        name = self.chart_aliases.get(name, name)
        if name not in self.charts:
            raise ValueError(
                f"Convention.chart: expected one of {self.charts} for group {self.name!r}, "
                f"got {name!r}"
            )
        return name

    def split_frame(self, chart: str) -> str | None:
        """``"body"``/``"world"`` for a split chart, ``None`` for the coupled one."""
        i = self.charts.index(self.chart(chart))
        return None if i == 0 else ("body" if i == 1 else "world")

    def perm(self, order: str) -> FloatArray:
        """Canonical index of each coordinate of a tangent in ``order``.

        ``rot_first``: rotation, then the vectors (then the scale); ``trans_first``: the vectors,
        then the rotation (then the scale).
        """
        rot = [] if self.rot is None else list(range(self.rot.start, self.rot.stop))
        vec = [i for s in self.vecs for i in range(s.start, s.stop)]
        tail = [self.scale] if self.scale is not None else []
        return np.array((rot + vec if order == "rot_first" else vec + rot) + tail)

    @property
    def canonical_order(self) -> Literal["rot_first", "trans_first"]:
        """``rot_first`` if the canonical tangent starts with the rotation, else ``trans_first``."""
        return "rot_first" if self.rot is None or self.rot.start == 0 else "trans_first"

    def identity(self) -> FloatArray:
        """Return the identity element ``(matrix, matrix)``."""
        return np.eye(self.matrix)

    def __repr__(self) -> str:
        return f"Group({self.name!r}, dim={self.dim}, matrix={self.matrix})"

    # ----------------------------------------------------------------- validated kernels
    def tangent(self, xi: Any, name: str = "xi") -> FloatArray:
        """Validate tangents ``(..., dim)`` (rotation part bounded, see ``_validate.tangent``)."""
        if self.rot is None:
            return validate.vector(xi, name, self.dim)
        return validate.tangent(xi, name, self.dim, self.rot)

    def _out(self, out: FloatArray, op: str) -> FloatArray:
        out = out if arrays.is_foreign(out) else np.asarray(out, dtype=np.float64)
        return validate.finite_output(out, f"{self.name}.{op}")

    def _inputs(self, *xs: Any) -> tuple[Any, ...]:
        """Return the arguments in one array type.

        The first torch/JAX array's where the kernels are array-generic (:attr:`array_api`), else
        host numpy copies (see ``arrays.host``).
        """
        xs = arrays.common(*xs)
        if self.array_api or not arrays.any_foreign(*xs):
            return xs
        return tuple(arrays.host(x, self.name) for x in xs)

    def exp(self, xi: Any) -> FloatArray:
        """Exponential: canonical tangent ``(..., dim)`` → element ``(..., matrix, matrix)``."""
        (xi,) = self._inputs(xi)
        return self._out(self.kernels.exp(self.tangent(xi)), "exp")

    def log(self, X: Any) -> FloatArray:
        """Principal logarithm: element → canonical tangent ``(..., dim)``."""
        (X,) = self._inputs(X)
        return self._out(self.kernels.log(self.element(X, "X")), "log")

    def inverse(self, X: Any) -> FloatArray:
        """``X⁻¹``: ``inverse(T_a_b) = T_b_a``."""
        (X,) = self._inputs(X)
        return self._out(self.kernels.inverse(self.element(X, "X")), "inverse")

    def compose(self, X1: Any, X2: Any) -> FloatArray:
        """``X1·X2`` (broadcast): ``compose(T_a_b, T_b_c) = T_a_c``."""
        X1, X2 = self._inputs(X1, X2)
        A, B = self.element(X1, "X1"), self.element(X2, "X2")
        validate.batch_shape(("X1", tuple(A.shape[:-2])), ("X2", tuple(B.shape[:-2])))
        f = self.kernels.compose
        return self._out(f(A, B) if f is not None else A @ B, "compose")

    def act(self, X: Any, x: Any) -> FloatArray:
        """Apply ``A x + b`` to points ``(..., k)``, ``k = matrix − len(cols)``.

        ``A`` is the top-left ``k × k`` block and ``b`` the first vector column (SE₂(3): the
        position, not the velocity); a rotation group acts as ``R x``. The group's own ``act``
        kernel may say otherwise.
        """
        X, x = self._inputs(X, x)
        Xa = self.element(X, "X")
        n = self.matrix - len(self.cols)
        xa = validate.vector(x, "x", n)
        validate.batch_shape(("X", tuple(Xa.shape[:-2])), ("x", tuple(xa.shape[:-1])))
        f = self.kernels.act
        if f is not None:
            return self._out(f(Xa, xa), "act")
        if not self.cols:
            return self._out(_mv(Xa, xa), "act")
        out = _mv(Xa[..., :n, :n], xa) + Xa[..., :n, self.cols[0]]
        return self._out(out, "act")

    def adjoint(self, X: Any) -> FloatArray:
        """``Ad_X``, ``(..., dim, dim)``: ``X·Exp(ξ)·X⁻¹ = Exp(Ad_X ξ)``."""
        (X,) = self._inputs(X)
        return self._out(self.kernels.adjoint(self.element(X, "X")), "adjoint")

    def jr(self, xi: Any) -> FloatArray:
        """Right Jacobian: ``Exp(ξ + δ) ≈ Exp(ξ)·Exp(jr(ξ) δ)``."""
        (xi,) = self._inputs(xi)
        x = self.tangent(xi)
        f = self.kernels.jr
        out: Any = f(x) if f is not None else _inv(self.kernels.jr_inv(x))
        return self._out(out, "jr")

    def jl(self, xi: Any) -> FloatArray:
        """Left Jacobian: ``Exp(ξ + δ) ≈ Exp(jl(ξ) δ)·Exp(ξ)``."""
        (xi,) = self._inputs(xi)
        x = self.tangent(xi)
        f = self.kernels.jl
        out: Any = f(x) if f is not None else _inv(self.kernels.jl_inv(x))
        return self._out(out, "jl")

    def jr_inv(self, xi: Any) -> FloatArray:
        """Inverse right Jacobian: the derivative of ``Log(Exp(ξ)·Exp(δ))`` at ``δ = 0``."""
        (xi,) = self._inputs(xi)
        return self._out(self.kernels.jr_inv(self.tangent(xi)), "jr_inv")

    def jl_inv(self, xi: Any) -> FloatArray:
        """Inverse left Jacobian: the derivative of ``Log(Exp(δ)·Exp(ξ))`` at ``δ = 0``."""
        (xi,) = self._inputs(xi)
        return self._out(self.kernels.jl_inv(self.tangent(xi)), "jl_inv")

    def interpolate(self, X0: Any, X1: Any, tau: Any) -> FloatArray:
        """Geodesic ``X0·Exp(τ·Log(X0⁻¹X1))``; ``τ`` broadcasts against the batch."""
        X0, X1, tau = self._inputs(X0, X1, tau)
        A, B = self.element(X0, "X0"), self.element(X1, "X1")
        t = tau if arrays.is_foreign(tau) else validate.as_float_array(tau, "tau")
        validate.check_finite(t, "tau", core_ndim=0)
        validate.batch_shape(
            ("X0", tuple(A.shape[:-2])), ("X1", tuple(B.shape[:-2])), ("tau", tuple(t.shape))
        )
        f = self.kernels.interpolate
        if f is not None:
            return self._out(f(A, B, t), "interpolate")
        k = self.kernels
        xi = self.tangent(t[..., None] * k.log(k.inverse(A) @ B), "tau·Log(X0⁻¹X1)")
        return self._out(A @ k.exp(xi), "interpolate")


#: Every registered group, by name (shipped ones first, then the user's, in registration order).
GROUPS: dict[str, Group] = {}


def register(group: Group, *, replace: bool = False) -> Group:
    """Register ``group`` under ``group.name`` and return it.

    After this ``lie.group(name)``, ``Convention(group=name)`` and every layer built on them work
    for it. Registering a second record under a registered name raises ``ValueError`` unless
    ``replace=True`` (the shipped groups cannot be replaced).
    """
    if not isinstance(group, Group):
        raise TypeError(f"register: expected a liebridge.lie.Group, got {type(group).__name__}")
    old = GROUPS.get(group.name)
    if old is not None and old is not group:
        if not replace or group.name in _SHIPPED:
            raise ValueError(f"register: a group named {group.name!r} is already registered")
    GROUPS[group.name] = group
    return group


_SHIPPED: set[str] = set()
#: The shipped groups' order in :data:`GROUPS` (whatever order their modules are imported in).
_SHIPPED_ORDER = ("so2", "se2", "so3", "se3", "sim3", "se23")


def register_shipped(group: Group) -> Group:
    """Register one of liebridge's own groups (cannot be replaced later)."""
    register(group)
    _SHIPPED.add(group.name)
    rank = {n: k for k, n in enumerate(_SHIPPED_ORDER)}
    ordered = sorted(GROUPS.items(), key=lambda kv: rank.get(kv[0], len(rank)))
    GROUPS.clear()
    GROUPS.update(ordered)
    return group


def group(name: str | Group) -> Group:
    """Return the record of the group called ``name`` (a :class:`Group` is returned unchanged).

    Raises ``ValueError`` naming the registered groups for an unknown name.
    """
    if isinstance(name, Group):
        return name
    rec = GROUPS.get(name) if isinstance(name, str) else None
    if rec is None:
        raise ValueError(f"group: unknown group {name!r} (registered: {', '.join(GROUPS)})")
    return rec
