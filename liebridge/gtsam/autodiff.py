"""GTSAM factors from a residual written in JAX or torch: Jacobians by automatic differentiation.

The user writes ``residual(*poses, *data) -> (m,)`` of their variables given as **matrices**
(``(4, 4)`` for SE(3), the group's matrix for the others: liebridge's ``[sR t; 0 1]`` for Sim(3),
``(3, 3)`` for SE(2), ``(5, 5)`` for SE₂(3)) in JAX or torch; :func:`autodiff_factor` returns a
``gtsam.CustomFactor`` whose Jacobian for pose ``a`` is

``J_a = ∂/∂d residual(…, conv.retract(X_a, d), …) |_{d=0} · conv.from_canonical(X_a)``,

the first factor taken by forward-mode automatic differentiation (``jax.jacfwd``,
``torch.func.jacfwd``) through the **named convention's retraction** — liebridge's own
:meth:`Convention.retract <liebridge.conventions.Convention.retract>` running on the backend's
arrays (:mod:`liebridge.arrays`; one formula source with the numpy path) — the second the
convention's first-order map from GTSAM's tangent (``ξ``, right perturbation ``X·Exp(ξ)``,
``Pose3``: (ω, v)) to its own (``d = M ξ``): the columns are GTSAM's, whatever the convention
(GTSAM retracts its variables its own way). False, and tempting: using the convention's
Jacobian ``∂r/∂d`` as GTSAM's (right only for a convention equal to GTSAM's to first order).

Batched: every factor built from the same ``residual`` object, convention and backend, with the
same number of keys and shapes of ``data``, is evaluated by :func:`liebridge.gtsam.optimize` in
one vectorised call (``jax.vmap`` under ``jax.jit``, ``torch.func.vmap``), not one Python call per
factor; GTSAM's own optimizers, :class:`~liebridge.gtsam.ISAM2` and ``optimize(batch=False)``
call each factor's callback (the same kernel on a batch of one).

Computations are float64 (JAX: inside ``jax.enable_x64``, without changing the global setting).
The conventions are those of a group GTSAM holds, whatever their rotation coordinates (their
retractions run on torch/JAX arrays); a convention of another group, or one whose tangent sits
inside a longer vector, is refused by name when the factor is built.
"""

from __future__ import annotations

import contextlib
import importlib
import inspect
import weakref
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, cast

import gtsam
import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions import Convention, ConventionLike, get, single_group, unchecked
from .custom import FactorEvaluationError, make_custom_factor
from .groups import GTSAM_GROUPS, GtsamGroup

__all__ = ["AutodiffBatch", "AutodiffSpec", "autodiff_factor"]

BACKENDS = ("jax", "torch")
#: Most keys of a factor the optimizer's batched pass hands to GTSAM (JacobianFactor's limit).
MAX_BATCHED_KEYS = 3


# ------------------------------------------------------------------------------ the kernels
@contextlib.contextmanager
def _x64() -> Iterator[None]:
    import jax

    ctx: Any = getattr(jax, "enable_x64", None)
    if ctx is None:  # older JAX: the same context manager under jax.experimental
        import jax.experimental

        ctx = getattr(jax.experimental, "enable_x64")  # noqa: B009
    with ctx(True):
        yield


def _import(backend: str) -> None:
    try:
        if backend == "jax":
            import jax  # noqa: F401
        else:
            import torch  # noqa: F401
    except ImportError as exc:
        raise ImportError(
            f'backend: {backend!r} needs {backend} installed (pip install ".[{backend}]" '
            "from the liebridge checkout)"
        ) from exc


class _Kernel:
    """The vectorised value and linearization of one (residual, convention, backend, #keys).

    ``value(X, data) -> r``, ``linearize(X, data) -> (r, J)`` with ``X (K, k, n, n)``, data
    arrays ``(K, ...)``, ``r (K, m)``, ``J (K, m, k, dim)`` in the **convention's** tangent
    (:class:`AutodiffBatch` maps it to GTSAM's).
    """

    def __init__(self, residual: Callable[..., Any], conv: Convention, backend: str, k: int):
        # held weakly where it can be: the kernel cache is keyed by the residual, and a strong
        # reference from its value would keep every residual alive for ever (the factors hold it)
        try:  # a bound method: alive as long as its object (the method object itself is transient)
            self._residual: Callable[[], Any] = (
                weakref.WeakMethod(residual)
                if inspect.ismethod(residual)
                else weakref.ref(residual)
            )
        except TypeError:
            self._residual = lambda: residual
        self.conv, self.backend, self.k = conv, backend, k
        self.dim = conv.record.dim
        self.name = getattr(residual, "__name__", type(residual).__name__)
        self._value: Any = None
        self._lin: Any = None
        self._checked = False

    def _build(self) -> None:
        ref, conv, k, dim = self._residual, self.conv, self.k, self.dim
        # the backend's namespace and transforms (imported by name: either may be absent)
        name, fname = ("jax.numpy", "jax") if self.backend == "jax" else ("torch", "torch.func")
        xp: Any = importlib.import_module(name)
        funcs: Any = importlib.import_module(fname)
        vmap, jacfwd = funcs.vmap, funcs.jacfwd

        def value(X: Any, *data: Any) -> Any:
            return ref()(*[X[a] for a in range(k)], *data)

        def perturbed(d: Any, X: Any, *data: Any) -> tuple[Any, Any]:
            # the convention's own retraction, on the backend's arrays (liebridge.arrays)
            r = ref()(*[conv.retract(X[a], d[a]) for a in range(k)], *data)
            return r, r

        def lin(X: Any, *data: Any) -> tuple[Any, Any]:
            d0 = xp.zeros((k, dim), dtype=X.dtype)
            J, r = jacfwd(perturbed, has_aux=True)(d0, X, *data)
            return r, J

        if self.backend == "jax":
            self._value, self._lin = funcs.jit(vmap(value)), funcs.jit(vmap(lin))
        else:
            self._value, self._lin = vmap(value), vmap(lin)

    def _call(self, fn: Any, X: FloatArray, data: Sequence[FloatArray]) -> Any:
        if self.backend == "jax":
            import jax.numpy as jnp

            with _x64():
                return fn(jnp.asarray(X), *[jnp.asarray(a) for a in data])
        import torch

        def tensor(a: FloatArray) -> Any:  # shares writable memory; copies a read-only view
            return torch.from_numpy(a if a.flags.writeable else a.copy())

        with torch.no_grad():
            return fn(tensor(X), *[tensor(a) for a in data])

    def check_retraction(self) -> None:
        """Retract the identity by zero on the backend's arrays: ``ValueError`` if it cannot."""
        if self._checked:
            return
        n = self.conv.record.matrix
        try:
            self._call(lambda X, d: self.conv.retract(X, d), np.eye(n), [np.zeros(self.dim)])
        except Exception as exc:
            raise ValueError(
                f"convention: {self.conv.name!r} ({self.conv.group}, rotation "
                f"{self.conv.rotation!r}): its retraction does not run on {self.backend} arrays "
                f"({type(exc).__name__}: {exc})"
            ) from None
        self._checked = True

    def value_shape(self, X: FloatArray, data: Sequence[FloatArray]) -> tuple[int, ...]:
        """Shape of :meth:`value`'s result (JAX: traced abstractly, nothing compiled)."""
        if self._value is None:
            self._build()
        if self.backend == "jax":
            import jax

            out = self._call(lambda *a: jax.eval_shape(self._value, *a), X, data)
        else:
            out = self._call(lambda *a: self._value(*a), X, data)
        return tuple(int(n) for n in out.shape)

    def value(self, X: FloatArray, data: Sequence[FloatArray]) -> FloatArray:
        if self._value is None:
            self._build()
        r = self._call(lambda *a: self._value(*a), X, data)
        return _numpy(r)

    def linearize(self, X: FloatArray, data: Sequence[FloatArray]) -> tuple[FloatArray, FloatArray]:
        if self._lin is None:
            self._build()
        r, J = self._call(lambda *a: self._lin(*a), X, data)
        return _numpy(r), _numpy(J)


def _numpy(a: Any) -> FloatArray:
    if hasattr(a, "detach"):
        a = a.detach().cpu().numpy()
    return np.asarray(a, dtype=np.float64)


# one kernel per (residual, convention, backend, #keys): factors sharing it are batched together
_KERNELS: weakref.WeakKeyDictionary[Any, dict[tuple[Convention, str, int], _Kernel]] = (
    weakref.WeakKeyDictionary()
)


def _kernel(residual: Callable[..., Any], conv: Convention, backend: str, k: int) -> _Kernel:
    try:
        table = _KERNELS.setdefault(residual, {})
    except TypeError:  # not weakly referenceable: a kernel of its own (correct, batched alone)
        return _Kernel(residual, conv, backend, k)
    if (conv, backend, k) not in table:
        table[conv, backend, k] = _Kernel(residual, conv, backend, k)
    return table[conv, backend, k]


# ------------------------------------------------------------------------------ the factor
@dataclass(frozen=True, eq=False)
class AutodiffSpec:
    """One autodiff factor as the optimizer's batched pass reads it (see :class:`AutodiffBatch`)."""

    kernel: _Kernel
    keys: tuple[int, ...]
    data: tuple[FloatArray, ...]
    sqrt_info: FloatArray  # upper-triangular R with RᵀR = Σ⁻¹ (GTSAM's noiseModel.R())


def _noise(noise: Any) -> Any:
    if isinstance(noise, gtsam.noiseModel.Base):
        return noise
    if isinstance(noise, (str, bytes)) or not hasattr(noise, "__len__"):
        raise TypeError(
            "noise: expected a gtsam noise model or a covariance matrix (m, m), got "
            f"{type(noise).__name__}"
        )
    cov = np.asarray(noise, dtype=np.float64) if not hasattr(noise, "detach") else _numpy(noise)
    if cov.ndim != 2 or cov.shape[0] != cov.shape[1]:
        raise ValueError(f"noise: expected a square covariance matrix (m, m), got {cov.shape}")
    cov = validate.positive_definite(cov, "noise", cov.shape[0])
    return gtsam.noiseModel.Gaussian.Covariance(np.ascontiguousarray(cov))


def _data(data: Any) -> tuple[FloatArray, ...]:
    if data is None:
        return ()
    if not isinstance(data, (tuple, list)):
        raise TypeError(f"data: expected a tuple of arrays, got {type(data).__name__}")
    out = []
    for n, a in enumerate(data):
        arr = _numpy(a) if hasattr(a, "detach") else np.asarray(a, dtype=np.float64)
        if not np.isfinite(arr).all():
            bad = np.argwhere(~np.isfinite(arr))[0].tolist()
            raise ValueError(f"data[{n}]: not finite at index {bad} (shape {arr.shape})")
        out.append(np.ascontiguousarray(arr))
    return tuple(out)


def _probe(kernel: _Kernel, rec: GtsamGroup, data: tuple[FloatArray, ...], m: int) -> None:
    """Call the residual once on identity poses: a wrong signature or size fails here, clearly."""
    n = rec.group.matrix
    X = np.broadcast_to(np.eye(n), (1, kernel.k, n, n)).copy()
    try:
        shape = kernel.value_shape(X, [a[None] for a in data])
    except Exception as exc:
        raise TypeError(
            f"residual: {kernel.name}(*poses, *data) with {kernel.k} poses ({n}, {n}) and "
            f"{len(data)} data arrays could not be evaluated ({kernel.backend}, vectorised with "
            f"vmap): {type(exc).__name__}: {exc}"
        ) from exc
    if shape != (1, m):
        raise ValueError(
            f"residual: {kernel.name} returned shape {shape[1:]}; expected ({m},), the noise "
            "model's dimension"
        )


def autodiff_factor(
    residual: Callable[..., Any],
    keys: Sequence[int],
    noise: Any,
    convention: ConventionLike,
    backend: str = "jax",
    *,
    data: Sequence[Any] | None = None,
) -> Any:
    """GTSAM factor of a residual written in JAX or torch, with automatic-differentiation Jacobians.

    Parameters
    ----------
    residual : callable
        ``residual(*poses, *data) -> (m,)``: one pose per key, as the group's matrix (``(4, 4)``
        ``[R t; 0 1]`` for SE(3), ``T_world_key``: maps the key's frame to the world's) in the
        backend's array type (``jax.Array`` or ``torch.Tensor``, float64); ``data`` arrays follow
        the poses. It must be traceable by ``vmap`` and forward-mode differentiation: no Python
        ``if`` on values (use ``where``), no in-place writes to its inputs, no ``.item()``; where it
        takes a ``log`` near zero, its gradient there must be finite (a Taylor branch selected
        with ``where``, its argument made safe by a second ``where``).
    keys : sequence of int
        GTSAM keys, one per pose argument, in that order; every one holds an element of the
        convention's group (``Pose3`` for SE(3) conventions).
    noise : gtsam.noiseModel.Base or array_like, shape (m, m)
        Noise model of the residual, or its covariance. Gaussian models (``Gaussian``,
        ``Diagonal``, ``Isotropic``, ``Unit``) are batched by :func:`liebridge.gtsam.optimize`;
        a robust model is evaluated by GTSAM through the callback.
    convention : Convention or str
        The convention whose retraction the residual is differentiated through,
        ``∂ residual(X ⊕ d) / ∂d`` at ``d = 0``; the result is delivered in GTSAM's tangent columns
        (times ``convention.from_canonical(X)``). Its group says what the keys hold.
    backend : {"jax", "torch"}
        The framework ``residual`` is written in.
    data : sequence of array_like, optional (keyword only)
        Per-factor constants (a measurement, a point), passed as float64 backend arrays after
        the poses. Factors sharing ``residual`` and data shapes are evaluated in one vectorised
        call; a measurement captured in a closure per factor works too, but is a new function
        each time and so a batch of its own.

    Returns
    -------
    gtsam.CustomFactor
        ``error`` is ``residual`` at the keys' values; Jacobians with respect to GTSAM's own
        perturbation of each key (``Pose3``: ``X·Exp(ξ)``, ξ = (ω, v)).

    Raises
    ------
    ValueError
        Unknown backend, a convention autodiff factors cannot retract through, a residual whose
        size is not the noise model's, duplicate keys, non-finite ``data``.
    TypeError
        ``residual`` not callable or failing on identity poses, ``noise`` of the wrong kind.
    ImportError
        The backend is not installed (``pip install ".[jax]"`` or ``".[torch]"``).

    Examples
    --------
    A between factor, ``Log(Z⁻¹·X_i⁻¹·X_j)`` (GTSAM's ``BetweenFactorPose3`` error), in torch,
    given a differentiable ``se3_log`` (``examples/autodiff_factor.py``)::

        def between(Xi, Xj, Z):
            return se3_log(torch.linalg.inv(Z) @ torch.linalg.inv(Xi) @ Xj)

        f = lb.gtsam.autodiff_factor(between, [1, 2], noise, "gtsam", "torch", data=(Z,))
    """
    if not callable(residual):
        raise TypeError(f"residual: expected a callable, got {type(residual).__name__}")
    if backend not in BACKENDS:
        raise ValueError(f"backend: expected one of {BACKENDS}, got {backend!r}")
    conv = single_group(get(convention))
    if conv.embed is not None or conv.group not in GTSAM_GROUPS:
        raise ValueError(
            f"convention: {conv.name!r} is a convention of {conv.group}"
            f"{' stored inside a longer vector' if conv.embed is not None else ''}; autodiff "
            f"factors take a convention of a group GTSAM holds ({', '.join(GTSAM_GROUPS)}), "
            "its tangent its own"
        )
    rec = GTSAM_GROUPS[conv.group]
    if isinstance(keys, (int, np.integer)) or not isinstance(keys, Sequence):
        raise TypeError(f"keys: expected a sequence of integer keys, got {type(keys).__name__}")
    keys = [validate.key(k, f"keys[{n}]") for n, k in enumerate(keys)]
    if not keys:
        raise ValueError("keys: a factor needs at least one key")
    _import(backend)
    model = _noise(noise)
    m = int(model.dim())
    arrays = _data(data)
    kernel = _kernel(residual, conv, backend, len(keys))
    kernel.check_retraction()
    _probe(kernel, rec, arrays, m)
    dim = kernel.dim

    def evaluate(
        values: Any, want: bool, _keep: Any = residual
    ) -> tuple[FloatArray, list[FloatArray] | None]:  # _keep: the factor holds its residual
        X = np.stack([rec.element_at(values, k) for k in keys])[None]
        batch = [a[None] for a in arrays]
        if not want:
            return kernel.value(X, batch)[0], None
        r, J = kernel.linearize(X, batch)
        M = unchecked.from_canonical(conv, X[0])  # (k, dim, dim): GTSAM's tangent → conv's
        return r[0], [J[0, :, a] @ M[a] for a in range(len(keys))]

    gaussian = isinstance(model, gtsam.noiseModel.Gaussian) and not isinstance(
        model, gtsam.noiseModel.Constrained
    )
    spec = None
    if gaussian and rec.read_all is not None and len(keys) <= MAX_BATCHED_KEYS:
        spec = AutodiffSpec(kernel, tuple(keys), arrays, np.asarray(model.R(), dtype=np.float64))
    return make_custom_factor(
        model, keys, [dim] * len(keys), evaluate, name=f"autodiff[{kernel.name}]", spec=spec
    )


# ------------------------------------------------------------------------------ the batched pass
@dataclass
class _Group:
    """Factors sharing one kernel and data shapes, stacked."""

    kernel: _Kernel
    keys: np.ndarray  # (K, k) uint64
    rows: np.ndarray  # (K, k) rows into the group's pose array
    data: tuple[FloatArray, ...]  # (K, ...) each
    R: FloatArray  # (K, m, m)
    at: np.ndarray  # (K, k·dim): where each factor's δ sits in the solution vector


class AutodiffBatch:
    """Every batched autodiff factor of a graph, bound to the graph's keys (see the module doc).

    :meth:`evaluate` returns the error and the stacked poses it read; :meth:`linearize` appends
    one whitened ``JacobianFactor`` (unit noise) per factor to a ``GaussianFactorGraph`` and
    returns the stacked system, which :meth:`linear_error` evaluates at a solution vector.
    """

    def __init__(self, specs: list[AutodiffSpec], values: Any, offset: dict[int, int]) -> None:
        """Group ``specs``; ``offset[k]``: where key ``k``'s block starts in a solution vector."""
        by: dict[tuple[Any, ...], list[AutodiffSpec]] = {}
        for s in specs:
            sig = (id(s.kernel), tuple(a.shape for a in s.data), s.sqrt_info.shape)
            by.setdefault(sig, []).append(s)
        self.groups: list[_Group] = []
        self.pose_keys: dict[str, np.ndarray] = {}
        for members in by.values():
            kern = members[0].kernel
            g = kern.conv.group
            if g not in self.pose_keys:
                self.pose_keys[g] = GTSAM_GROUPS[g].read_all(values, None)[0]  # type: ignore[misc]
            all_keys = self.pose_keys[g]
            keys = np.array([s.keys for s in members], dtype=np.uint64)
            rows = np.searchsorted(all_keys, keys)
            rows = np.clip(rows, 0, len(all_keys) - 1)
            if len(all_keys) == 0 or (all_keys[rows] != keys).any():
                bad = keys[all_keys[rows] != keys] if len(all_keys) else keys
                raise ValueError(
                    f"values: no {GTSAM_GROUPS[g].cls} for key {int(bad.flat[0])} of an autodiff "
                    f"factor ({kern.name})"
                )
            d = np.arange(kern.dim)
            at = np.array(
                [[offset[int(k)] + i for k in s.keys for i in d] for s in members], dtype=np.int64
            )
            data = tuple(
                np.stack([s.data[n] for s in members]) for n in range(len(members[0].data))
            )
            R = np.stack([s.sqrt_info for s in members])
            self.groups.append(_Group(kern, keys, rows, data, R, at))

    def __len__(self) -> int:
        return sum(len(g.keys) for g in self.groups)

    def poses(self, values: Any) -> list[FloatArray]:
        """Stacked poses ``(K, k, n, n)`` of every group at ``values``."""
        read = {
            g: GTSAM_GROUPS[g].read_all(values, keys)[1]  # type: ignore[misc]
            for g, keys in self.pose_keys.items()
        }
        return [read[g.kernel.conv.group][g.rows] for g in self.groups]

    def _check(self, g: _Group, what: str, arr: FloatArray) -> None:
        bad = ~np.isfinite(arr.reshape(len(arr), -1)).all(axis=1)
        if bad.any():
            n = int(np.flatnonzero(bad)[0])
            raise FactorEvaluationError(
                f"autodiff[{g.kernel.name}] on keys {[int(k) for k in g.keys[n]]}: {what} is not "
                f"finite (batch index {n} of {len(arr)})"
            )

    def evaluate(self, values: Any) -> tuple[float, list[FloatArray]]:
        """``½ Σ ‖R r‖²`` over every factor at ``values``, and the stacked poses read there."""
        X = self.poses(values)
        err = 0.0
        for g, Xg in zip(self.groups, X, strict=True):
            r = g.kernel.value(Xg, g.data)
            self._check(g, "the residual", r)
            w = np.einsum("kij,kj->ki", g.R, r)
            err += 0.5 * float(np.einsum("ki,ki->", w, w))
        return err, X

    def linearize(
        self, X: list[FloatArray], linear: Any
    ) -> list[tuple[FloatArray, FloatArray, np.ndarray]]:
        """Append the whitened factors at the poses ``X`` (from :meth:`evaluate`) to ``linear``.

        Returns ``[(A (K, m, k·dim), b (K, m), at (K, k·dim))]`` per group.
        """
        system = []
        for g, Xg in zip(self.groups, X, strict=True):
            kern = g.kernel
            r, J = kern.linearize(Xg, g.data)  # J (K, m, k, dim) in the convention's tangent
            self._check(g, "the residual", r)
            self._check(g, "a Jacobian", J)
            K, k, dim = len(Xg), kern.k, kern.dim
            M = unchecked.from_canonical(kern.conv, Xg)  # (K, k, dim, dim)
            J = np.einsum("kmad,kade->kmae", J, M).reshape(K, -1, k * dim)
            A = g.R @ J
            b = -np.einsum("kij,kj->ki", g.R, r)
            unit = gtsam.noiseModel.Unit.Create(b.shape[-1])
            add, factor = linear.add, cast(Any, gtsam.JacobianFactor)
            for n in range(K):
                blocks: list[Any] = []
                for a in range(k):
                    blocks += [
                        int(g.keys[n, a]),
                        np.ascontiguousarray(A[n, :, a * dim : (a + 1) * dim]),
                    ]
                add(factor(*blocks, b[n], unit))
            system.append((A, b, g.at))
        return system

    @staticmethod
    def linear_error(
        system: list[tuple[FloatArray, FloatArray, np.ndarray]], delta: FloatArray
    ) -> float:
        """``½ Σ ‖A δ − b‖²`` of :meth:`linearize`'s factors at the solution vector ``delta``."""
        err = 0.0
        for A, b, at in system:
            res = np.einsum("kij,kj->ki", A, np.take(delta, at)) - b
            err += 0.5 * float(np.einsum("ki,ki->", res, res))
        return err

    @staticmethod
    def error_at_zero(system: list[tuple[FloatArray, FloatArray, np.ndarray]]) -> float:
        """``½ Σ ‖b‖²``: :meth:`linear_error` at ``δ = 0``."""
        return sum(0.5 * float(np.einsum("ki,ki->", b, b)) for _, b, _ in system)
