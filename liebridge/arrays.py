"""Array backends: numpy, torch and JAX through one set of formulas.

liebridge's kernels and conventions are written once, against the operations the Python array API
standard names (``xp.sin``, ``xp.where``, ``xp.stack``, ``@``, …). A numpy array runs them with
numpy itself (and the optional compiled passes, which are fast paths of the same formulas); a
``torch.Tensor`` or a JAX array runs them with its own namespace, through `array-api-compat
<https://data-apis.org/array-api-compat/>`_, and the result is an array of the caller's type, on
the caller's device, in the caller's dtype, differentiable (no host round trip, no in-place write).

This module holds only the mechanics: which namespace an array belongs to, whether it is being
traced (``jax.jit``, ``torch.compile``: value checks are skipped there, shapes still checked),
building a matrix from its entries, and the host copy used to word an error message. Validation
itself is :mod:`liebridge._validate`'s.

Adding a backend: an array whose namespace array-api-compat resolves works once its top-level
module is in :data:`BACKENDS` (and, if it traces, :func:`is_traced` knows its tracer).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from typing import Any, ParamSpec, TypeVar

import numpy as np

#: Top-level modules of the array types that run the array-generic formulas (numpy runs its own).
BACKENDS = frozenset({"torch", "jax", "jaxlib"})

_INSTALL = {
    "torch": 'pip install ".[torch]" (in the checkout)',
    "jax": 'pip install ".[jax]" (in the checkout)',
}


def backend_of(x: Any) -> str | None:
    """Return ``"torch"`` or ``"jax"`` for an array of those libraries, else ``None``.

    Only the module name of ``type(x)`` is read: nothing is imported.
    """
    root = type(x).__module__.partition(".")[0]
    if root not in BACKENDS:
        return None
    return "torch" if root == "torch" else "jax"


def is_foreign(x: Any) -> bool:
    """Whether ``x`` is a torch or JAX array (runs the array-generic formulas, not numpy's)."""
    return backend_of(x) is not None


def any_foreign(*xs: Any) -> bool:
    """Whether any of ``xs`` is a torch or JAX array."""
    return any(is_foreign(x) for x in xs)


def namespace(*xs: Any) -> Any:
    """Return the array namespace of ``xs`` (numpy for numpy arrays; torch's or JAX's otherwise)."""
    foreign = [x for x in xs if is_foreign(x)]
    if not foreign:
        return np
    try:
        import array_api_compat
    except ImportError:  # pragma: no cover - the torch/jax extras install it
        kind = backend_of(foreign[0]) or "torch"
        raise ImportError(
            f"liebridge on {kind} arrays needs array-api-compat: {_INSTALL[kind]}"
        ) from None
    try:
        return array_api_compat.array_namespace(*foreign)
    except TypeError as exc:
        raise TypeError(f"arrays of different libraries in one call: {exc}") from None


def is_traced(x: Any) -> bool:
    """Whether ``x`` is a placeholder being traced (``jax.jit``/``vmap``, ``torch.compile``).

    Values of a traced array are not known: validation checks shapes only.
    """
    kind = backend_of(x)
    if kind == "jax":
        import jax

        return isinstance(x, jax.core.Tracer)
    if kind == "torch":
        import torch

        return bool(torch.compiler.is_compiling())
    return False


def all_true(mask: Any) -> bool | None:
    """``bool(all(mask))``, or ``None`` where the value is not known (tracing, ``torch.func``)."""
    if is_traced(mask):
        return None
    xp = namespace(mask)
    try:
        return bool(xp.all(mask))
    except RuntimeError:  # torch.func.vmap/grad: data-dependent control flow is refused there
        return None


def to_numpy(x: Any) -> np.ndarray:
    """Return a detached host numpy copy of ``x`` (for error messages and numpy-only code)."""
    if backend_of(x) == "torch":
        return np.asarray(x.detach().cpu().numpy())
    return np.asarray(x)


#: Readers of other libraries' pose objects that hold tensors (PyPose ``LieTensor``, lietorch,
#: Theseus, kornia, jaxlie), by top-level module: ``root → reader(obj, name) -> matrix`` in the
#: object's own array type. :mod:`liebridge.interop` registers them (this floor names no library).
OBJECT_READERS: dict[str, Callable[[Any, str], Any]] = {}


def unwrap(x: Any, name: str) -> Any:
    """``x``'s homogeneous matrix if it is a registered library's pose object, else ``x``."""
    reader = OBJECT_READERS.get(type(x).__module__.partition(".")[0])
    return reader(x, name) if reader is not None else x


def common(*xs: Any) -> tuple[Any, ...]:
    """``xs`` with numpy arrays, lists and numbers moved to the first torch/JAX array's type.

    Mixed calls (a tensor pose and a numpy increment) then run on the tensor's namespace, device
    and dtype; anything else (another library's pose object, a string) is left for validation.
    """
    if OBJECT_READERS:
        xs = tuple(unwrap(x, "argument") for x in xs)
    ref = next((x for x in xs if is_foreign(x)), None)
    if ref is None:
        return xs
    out = []
    for x in xs:
        if not is_foreign(x) and isinstance(x, (np.ndarray, list, tuple, int, float)):
            try:
                x = like(np.asarray(x, dtype=np.float64), ref)
            except (TypeError, ValueError):
                pass  # validation words the error
        out.append(x)
    return tuple(out)


def host(x: Any, where: str) -> Any:
    """``x`` as a host numpy array for numpy-only code (other values unchanged).

    A traced array, or a tensor that requires grad, is refused with ``TypeError``: copying it to
    the host would silently cut the gradient.
    """
    if not is_foreign(x):
        return x
    if is_traced(x) or bool(getattr(x, "requires_grad", False)):
        raise TypeError(
            f"{where}: runs on numpy arrays only; a {type(x).__module__}.{type(x).__name__} that "
            "is traced or requires grad would lose its gradient here (docs/tensors.md lists the "
            "array-generic functions)"
        )
    return to_numpy(x)


_P = ParamSpec("_P")
_R = TypeVar("_R")


def numpy_only(fn: Callable[_P, _R]) -> Callable[_P, _R]:
    """Mark a function as numpy-only: torch/JAX arguments are copied to the host first.

    Its result is then numpy (as before the array-generic core); a traced array or a tensor that
    requires grad gets :func:`host`'s ``TypeError`` instead of a silently cut gradient.
    """
    where = f"{fn.__module__.removeprefix('liebridge.')}.{fn.__name__}"

    @functools.wraps(fn)
    def wrapper(*args: _P.args, **kwargs: _P.kwargs) -> _R:
        a = tuple(host(x, where) for x in args)
        k = {name: host(v, where) for name, v in kwargs.items()}
        return fn(*a, **k)

    return wrapper


def float_dtype(x: Any) -> Any:
    """Return the float dtype results take: ``x``'s if it is float32/float64, else float64."""
    xp = namespace(x)
    dt = x.dtype
    if dt in (xp.float32, xp.float64):
        return dt
    return xp.float64


def eps(x: Any) -> float:
    """Machine epsilon of ``x``'s dtype."""
    xp = namespace(x)
    return float(xp.finfo(x.dtype).eps)


def like(value: Any, ref: Any) -> Any:
    """``value`` (a number or an array) as an array of ``ref``'s namespace, dtype and device."""
    xp = namespace(ref)
    if xp is np:
        return np.asarray(value, dtype=np.float64)
    import array_api_compat

    if isinstance(value, np.ndarray) and not value.flags.writeable:
        value = np.array(value)  # torch refuses to wrap read-only memory (a broadcast view)
    return xp.asarray(value, dtype=ref.dtype, device=array_api_compat.device(ref))


def eye(n: int, ref: Any, batch: tuple[int, ...] = ()) -> Any:
    """Return the ``n × n`` identity of ``ref``'s namespace, dtype and device, over ``batch``."""
    xp = namespace(ref)
    if xp is np:
        return np.broadcast_to(np.eye(n), (*batch, n, n))
    import array_api_compat

    E = xp.eye(n, dtype=ref.dtype, device=array_api_compat.device(ref))
    return xp.broadcast_to(E, (*batch, n, n)) if batch else E


def zeros(shape: tuple[int, ...], ref: Any) -> Any:
    """Zeros of ``shape`` in ``ref``'s namespace, dtype and device."""
    xp = namespace(ref)
    if xp is np:
        return np.zeros(shape)
    import array_api_compat

    return xp.zeros(shape, dtype=ref.dtype, device=array_api_compat.device(ref))


def matrix(entries: Sequence[Any], rows: int, cols: int) -> Any:
    """Return the ``(..., rows, cols)`` matrix of row-major ``entries`` (batch arrays or numbers).

    numpy writes each entry into one preallocated output (its fastest layout); the other backends
    stack them (no in-place write, so autograd and tracing see one expression).
    """
    arrays = [e for e in entries if not isinstance(e, (int, float))]
    if not any_foreign(*arrays):  # numpy: the kernels' blocks call this in loops, keep it lean
        shapes = {np.shape(e) for e in arrays}
        shape = shapes.pop() if len(shapes) == 1 else np.broadcast_shapes(*shapes, ())
        out = np.empty((*shape, rows, cols))
        for k, e in enumerate(entries):
            out[..., k // cols, k % cols] = e
        return out
    xp = namespace(*arrays)
    ref = arrays[0]
    shape = tuple(np.broadcast_shapes(*(tuple(a.shape) for a in arrays)))
    full = [
        xp.broadcast_to(like(e, ref) if isinstance(e, (int, float)) else e, shape) for e in entries
    ]
    return xp.reshape(xp.stack(full, axis=-1), (*shape, rows, cols))


def concat(xs: Sequence[Any], axis: int = 0) -> Any:
    """Concatenate along ``axis`` (numpy ≥ 1.24 too, which spells it ``concatenate``)."""
    xp = namespace(*xs)
    return np.concatenate(xs, axis=axis) if xp is np else xp.concat(list(xs), axis=axis)


def atan2(y: Any, x: Any) -> Any:
    """``atan2(y, x)`` element-wise (numpy ≥ 1.24 too, which spells it ``arctan2``)."""
    xp = namespace(y, x)
    return np.arctan2(y, x) if xp is np else xp.atan2(y, x)


def vector(entries: Sequence[Any]) -> Any:
    """Return the ``(..., n)`` vector of ``entries`` (batch arrays), like :func:`matrix`."""
    return matrix(entries, 1, len(entries))[..., 0, :]


def blocks(grid: Sequence[Sequence[Any]]) -> Any:
    """Return the block matrix of a grid of ``(..., r_i, c_j)`` arrays (batch shapes broadcast)."""
    flat = [b for row in grid for b in row]
    xp = namespace(*flat)
    batch = tuple(np.broadcast_shapes(*(tuple(b.shape[:-2]) for b in flat)))
    rows = [concat([xp.broadcast_to(b, (*batch, *b.shape[-2:])) for b in row], -1) for row in grid]
    return concat(rows, -2)


def mT(A: Any) -> Any:
    """Return the transpose of the last two axes."""
    xp = namespace(A)
    if xp is np:
        return np.swapaxes(A, -1, -2)
    return (
        xp.matrix_transpose(A) if hasattr(xp, "matrix_transpose") else xp.linalg.matrix_transpose(A)
    )


def matvec(A: Any, x: Any) -> Any:
    """Return ``A x`` for ``(..., m, n)`` and ``(..., n)`` (broadcast)."""
    return (A @ x[..., None])[..., 0]


def dot(a: Any, b: Any) -> Any:
    """Return ``a · b`` over the last axis."""
    xp = namespace(a, b)
    return xp.sum(a * b, axis=-1)
