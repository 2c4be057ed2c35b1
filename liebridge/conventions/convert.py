"""Tangents, covariances, information matrices and Jacobians translated between conventions.

Everything is one formula. With ``M = tangent_map(X, src, dst)``, the derivative at ``d = 0`` of
``dst.local(X, src.retract(X, d))``:

* tangent: ``d_dst = M d_src`` (first order) or ``dst.local(X, src.retract(X, d_src))`` (exact);
* covariance: ``Σ_dst = M Σ_src Mᵀ``; information: ``Λ_dst = M⁻ᵀ Λ_src M⁻¹``;
* Jacobian of a function with a group input at ``X`` and a group output at ``Y``:
  ``J_dst = M(Y) · J_src · M(X)⁻¹``.

``M`` is closed form (adjoints, permutations, block rotations, scale) and ``M⁻¹`` is
``tangent_map(X, dst, src)``, also closed form: no matrix is inverted. Whether the first-order
map is the whole story is :func:`is_exactly_linear`: side, order, rotation scale (``exp`` ↔
``half_exp``) and body ↔ world translation frames are exactly linear; a change between the SE(3)
exponential and a decoupled chart, or to/from ``quat_vec``/``cayley`` coordinates, is not, and
for a large covariance there :func:`convert_covariance` offers ``method="unscented"``.
"""

from __future__ import annotations

import functools
import math
import re
import types
import warnings
from typing import Any, Literal

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from .bundle import Bundle
from .chart import Chart
from .convention import Convention
from .cubature import cubature_rule_5, sqrt_psd
from .engine import convertible
from .navstate import NavChart, nav_exactly_linear
from .registry import ConventionLike, get
from .tangent_maps import pair_map_coefficients
from .unchecked import tangent_map as unchecked_map

__all__ = [
    "convert_covariance",
    "convert_information",
    "convert_jacobian",
    "convert_tangent",
    "is_exactly_linear",
    "tangent_map",
]

_LINEAR_ROTATIONS = {"exp", "half_exp"}


def _chart_family(c: Convention) -> str:
    return "coupled" if c.chart == c.record.coupled_chart else "split"


def _check_groups(a: Chart, b: Chart) -> None:
    if not convertible(a.group, b.group):
        raise ValueError(
            f"src {a.name!r} is a {a.group} convention and dst {b.name!r} a {b.group} one: "
            "tangents of different groups cannot be converted into each other"
        )


def _element(a: Chart, b: Chart, X: Any, name: str = "X") -> FloatArray:
    """Validate ``X`` as an element of the (common) group of ``a`` and ``b``."""
    _check_groups(a, b)
    if a.group == b.group:
        return b.element(X, name)
    # an SE(3) convention with an SO(3) one: X is a rotation (the narrower group's element)
    return (b if len(b.record.vecs) <= len(a.record.vecs) else a).element(X, name)


# --------------------------------------------------------------------------------------------
# the compiled validate-and-convert pass (optional; built from _convert_ext.c with the package)

_convert_ext: types.ModuleType | None
try:
    from . import _convert_ext
except ImportError:  # pragma: no cover - the build skips it where no C compiler is found
    _convert_ext = None

#: Whether the compiled pass was built (``liebridge/conventions/_convert_ext.c``). Without it the
#: same numbers come from numpy (``benchmarks/bench_speed.py`` measures both).
COMPILED = _convert_ext is not None

#: ``(grid_pose, grid_pose_2, grid_rot, grid_rot_2, rotation tolerance)``, see _convert_ext.c
_Plan = tuple[Any, Any, Any, Any, float]


def _grids(a: Convention, b: Convention, so3: bool) -> tuple[Any, Any]:
    t = pair_map_coefficients(a, b, so3)
    return t[0], (t[1] if len(t) > 1 else None)


def _compiled_plan(src: Any, dst: Any) -> _Plan | None:
    """Return the compiled kernel's plan for ``tangent_map(·, src, dst)``, or None (numpy only).

    The kernel covers the SE(3)/SO(3) conventions whose map is the closed-form grid of
    ``tangent_maps.py`` (not Euler angles, embeddings or bundles). Anything the kernel does not
    cover, including an unknown name or an unhashable argument, gets None: the numpy path then
    raises its usual error. Plans are memoized (a bounded cache: they depend only on the pair).
    """
    try:
        return _plan_for(src, dst)
    except (TypeError, ValueError):
        return None


@functools.lru_cache(maxsize=1024)
def _plan_for(src: Any, dst: Any) -> _Plan | None:
    a, b = get(src), get(dst)
    if not (isinstance(a, Convention) and isinstance(b, Convention)):
        return None  # whole-state charts: the numpy path
    simple = (
        a._engine.rotations_3d
        and b._engine.rotations_3d
        and not (a.is_euler or b.is_euler)
        and a.embed is None
        and b.embed is None
    )
    if not simple:
        return None
    pose = bool(a.record.vecs and b.record.vecs)  # else X must be a rotation (_element)
    p1, p2 = _grids(a, b, False) if pose else (None, None)
    r1, r2 = _grids(a, b, True)
    return (p1, p2, r1, r2, validate.ROTATION_TOL)


def _map_shape(X: FloatArray) -> tuple[int, ...] | None:
    """``X``'s batch shape + ``(n, n)`` for a pose or rotation array, else None."""
    k = X.shape[-1] if X.ndim >= 2 else 0
    if (k != 4 and k != 3) or X.shape[-2] != k:
        return None
    n = 6 if k == 4 else 3
    return (*X.shape[:-2], n, n)


def is_exactly_linear(src: ConventionLike, dst: ConventionLike) -> bool:
    """Whether ``dst.local(X, src.retract(X, d))`` is linear in ``d`` (so ``M d`` is exact).

    True when the two differ only by side, order, rotation scale (``exp`` ↔ ``half_exp``) or the
    frame of a decoupled translation (``so3xr3_body`` ↔ ``so3xr3_world``); False across
    ``se3`` ↔ ``so3xr3`` or when one side uses ``quat_vec``/``cayley`` and the other does not.
    Exactness holds within the charts' common domain (rotation angle below π).
    """
    a, b = get(src), get(dst)
    _check_groups(a, b)
    if isinstance(a, Bundle) and isinstance(b, Bundle):
        return a.exactly_linear_to(b, is_exactly_linear)
    if isinstance(a, NavChart) or isinstance(b, NavChart):  # decided by the pose charts
        return nav_exactly_linear(a, b, is_exactly_linear)
    if not (isinstance(a, Convention) and isinstance(b, Convention)):
        return False  # a bundle and a single group's convention do not convert (checked above)
    if _chart_family(a) != _chart_family(b):
        return False
    if a.is_euler or b.is_euler:  # absolute angles: linear only between two Euler orders
        return a.is_euler and b.is_euler
    return a.rotation == b.rotation or {a.rotation, b.rotation} <= _LINEAR_ROTATIONS


def tangent_map(X: Any, src: ConventionLike, dst: ConventionLike) -> FloatArray:
    """First-order map of tangents from ``src`` to ``dst`` at ``X``.

    Parameters
    ----------
    X : array_like, shape (..., 4, 4) or (..., 3, 3)
        The pose (or rotation) both tangents live at.
    src, dst : Convention or str
        Conventions (objects or registry names).

    Returns
    -------
    ndarray, shape (..., 6, 6) or (..., 3, 3)
        ``M = ∂/∂d dst.local(X, src.retract(X, d)) |_{d=0}``, closed form.
    """
    if _convert_ext is not None and type(X) is np.ndarray:
        plan = _compiled_plan(src, dst)
        shape = _map_shape(X)
        if plan is not None and shape is not None:
            out = np.empty(shape)
            if _convert_ext.transform(0, plan, X, None, out) == -1:
                return out
    a, b = get(src), get(dst)
    (X,) = _inputs(a, b, X)
    return validate.finite_output(unchecked_map(_element(a, b, X), a, b), "tangent_map")


def convert_tangent(
    d: Any, X: Any, src: ConventionLike, dst: ConventionLike, *, exact: bool = True
) -> FloatArray:
    """Re-express a tangent ``d`` at ``X`` from ``src`` in ``dst``.

    ``exact=True`` returns ``dst.local(X, src.retract(X, d))`` (the same perturbed pose, read in
    ``dst``'s chart); ``exact=False`` the first-order ``tangent_map(X, src, dst) @ d``. They agree
    whenever :func:`is_exactly_linear` holds.
    """
    a, b = get(src), get(dst)
    d, X = _inputs(a, b, d, X)
    Xa = _element(a, b, X)
    d = a._increment(d, Xa.shape[-1] == 3)
    validate.batch_shape(("d", tuple(d.shape[:-1])), ("X", tuple(Xa.shape[:-2])))
    if exact:
        out = b._local(Xa, a._retract(Xa, d))
    else:
        out = arrays.matvec(unchecked_map(Xa, a, b), d)
    return validate.finite_output(_out(out), "convert_tangent")


def _inputs(a: Chart, b: Chart, *xs: Any) -> tuple[Any, ...]:
    """Return the arguments in one array type (torch/JAX where both charts run on it)."""
    return a._inputs(*b._inputs(*xs))


def _out(x: Any) -> Any:
    """Return a numpy result as float64, a torch/JAX result as it is."""
    return x if arrays.is_foreign(x) else np.asarray(x, dtype=np.float64)


def convert_covariance(
    cov: Any,
    X: Any,
    src: ConventionLike,
    dst: ConventionLike,
    *,
    method: Literal["linear", "unscented"] = "linear",
    chunk_size: int | None = None,
) -> FloatArray:
    """Re-express a covariance of a perturbation at ``X`` from ``src``'s tangent to ``dst``'s.

    Parameters
    ----------
    cov : array_like, shape (..., n, n)
        Symmetric positive semi-definite covariance in ``src``'s tangent (``n`` = 6, or 3 for a
        rotation).
    X : array_like, shape (..., 4, 4) or (..., 3, 3)
        Mean pose (rotation).
    src, dst : Convention or str
    method : {"linear", "unscented"}
        ``"linear"``: ``M Σ Mᵀ`` (exact when :func:`is_exactly_linear`). ``"unscented"``: sigma
        points of a fifth-degree Gaussian cubature (``2n² + 1`` points, ``cubature_rule_5``)
        scaled by ``S`` (``S Sᵀ = Σ``) and pushed through ``dst.local(X, src.retract(X, ·))``;
        the covariance about the transformed mean is returned (the mean shift, second order,
        is dropped: it belongs to the pose). Exact for maps quadratic in the perturbation.
    chunk_size : int, optional
        ``"unscented"`` only: batch elements transformed per pass (default
        :data:`UNSCENTED_CHUNK`, 4096). Memory stays ≈ 20 kB × ``chunk_size`` whatever the batch
        size (10⁶ covariances in one pass needed ≈ 20 GB); results do not depend on it.

    Returns
    -------
    ndarray, shape (..., n, n)

    Notes
    -----
    Where the compiled pass is built (:data:`COMPILED`), ``method="linear"`` on float64 arrays
    with equal batch shapes validates and converts each element in one C loop; an element it
    cannot certify sends the whole call through the numpy path, which accepts it or raises the
    same error as without the compiled pass.
    """
    if (
        _convert_ext is not None
        and method == "linear"
        and type(cov) is np.ndarray
        and type(X) is np.ndarray
    ):
        plan = _compiled_plan(src, dst)
        if plan is not None:
            res = np.empty(cov.shape)
            if _convert_ext.transform(1, plan, X, cov, res) == -1:
                return res
    if method != "linear" and method != "unscented":  # "Linear", " unscented": as all options
        method = validate.option(method, "method", ("linear", "unscented"))
    a, b = get(src), get(dst)
    cov, X = _inputs(a, b, cov, X)
    Xa = _element(a, b, X)
    so3 = Xa.shape[-1] == 3
    n = a.dim(Xa)
    cov = validate.covariance(cov, "cov", n)
    batch = tuple(Xa.shape[:-2])
    if tuple(cov.shape[:-2]) != batch:
        batch = validate.batch_shape(("cov", tuple(cov.shape[:-2])), ("X", batch))
    if method == "linear" and arrays.is_foreign(Xa):
        M = unchecked_map(Xa, a, b)
        return validate.finite_output(M @ cov @ arrays.mT(M), "convert_covariance")
    if method == "linear":
        M = unchecked_map(Xa, a, b)
        # a batch: numpy multiplies stacks of small matrices fast only when they are contiguous
        Mt = M.T if M.ndim == 2 else np.ascontiguousarray(M.swapaxes(-1, -2))
        with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported just below
            linear = M @ cov @ Mt
        return validate.finite_output(linear, "convert_covariance")
    if method != "unscented":
        raise ValueError(f"method: expected 'linear' or 'unscented', got {method!r}")
    chunk = _chunk_size(chunk_size)
    if arrays.is_foreign(Xa):  # torch/JAX: the same passes, the chunks concatenated
        return _unscented_foreign(cov, Xa, a, b, n, so3, batch, chunk)
    # X and cov broadcast against each other first (one covariance at many poses, many at one);
    # each chunk gathers its elements from the broadcast views, so nothing is copied whole.
    Xv = np.broadcast_to(Xa, (*batch, *Xa.shape[-2:]))
    cv = np.broadcast_to(cov, (*batch, n, n))
    total = math.prod(batch)
    out: FloatArray | None = None  # dst's dimension (an embedding may differ from n)
    for lo in range(0, max(total, 1), chunk):  # bounded memory: ≈ 20 kB per element in flight
        hi = min(lo + chunk, total)
        where = np.unravel_index(np.arange(lo, hi), batch) if batch else ()
        Xc = Xv[where].reshape((-1, *Xa.shape[-2:]))
        cc = cv[where].reshape((-1, n, n))
        try:
            part = _unscented(cc, Xc, a, b, n, so3)
        except ValueError as e:  # name the index in the caller's batch, not in the chunk
            raise ValueError(_rebase_index(str(e), lo, batch)) from None
        if out is None:
            out = np.empty((total, *part.shape[1:]))
        out[lo:hi] = part
    assert out is not None  # the loop runs at least once (an empty batch: one empty pass)
    return validate.finite_output(out.reshape((*batch, *out.shape[1:])), "convert_covariance")


#: Batch elements per pass of the unscented transform (10⁶ covariances at once needed
#: ≈ 20 GB; in chunks of this size the peak is ≈ 20 kB × 4096 ≈ 80 MB, at the same speed).
UNSCENTED_CHUNK = 4096


def _rebase_index(msg: str, offset: int, batch: tuple[int, ...]) -> str:
    """``… at batch index (j, k) …`` of a chunk's sigma points → the caller's ``(*i, k)``."""
    m = re.search(r"at batch index \((\d+), (\d+)\)", msg)
    if m is None:
        return msg
    where = tuple(int(i) for i in np.unravel_index(offset + int(m.group(1)), batch or (1,)))
    i = (*where[: len(batch)], int(m.group(2)))
    return msg[: m.start()] + f"at batch index {i}" + msg[m.end() :]


def _chunk_size(chunk_size: Any) -> int:
    if chunk_size is None:
        return UNSCENTED_CHUNK
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, int | np.integer):
        raise TypeError(f"chunk_size: expected a positive int, got {type(chunk_size).__name__}")
    if chunk_size < 1:
        raise ValueError(f"chunk_size: expected a positive int, got {chunk_size}")
    return int(chunk_size)


def _unscented_foreign(
    cov: Any,
    Xa: Any,
    a: Chart,
    b: Chart,
    n: int,
    so3: bool,
    batch: tuple[int, ...],
    chunk: int,
) -> Any:
    """:func:`_unscented` on torch/JAX arrays: broadcast, flattened, in chunks, concatenated."""
    xp = arrays.namespace(Xa)
    k = Xa.shape[-1]
    total = math.prod(batch)
    Xv = xp.reshape(xp.broadcast_to(Xa, (*batch, k, k)), (total, k, k))
    cv = xp.reshape(xp.broadcast_to(cov, (*batch, n, n)), (total, n, n))
    parts = []
    for lo in range(0, max(total, 1), chunk):
        hi = min(lo + chunk, total)
        try:
            parts.append(_unscented(cv[lo:hi], Xv[lo:hi], a, b, n, so3))
        except ValueError as e:  # name the index in the caller's batch, not in the chunk
            raise ValueError(_rebase_index(str(e), lo, batch)) from None
    out = parts[0] if len(parts) == 1 else arrays.concat(parts, 0)
    return validate.finite_output(xp.reshape(out, (*batch, *out.shape[1:])), "convert_covariance")


def _unscented(
    cov: FloatArray, Xa: FloatArray, a: Chart, b: Chart, n: int, so3: bool
) -> FloatArray:
    """Convert a flat batch of covariances ``(N, n, n)`` at ``(N, k, k)`` by sigma points.

    numpy, torch and JAX alike (the rule's points and weights moved to the array's device).
    """
    if arrays.is_foreign(Xa):
        pts_np, w_np = cubature_rule_5(n)
        pts, w = arrays.like(pts_np, Xa), arrays.like(w_np, Xa)
        S = sqrt_psd(cov)
        deltas = arrays.mT(S @ arrays.mT(pts))  # (..., K, n)
        a._increment(deltas, so3, "cov (its sigma points)")
        Xb = Xa[..., None, :, :]
        y = b._local(Xb, a._retract(Xb, deltas))
        mean = arrays.matvec(arrays.mT(y), w)
        dy = y - mean[..., None, :]
        out = arrays.mT(dy * w[:, None]) @ dy
        out = 0.5 * (out + arrays.mT(out))
        return validate.finite_output(out, "convert_covariance (unscented: the sigma points at X)")
    pts, w = cubature_rule_5(n)
    S = sqrt_psd(cov)  # (..., n, n), S Sᵀ = Σ
    deltas = np.einsum("...ij,kj->...ki", S, pts)  # (..., K, n)
    a._increment(deltas, so3, "cov (its sigma points)")  # increments the kernel can evaluate
    Xb = Xa[..., None, :, :]
    # an element near float64's limit overflows in the sigma points' products: said below
    with np.errstate(over="ignore", invalid="ignore"):
        y = b._local(Xb, a._retract(Xb, deltas))
        mean = np.einsum("k,...ki->...i", w, y)
        dy = y - mean[..., None, :]
        out = np.einsum("k,...ki,...kj->...ij", w, dy, dy)
    out = np.asarray(0.5 * (out + np.swapaxes(out, -1, -2)), dtype=np.float64)
    return validate.finite_output(out, "convert_covariance (unscented: the sigma points at X)")


def convert_information(info: Any, X: Any, src: ConventionLike, dst: ConventionLike) -> FloatArray:
    """Re-express an information matrix: ``Λ_dst = M⁻ᵀ Λ_src M⁻¹``.

    ``M⁻¹ = tangent_map(X, dst, src)`` in closed form.
    Works for singular (rank-deficient) information: nothing is inverted.
    """
    if _convert_ext is not None and type(info) is np.ndarray and type(X) is np.ndarray:
        plan = _compiled_plan(dst, src)  # M⁻¹ = tangent_map(X, dst, src)
        if plan is not None:
            out = np.empty(info.shape)
            if _convert_ext.transform(2, plan, X, info, out) == -1:
                return out
    a, b = get(src), get(dst)
    info, X = _inputs(a, b, info, X)
    Xa = _element(a, b, X)
    n = a.dim(Xa)
    info = validate.covariance(info, "info", n)
    validate.batch_shape(("info", tuple(info.shape[:-2])), ("X", tuple(Xa.shape[:-2])))
    Mi = unchecked_map(Xa, b, a)
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported just below
        out = _out(arrays.mT(Mi) @ info @ Mi)
    return validate.finite_output(out, "convert_information")


def _is_convention_like(x: Any) -> bool:
    return isinstance(x, (str, Convention, Bundle, NavChart))


def convert_jacobian(
    J: Any,
    X: Any = None,
    src: Any = None,
    dst: Any = None,
    *,
    at_output: Any = None,
    at_input: Any = None,
) -> FloatArray:
    """Re-express a Jacobian ``J_out_in`` whose group input and/or output changes convention.

    ``J_dst = M(Y) · J_src · M(X)⁻¹`` with ``M(·) = tangent_map(·, src, dst)``: ``X`` (the group
    input's point) converts the columns, ``at_output=Y`` (the group output's point) the rows.
    ``None`` leaves that side as it is (a vector input or output). The argument order is the
    conversions' family order ``f(value, X, src, dst)`` (:func:`convert_covariance`,
    :func:`convert_tangent`).

    Parameters
    ----------
    J : array_like, shape (..., m, n)
    X : array_like, shape (..., 4, 4) or (..., 3, 3), or None
        The input point; None for a vector input.
    src, dst : Convention or str
    at_output : array_like, shape (..., 4, 4) or (..., 3, 3), optional
        The output point; None for a vector output.
    at_input : optional
        Deprecated spelling of ``X`` (the order of earlier releases,
        ``convert_jacobian(J, src, dst, at_input=X, at_output=Y)``, still works with a
        ``DeprecationWarning``).

    Returns
    -------
    ndarray, shape (..., m, n)
    """
    if dst is None and _is_convention_like(X) and _is_convention_like(src):
        warnings.warn(
            "convert_jacobian(J, src, dst, at_input=X) is the order of earlier releases; write "
            "convert_jacobian(J, X, src, dst, at_output=Y)",
            DeprecationWarning,
            stacklevel=2,
        )
        X, src, dst = at_input, X, src
    elif at_input is not None:
        if X is not None:
            raise TypeError("X: given twice (positionally and as at_input)")
        warnings.warn(
            "convert_jacobian(..., at_input=X) is deprecated; pass X second",
            DeprecationWarning,
            stacklevel=2,
        )
        X = at_input
    if src is None or dst is None:
        raise TypeError("convert_jacobian(J, X, src, dst): src and dst are required")
    at_input = X
    if _convert_ext is not None and type(J) is np.ndarray and J.ndim >= 2:
        out = _jacobian_compiled(J, src, dst, at_input, at_output)
        if out is not None:
            return out
    a, b = get(src), get(dst)
    J, at_input, at_output = _inputs(a, b, J, at_input, at_output)
    if arrays.is_foreign(J):
        Jm = _jacobian_input(J)
    else:
        Jm = validate.as_float_array(J, "J")
    if Jm.ndim < 2:
        raise ValueError(f"J: expected shape (..., m, n), got {tuple(Jm.shape)}")
    validate.check_finite(Jm, "J", core_ndim=2)
    if at_input is None and at_output is None:
        if arrays.is_foreign(Jm):
            return Jm * 1.0  # nothing to convert; never an alias
        return np.array(Jm, dtype=np.float64, copy=True)  # nothing to convert; never an alias
    if at_input is not None:
        X = _element(a, b, at_input, "at_input")
        validate.batch_shape(("J", tuple(Jm.shape[:-2])), ("at_input", tuple(X.shape[:-2])))
        Mi = unchecked_map(X, b, a)
        if Jm.shape[-1] != Mi.shape[-2]:
            raise ValueError(f"J: {Jm.shape[-1]} columns, but the input tangent has {Mi.shape[-2]}")
        with np.errstate(over="ignore", invalid="ignore"):  # reported by finite_output below
            Jm = Jm @ Mi
    if at_output is not None:
        Y = _element(a, b, at_output, "at_output")
        validate.batch_shape(("J", tuple(Jm.shape[:-2])), ("at_output", tuple(Y.shape[:-2])))
        Mo = unchecked_map(Y, a, b)
        if Jm.shape[-2] != Mo.shape[-1]:
            raise ValueError(f"J: {Jm.shape[-2]} rows, but the output tangent has {Mo.shape[-1]}")
        with np.errstate(over="ignore", invalid="ignore"):  # reported by finite_output below
            Jm = Mo @ Jm
    return validate.finite_output(_out(Jm), "convert_jacobian")


def _jacobian_input(J: Any) -> Any:
    """Validate a torch/JAX Jacobian (integers become float64, as validation converts)."""
    return validate.vector(J, "J", J.shape[-1]) if J.ndim >= 1 else J


def _jacobian_compiled(
    J: FloatArray, src: Any, dst: Any, at_input: Any, at_output: Any
) -> FloatArray | None:
    """:func:`convert_jacobian` by the compiled pass, or None (then numpy decides)."""
    assert _convert_ext is not None
    if at_input is None and at_output is None:
        return None
    if at_input is not None:
        if type(at_input) is not np.ndarray:
            return None
        plan = _compiled_plan(dst, src)  # M(X)⁻¹ = tangent_map(X, dst, src)
        if plan is None:
            return None
        out = np.empty(J.shape)
        if _convert_ext.transform(3, plan, at_input, J, out) != -1:
            return None
        J = out
    if at_output is not None:
        if type(at_output) is not np.ndarray:
            return None
        plan = _compiled_plan(src, dst)
        if plan is None:
            return None
        out = np.empty(J.shape)
        if _convert_ext.transform(4, plan, at_output, J, out) != -1:
            return None
    return out
