"""Central finite differences through an explicit retraction and local map (no conventions).

The numerical core of :func:`liebridge.check.numerical_jacobian` (which adds the convention
shorthands on top): a Jacobian is only meaningful with respect to the chart it claims, so the
differences are taken through a given ``retract`` and read back through a given ``local``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray

Retract = Callable[[Any, FloatArray], Any]
Local = Callable[[Any, Any], Any]


def _euclidean_local(y0: Any, y: Any) -> FloatArray:
    if arrays.any_foreign(y0, y):
        return y - y0
    return np.asarray(y, dtype=np.float64) - np.asarray(y0, dtype=np.float64)


#: Matrix shapes read as group elements when a retraction is given, and their default tangent
#: dimension: SO(2) 1; SO(3) 3 (an SE(2) pose is 3×3 too: pass ``dim=3``, same number); SE(3) 6
#: (Sim(3) is 4×4 too: pass ``dim=7``); SE₂(3) 9.
_GROUP_SHAPES = ((2, 2), (3, 3), (4, 4), (5, 5))
_DEFAULT_DIM = {2: 1, 3: 3, 4: 6, 5: 9}


def _tangent_dim(x: FloatArray) -> int:
    if x.ndim >= 2 and tuple(x.shape[-2:]) in _GROUP_SHAPES:
        return _DEFAULT_DIM[x.shape[-1]]
    return int(x.shape[-1])


def central_differences(
    f: Callable[[Any], Any],
    x: Any,
    *,
    retract: Retract | None = None,
    local: Local | None = None,
    out_local: Local | str | None = None,
    dim: int | None = None,
    eps: float = 1e-6,
) -> FloatArray:
    """Central-difference Jacobian ``J_out_in`` of ``f`` at ``x``.

    Column ``j`` is ``(out_local(y0, f(retract(x, +ε e_j))) − out_local(y0, f(retract(x, −ε e_j))))
    / 2ε`` with ``y0 = f(x)``.

    The engine of :func:`liebridge.check.numerical_jacobian`, the one public name for users
    (layers below ``check`` call this). The parameters are those of it (documented there,
    with the convention shorthands it adds): ``retract(x, d)`` perturbs the input (default
    ``x + d``), ``local(y0, y)`` reads the output back (default: the input's ``local`` if given,
    else ``y − y0``), ``out_local`` overrides it, ``dim`` is the input tangent dimension (1, 3,
    6, 9 for ``(2, 2)`` … ``(5, 5)`` group elements, else the last axis; pass 7 for Sim(3)) and
    ``eps`` the step.

    On a torch/JAX ``x`` the same formula runs in its namespace (no writes: the steps are rows of
    the identity), and the result is of ``x``'s array type, differentiable.

    Returns
    -------
    ndarray (or ``x``'s array type), shape (..., m, dim)
    """
    foreign = arrays.is_foreign(x)
    if foreign:  # float32/float64, finite (a 0-d array: the vector error below)
        x_arr = validate.vector(x, "x", int(x.shape[-1])) if x.ndim >= 1 else x
    else:
        x_arr = validate.as_float_array(x, "x")  # a library pose/rotation object too
    if retract is None:
        # Euclidean input: always a batch of vectors, even when shaped (..., 3, 3) or (..., 4, 4)
        if x_arr.ndim < 1:
            raise ValueError("x: a vector input needs shape (..., n)")
        n, batch = int(x_arr.shape[-1]), tuple(x_arr.shape[:-1])
        if dim is not None and dim != n:
            raise ValueError(f"dim: {dim} does not match the vector length {n} of x")
    else:
        n = dim if dim is not None else _tangent_dim(x_arr)
        square = x_arr.ndim >= 2 and x_arr.shape[-2] == x_arr.shape[-1]
        # a square matrix is a group element when its size is a group's, or when the tangent
        # size differs from its last axis (then it cannot be a batch of vectors: a bundle)
        group = square and (tuple(x_arr.shape[-2:]) in _GROUP_SHAPES or n != x_arr.shape[-1])
        batch = tuple(x_arr.shape[:-2] if group else x_arr.shape[:-1])
    ret: Retract = retract if retract is not None else (lambda a, d: a + d)
    if out_local is None:
        out: Local = local if local is not None else _euclidean_local
    elif isinstance(out_local, str):
        if out_local != "euclidean":
            raise ValueError(f"out_local: expected a callable or 'euclidean', got {out_local!r}")
        out = _euclidean_local
    else:
        out = out_local

    def read(y: Any) -> Any:  # the output's local coordinates, in x's array type
        v = out(y0, y)
        if foreign:
            return (
                v if arrays.is_foreign(v) else arrays.like(np.asarray(v, dtype=np.float64), x_arr)
            )
        return np.asarray(v, dtype=np.float64)

    y0 = f(x_arr)
    E = arrays.eye(n, x_arr) if foreign else np.eye(n)
    xp = arrays.namespace(x_arr)
    cols = []
    for j in range(n):
        d = xp.broadcast_to(eps * E[j, :], (*batch, n))
        cols.append((read(f(ret(x_arr, d))) - read(f(ret(x_arr, -d)))) / (2.0 * eps))
    return xp.stack(cols, axis=-1)
