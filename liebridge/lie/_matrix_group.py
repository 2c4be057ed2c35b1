"""What every matrix-group kernel does the same way: product, action on points, geodesic.

The group modules (``se2``, ``se3``, ``sim3``, ``se23``) pass their own validator and unchecked
``log``/``exp``/``inverse``; the maths is the same for any matrix group: ``X1·X2``,
``A x + b`` with ``A, b`` the top-left block and column of ``X``, and ``X0·Exp(τ·Log(X0⁻¹X1))``.
Argument names (``T1`` or ``X1``...) are the caller's, so errors name what the user typed.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray

Check = Callable[[Any, str], FloatArray]
Unary = Callable[[FloatArray], FloatArray]


def compose(X1: Any, X2: Any, check: Check, names: tuple[str, str], where: str) -> FloatArray:
    """Return ``X1·X2`` for two validated batches (broadcast)."""
    A, B = check(X1, names[0]), check(X2, names[1])
    validate.batch_shape((names[0], A.shape[:-2]), (names[1], B.shape[:-2]))
    return validate.finite_output(_float(A @ B), where)


def act(X: Any, x: Any, check: Check, n: int, names: tuple[str, str], where: str) -> FloatArray:
    """Apply ``A x + b`` (``A = X[..., :n, :n]``, ``b = X[..., :n, n]``) to points ``(..., n)``."""
    Xa = check(X, names[0])
    xa = validate.vector(x, names[1], n)
    validate.batch_shape((names[0], Xa.shape[:-2]), (names[1], xa.shape[:-1]))
    out = arrays.matvec(Xa[..., :n, :n], xa) + Xa[..., :n, n]
    return validate.finite_output(_float(out), where)


def interpolate(
    X0: Any,
    X1: Any,
    tau: Any,
    check: Check,
    tangent: Callable[[Any, str], FloatArray],
    ops: tuple[Unary, Unary, Unary],
    names: tuple[str, str],
    where: str,
) -> FloatArray:
    """Return the geodesic ``X0·Exp(τ·Log(X0⁻¹X1))``; ``ops = (log, exp, inverse)`` unchecked."""
    log, exp, inverse = ops
    A, B = check(X0, names[0]), check(X1, names[1])
    tau_ = (
        arrays.like(validate.as_float_array(tau, "tau"), A)
        if arrays.is_foreign(A) and not arrays.is_foreign(tau)
        else validate.as_float_array(tau, "tau")
    )
    validate.check_finite(tau_, "tau", core_ndim=0)
    validate.batch_shape(
        (names[0], A.shape[:-2]), (names[1], B.shape[:-2]), ("tau", tuple(tau_.shape))
    )
    xi = tangent(tau_[..., None] * log(inverse(A) @ B), f"tau·Log({names[0]}⁻¹{names[1]})")
    return validate.finite_output(_float(A @ exp(xi)), where)


def _float(x: Any) -> Any:
    """Return a numpy result as a float64 ndarray, a torch/JAX result as it is."""
    return x if arrays.is_foreign(x) else np.asarray(x, dtype=np.float64)
