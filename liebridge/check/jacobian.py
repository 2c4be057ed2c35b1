"""Central finite-difference Jacobians through an explicit retraction and local map."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .. import arrays
from .._validate import FloatArray
from ..conventions import Convention, get
from ..lie import numdiff
from ..lie.numdiff import Local, Retract

#: Default step per dtype: ≈ ε^(1/3) balances truncation (ε² f''') and rounding (ε_mach / ε).
_EPS = {"float64": 1e-6, "float32": 3e-3}


def numerical_jacobian(
    f: Callable[[Any], Any],
    x: Any,
    *,
    retract: Retract | None = None,
    local: Local | None = None,
    out_local: Local | str | None = None,
    dim: int | None = None,
    eps: float | None = None,
    in_convention: Any = None,
    out_convention: Any = None,
) -> FloatArray:
    """Central-difference Jacobian ``J_out_in`` of ``f`` at ``x``.

    Column ``j`` is ``(out_local(y0, f(retract(x, +ε e_j))) − out_local(y0, f(retract(x, −ε e_j))))
    / 2ε`` with ``y0 = f(x)``.

    Parameters
    ----------
    f : callable
        The function; it receives what ``retract`` returns (batched if ``x`` is batched).
    x : array_like
        The point: a pose ``(..., 4, 4)``, a rotation ``(..., 3, 3)`` or a vector ``(..., n)``.
        A torch tensor or a JAX array is differentiated in its own library, on its device and
        in its dtype (the steps are built without an in-place write), and the Jacobian is an
        array of that type; ``f``, ``retract`` and the local maps then receive and return
        arrays of that type (a numpy result of a local map is moved to it).
        Without ``retract`` it is always read as a batch of vectors (the last axis), so a
        ``(k, 3)``-shaped or ``(3, 3)``-shaped array of 3-vectors is differentiated row by row.
    retract : callable, optional
        ``retract(x, d)`` with ``d`` of shape ``(..., dim)``. Default: ``x + d`` (vector input).
        With a retraction, square ``(..., n, n)`` inputs are group elements.
    local : callable, optional
        ``local(y0, y)`` of the *input* chart; used for the output when ``out_local`` is None
        (a map from a group to the same group in the same convention).
    out_local : callable or ``"euclidean"``, optional
        Local map of the output. ``"euclidean"`` (or no ``local`` either) means ``y − y0``.
    dim : int, optional
        Input tangent dimension. With ``retract`` a convention's ``retract`` (or
        ``in_convention``) it is that convention's (its group record's: Sim(3) 7, a user's group
        its own); else inferred for square group elements as 1, 3, 6, 9 for ``(2, 2)``,
        ``(3, 3)``, ``(4, 4)``, ``(5, 5)`` (SO(2); SO(3) or SE(2); SE(3); SE₂(3)), else ``n``.
    eps : float, optional
        Step. Default 1e-6 (float64: errors around 1e-9 for O(1) second derivatives); for a
        float32 tensor 3e-3 (errors around 1e-5; a 1e-6 step would be lost to rounding).
    in_convention, out_convention : Convention or str, optional
        Shorthands: ``in_convention=c`` sets ``retract=c.retract`` (and ``local=c.local``);
        ``out_convention=c`` sets ``out_local=c.local``. A Jacobian is then exactly the object
        ``liebridge.convert_jacobian`` converts between conventions.

    Returns
    -------
    ndarray (or the input's array type), shape (..., m, dim)
    """
    if in_convention is not None or out_convention is not None:
        if in_convention is not None:
            cin = get(in_convention)
            retract = retract if retract is not None else cin.retract
            local = local if local is not None else cin.local
            if dim is None:  # the convention knows its tangent (Sim(3) is 4×4 with 7 dof)
                dim = cin.dim(x)  # (a library pose object too)
        if out_convention is not None:
            out_local = out_local if out_local is not None else get(out_convention).local
    owner = getattr(retract, "__self__", None)
    if dim is None and isinstance(owner, Convention):  # conv.retract: its group's record knows
        dim = owner.dim(x)
    if eps is None:  # the step by precision (a float32 tensor: 1e-6 would be lost to rounding)
        f32 = arrays.is_foreign(x) and str(x.dtype).endswith("float32")
        eps = _EPS["float32" if f32 else "float64"]
    return numdiff.central_differences(
        f, x, retract=retract, local=local, out_local=out_local, dim=dim, eps=eps
    )


def assert_jacobian(
    actual: Any,
    expected: Any,
    *,
    atol: float = 1e-7,
    rtol: float = 1e-6,
    name: str = "Jacobian",
) -> None:
    """Raise ``AssertionError`` naming the worst entry unless ``|a − e| ≤ atol + rtol·|e|``.

    The message gives the index of the entry with the largest excess over the tolerance, both
    values and the difference. NaN or Inf in ``actual`` or ``expected`` always fails.
    """
    a = np.asarray(arrays.to_numpy(actual), dtype=np.float64)  # tensors: a detached host copy
    e = np.asarray(arrays.to_numpy(expected), dtype=np.float64)
    if a.shape != e.shape:
        raise AssertionError(f"{name}: shape {a.shape} != expected {e.shape}")
    excess = np.abs(a - e) - (atol + rtol * np.abs(e))
    finite = np.isfinite(a) & np.isfinite(e)
    if not finite.all() or (excess > 0).any():
        # a NaN/Inf on either side is the worst possible entry (NaN > 0 is False: never pass it)
        bad = np.where(finite, excess, np.inf)
        i = np.unravel_index(int(np.argmax(bad)), a.shape)
        raise AssertionError(
            f"{name}: worst entry {tuple(int(k) for k in i)}: got {a[i]:.12g}, expected "
            f"{e[i]:.12g} (|diff| = {abs(a[i] - e[i]):.3g}, atol={atol:g}, rtol={rtol:g})"
        )
