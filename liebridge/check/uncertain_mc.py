"""Monte Carlo counterparts of :mod:`liebridge.uncertain`'s operations (their reference).

Each function draws the inputs' perturbations from their joint Gaussian in the convention's
tangent, ``δ ~ N(0, Σ_joint)``, builds the samples with the convention's own ``retract``, applies
the exact group operation (matrix products, :func:`numpy.linalg.inv`; no Jacobian anywhere) and
reads the results back with the convention's ``local`` at the operation's value on the means.
The covariance is taken about the sample mean (so it is comparable with
``method="unscented"``, which also drops the mean shift). The sampling error of an entry is
about ``√(2/n)`` relative.

They return the same types as the operations (:class:`~liebridge.uncertain.UncertainPose`,
:class:`~liebridge.uncertain.UncertainPoint`), with the mean of the operation on the means.

torch tensors and JAX arrays run the same formulas on their device and get results of their
type, dtype and device (a numpy operand beside them is moved there). The random numbers are
numpy's: the standard normals are drawn on the host by the ``Generator`` ``rng`` (the same
numbers, in the same order, as for numpy input) and moved to the device with ``arrays.like``;
the covariance's factor ``Q √Λ`` (``eigh``, as numpy's) is computed on the device, with its
column signs aligned to numpy's from a detached host copy (LAPACK implementations choose them
differently; a discrete choice, no gradient is cut). The samples are reparameterised, so the
results are differentiable with respect to the means and the covariances (where the
eigenvectors are: distinct eigenvalues), and equal numpy's to rounding for the same seed.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from ..conventions import Convention, group_input
from ..uncertain import UncertainPoint, UncertainPose
from .montecarlo import _aligned, _cov_generic, _element, _root

__all__ = [
    "monte_carlo_act",
    "monte_carlo_average",
    "monte_carlo_compose",
    "monte_carlo_fuse",
    "monte_carlo_inverse",
    "monte_carlo_relative",
    "monte_carlo_transform",
]


def _common(*xs: Any) -> list[Any]:
    """``xs`` with numpy operands moved to the first torch/JAX array's type, dtype and device.

    :class:`UncertainPose` objects are compared by their ``T``; arrays and ``None`` pass through
    :func:`liebridge.arrays.common`. Two torch/JAX dtypes that differ are a ``TypeError``.
    """
    ref = next(
        (
            a
            for a in (x.T if isinstance(x, UncertainPose) else x for x in xs)
            if arrays.is_foreign(a)
        ),
        None,
    )
    if ref is None:
        return list(xs)
    out = []
    for x in xs:
        if isinstance(x, UncertainPose):
            if not arrays.is_foreign(x.T):
                x = UncertainPose(
                    arrays.like(np.array(x.T), ref), arrays.like(np.array(x.cov), ref), x.convention
                )
            elif x.T.dtype != ref.dtype:
                raise TypeError(f"dtype {x.T.dtype} differs from {ref.dtype}; convert one first")
        elif x is not None:
            x = arrays.common(ref, x)[1]
        out.append(x)
    return out


def _arr(x: Any) -> Any:
    """``numpy.asarray`` for numpy input; a torch/JAX array as it is."""
    return x if arrays.is_foreign(x) else np.asarray(x)


def _rng(rng: np.random.Generator | None) -> np.random.Generator:
    return rng if rng is not None else np.random.default_rng(0)


def _check_n(n: int) -> None:
    if n < 2:
        raise ValueError(f"n: need at least 2 samples, got {n}")


def _draw(joint: FloatArray, n: int, rng: np.random.Generator) -> FloatArray:
    """``(..., n, N)`` samples of ``N(0, joint)`` (eigen square root: PSD joints allowed)."""
    if isinstance(joint, tuple) or arrays.is_foreign(joint):
        return _draw_generic(joint, n, rng)
    lam, Q = np.linalg.eigh(0.5 * (joint + np.swapaxes(joint, -1, -2)))
    S = Q * np.sqrt(np.clip(lam, 0.0, None))[..., None, :]
    z = rng.standard_normal((*joint.shape[:-2], n, joint.shape[-1]))
    return np.asarray(z @ np.swapaxes(S, -1, -2), dtype=np.float64)


def _block_diagonal(parts: list[Any]) -> Any:
    dims = [int(b.shape[-1]) for b in parts]
    return arrays.blocks(
        [
            [b if i == k else arrays.zeros((dims[i], dims[k]), b) for k in range(len(parts))]
            for i, b in enumerate(parts)
        ]
    )


def _draw_generic(joint: Any, n: int, rng: np.random.Generator) -> Any:
    """:func:`_draw` on torch/JAX arrays: numpy's normals, the factor on the device.

    ``joint`` is the joint covariance or, for independent inputs, a tuple of its diagonal
    blocks, each factored on its own (a gradient then needs distinct eigenvalues within each
    block only: an isotropic covariance that does not require grad, or a zero one, does not make
    the other's NaN). The factor's columns are ordered and signed as numpy's ``eigh`` of the
    whole joint (:func:`~liebridge.check.montecarlo._aligned`), so the draws are numpy's.
    """
    blocks = list(joint) if isinstance(joint, tuple) else [joint]
    ref = blocks[0]
    xp = arrays.namespace(ref)
    if len(blocks) > 1 and arrays.is_traced(ref):  # no alignment: numpy's order of the whole
        blocks = [_block_diagonal(blocks)]
    syms = [0.5 * (b + arrays.mT(b)) for b in blocks]
    pairs = [xp.linalg.eigh(b) for b in syms]
    lam = arrays.concat([p[0] for p in pairs], -1)
    V = pairs[0][1] if len(pairs) == 1 else _block_diagonal([p[1] for p in pairs])
    full = syms[0] if len(syms) == 1 else _block_diagonal(syms)
    S = _aligned(
        V * _root(lam)[..., None, :],
        V,
        lambda: np.linalg.eigh(arrays.to_numpy(full).astype(np.float64))[1],
    )
    z = rng.standard_normal((*ref.shape[:-2], n, int(S.shape[-1])))
    return arrays.like(z, ref) @ arrays.mT(S)


def _cov(y: FloatArray) -> FloatArray:
    if arrays.is_foreign(y):
        return _cov_generic(y)
    dy = y - y.mean(axis=-2, keepdims=True)
    return np.asarray(np.einsum("...ki,...kj->...ij", dy, dy) / (y.shape[-2] - 1), np.float64)


def _joint(A: UncertainPose, B: UncertainPose, cross: Any) -> Any:
    n = A.dim
    shape = validate.batch_shape(("A", A.batch_shape), ("B", B.batch_shape))
    if arrays.is_foreign(A.T):
        if cross is None:  # independent: the blocks (factored one by one)
            xp = arrays.namespace(A.T)
            return (
                xp.broadcast_to(A.cov, (*shape, n, n)),
                xp.broadcast_to(B.cov, (*shape, n, n)),
            )
        X = validate.square(cross, "cross", n)
        shape = validate.batch_shape(("A and B", shape), ("cross", tuple(X.shape[:-2])))
        xp = arrays.namespace(X)
        J = arrays.blocks([[A.cov, X], [arrays.mT(X), B.cov]])
        J = xp.broadcast_to(J, (*shape, 2 * n, 2 * n))
        return validate.covariance(J, "cross (the joint covariance)", 2 * n)
    X = np.zeros((n, n)) if cross is None else validate.as_float_array(cross, "cross")
    shape = validate.batch_shape(("A and B", shape), ("cross", X.shape[:-2]))
    J = np.zeros((*shape, 2 * n, 2 * n))
    J[..., :n, :n] = A.cov
    J[..., n:, n:] = B.cov
    J[..., :n, n:] = X
    J[..., n:, :n] = np.swapaxes(X, -1, -2)
    return validate.covariance(J, "cross (the joint covariance)", 2 * n)


def _same(A: UncertainPose, B: UncertainPose) -> Convention:
    if A.convention.fields != B.convention.fields:
        raise ValueError(f"B: convention {B.convention.name!r} differs from A's")
    return A.convention


def _samples(c: Convention, T: FloatArray, d: FloatArray) -> FloatArray:
    xp = arrays.namespace(T)
    return c.retract(xp.broadcast_to(T[..., None, :, :], (*d.shape[:-1], *T.shape[-2:])), d)


def _joint_samples(
    A: UncertainPose, B: UncertainPose, cross: Any, n: int, rng: np.random.Generator | None
) -> tuple[Convention, FloatArray, FloatArray]:
    """``n`` joint samples of two correlated uncertain poses (their convention, A_k, B_k)."""
    _check_n(n)
    c = _same(A, B)
    d = _draw(_joint(A, B, cross), n, _rng(rng))
    k = A.dim
    return c, _samples(c, A.T, d[..., :k]), _samples(c, B.T, d[..., k:])


def _result(c: Convention, TC: FloatArray, Y: FloatArray) -> UncertainPose:
    y = c.local(arrays.namespace(TC).broadcast_to(TC[..., None, :, :], tuple(Y.shape)), Y)
    return UncertainPose(TC, _cov(y), c)


def monte_carlo_compose(
    A: UncertainPose,
    B: UncertainPose,
    cross: Any = None,
    *,
    n: int = 20000,
    rng: np.random.Generator | None = None,
) -> UncertainPose:
    """Monte Carlo of ``compose(A, B, cross)``: samples ``A_k·B_k`` read at ``A.T·B.T``."""
    A, B, cross = _common(A, B, cross)
    c, SA, SB = _joint_samples(A, B, cross, n, rng)
    Y = SA @ SB
    return _result(c, _arr(A.T @ B.T), Y)


def monte_carlo_inverse(
    A: UncertainPose, *, n: int = 20000, rng: np.random.Generator | None = None
) -> UncertainPose:
    """Monte Carlo of ``inverse(A)``: samples ``A_k⁻¹`` read at ``A.T⁻¹``."""
    _check_n(n)
    if arrays.is_foreign(A.T):
        inv = arrays.namespace(A.T).linalg.inv
        d = _draw(A.cov, n, _rng(rng))
        Y = inv(_samples(A.convention, A.T, d))
        return _result(A.convention, _clean(inv(A.T)), _clean(Y))
    d = _draw(np.asarray(A.cov), n, _rng(rng))
    Y = np.asarray(np.linalg.inv(_samples(A.convention, A.T, d)), dtype=np.float64)
    TC = np.asarray(np.linalg.inv(A.T), dtype=np.float64)
    return _result(A.convention, _clean(TC), _clean(Y))


def monte_carlo_relative(
    A: UncertainPose,
    B: UncertainPose,
    cross: Any = None,
    *,
    n: int = 20000,
    rng: np.random.Generator | None = None,
) -> UncertainPose:
    """Monte Carlo of ``relative(A, B, cross)``: samples ``A_k⁻¹·B_k`` read at ``A.T⁻¹·B.T``."""
    A, B, cross = _common(A, B, cross)
    c, SA, SB = _joint_samples(A, B, cross, n, rng)
    if arrays.is_foreign(A.T):
        inv = arrays.namespace(A.T).linalg.inv
        return _result(c, _clean(inv(A.T) @ B.T), _clean(inv(SA) @ SB))
    Y = np.asarray(np.linalg.inv(SA) @ SB)
    TC = np.asarray(np.linalg.inv(A.T) @ B.T, dtype=np.float64)
    return _result(c, _clean(TC), _clean(Y))


def monte_carlo_transform(
    A: UncertainPose,
    T_fixed: Any,
    side: Literal["left", "right"] = "left",
    *,
    n: int = 20000,
    rng: np.random.Generator | None = None,
) -> UncertainPose:
    """Monte Carlo of ``transform(A, T_fixed, side)``, known ``T_fixed``: ``F·A_k`` or ``A_k·F``."""
    _check_n(n)
    A, T_fixed = _common(A, T_fixed)
    if arrays.is_foreign(A.T):
        F = _element(T_fixed, "T_fixed")
    else:
        F = group_input(T_fixed, "T_fixed")
    d = _draw(_arr(A.cov), n, _rng(rng))
    S = _samples(A.convention, A.T, d)
    Fb = F[..., None, :, :]
    Y = Fb @ S if side == "left" else S @ Fb
    return _result(A.convention, _arr(F @ A.T if side == "left" else A.T @ F), Y)


def monte_carlo_act(
    A: UncertainPose,
    p: Any,
    cov_p: Any = None,
    *,
    n: int = 20000,
    rng: np.random.Generator | None = None,
) -> UncertainPoint:
    """Monte Carlo of ``act(A, p, cov_p)``: points ``R_k p_k + t_k`` (``R_k p_k`` for rotations)."""
    _check_n(n)
    A, p, cov_p = _common(A, p, cov_p)
    g = _rng(rng)
    pa = validate.vector(p, "p", 3)
    if cov_p is not None:
        Cp = validate.covariance(cov_p, "cov_p", 3)
    else:
        Cp = arrays.zeros((3, 3), pa) if arrays.is_foreign(pa) else np.zeros((3, 3))
    xp = arrays.namespace(pa, Cp, A.T)
    dA = _draw(_arr(A.cov), n, g)
    pk = pa[..., None, :] + _draw(xp.broadcast_to(Cp, (*pa.shape[:-1], 3, 3)), n, g)
    S = _samples(A.convention, A.T, dA)
    if arrays.is_foreign(S):
        q, q0 = arrays.matvec(S[..., :3, :3], pk), arrays.matvec(A.T[..., :3, :3], pa)
    else:
        q = np.einsum("...ij,...j->...i", S[..., :3, :3], pk)
        q0 = np.einsum("...ij,...j->...i", A.T[..., :3, :3], pa)
    if A.dim == 6:
        q = q + S[..., :3, 3]
        q0 = q0 + A.T[..., :3, 3]
    return UncertainPoint(q0, _cov(q))


def _clean(Y: FloatArray) -> FloatArray:
    """Exact bottom row after :func:`numpy.linalg.inv` (it leaves ~1e-17 entries).

    torch/JAX: the top rows concatenated with the constant row (no in-place write).
    """
    if arrays.is_foreign(Y):
        if Y.shape[-1] != 4:
            return Y
        xp = arrays.namespace(Y)
        row = arrays.like(np.array([[0.0, 0.0, 0.0, 1.0]]), Y)
        row = xp.broadcast_to(row, (*Y.shape[:-2], 1, 4))
        return arrays.concat([Y[..., :3, :], row], -2)
    Y = np.array(Y, dtype=np.float64)
    if Y.shape[-1] == 4:
        Y[..., 3, :] = (0.0, 0.0, 0.0, 1.0)
    return Y


def monte_carlo_average(
    estimates: list[UncertainPose], *, n: int = 100000, rng: np.random.Generator | None = None
) -> UncertainPose:
    """Importance-sampled counterpart of ``average(estimates)`` (and ``fuse``).

    Samples ``X_k = c.retract(T_0, δ_k)``, ``δ_k ~ N(0, Σ_0)`` from the first estimate, weighted
    by the other factors ``exp(−½‖c.local(T_i, X_k)‖²_{Σ_i⁻¹})`` (their covariances must be
    positive definite): the product of the densities in the same sense as the MAP (chart
    coordinates, no Jacobian determinant). Returns the weighted mean (found by re-centring the
    chart three times) and the weighted covariance in ``c``'s tangent there. It is the
    posterior *mean*, which differs from the MAP at second order; the covariances agree to
    first order.
    """
    _check_n(n)
    if len(estimates) < 2:
        raise ValueError("estimates: need at least two UncertainPose objects")
    estimates = _common(*estimates)
    E0 = estimates[0]
    c = E0.convention
    for E in estimates[1:]:
        _same(E0, E)
    if E0.batch_shape or any(E.batch_shape for E in estimates):
        raise ValueError("estimates: expected unbatched UncertainPose objects")
    if arrays.is_foreign(E0.T):
        return _average_generic(estimates, n, _rng(rng))
    X = _samples(c, E0.T, _draw(np.asarray(E0.cov), n, _rng(rng)))
    logw = np.zeros(n)
    for i, E in enumerate(estimates[1:], 1):
        try:
            L = np.linalg.cholesky(np.asarray(E.cov))
        except np.linalg.LinAlgError:
            raise ValueError(f"estimates[{i}]: covariance must be positive definite") from None
        r = c.local(np.broadcast_to(E.T, X.shape), X)
        z = np.linalg.solve(L, r.T)
        logw -= 0.5 * np.einsum("ik,ik->k", z, z)
    w = np.exp(logw - logw.max())
    w /= w.sum()
    ref = np.array(E0.T)
    for _ in range(3):
        y = c.local(np.broadcast_to(ref, X.shape), X)
        ref = c.retract(ref, w @ y)
    y = c.local(np.broadcast_to(ref, X.shape), X)
    dy = y - w @ y
    cov = np.einsum("k,ki,kj->ij", w, dy, dy) / (1.0 - np.sum(w**2))
    return UncertainPose(ref, cov, c)


def _average_generic(estimates: list[UncertainPose], n: int, g: np.random.Generator) -> Any:
    """:func:`monte_carlo_average` on torch/JAX arrays: the same formulas, no in-place write.

    A covariance that is not positive definite is refused from one scalar read on the host
    (not under tracing, where it gives NaN weights instead).
    """
    E0 = estimates[0]
    c = E0.convention
    xp = arrays.namespace(E0.T)
    X = _samples(c, E0.T, _draw(E0.cov, n, g))
    shape = tuple(X.shape)
    logw = arrays.zeros((n,), E0.T)
    for i, E in enumerate(estimates[1:], 1):
        if arrays.all_true(xp.linalg.eigvalsh(E.cov) > 0) is False:
            raise ValueError(f"estimates[{i}]: covariance must be positive definite")
        L = xp.linalg.cholesky(E.cov)
        r = c.local(xp.broadcast_to(E.T, shape), X)
        z = xp.linalg.solve(L, arrays.mT(r))
        logw = logw - 0.5 * xp.sum(z * z, axis=0)
    w = xp.exp(logw - xp.max(logw))
    w = w / xp.sum(w)
    ref = E0.T
    for _ in range(3):
        y = c.local(xp.broadcast_to(ref, shape), X)
        ref = c.retract(ref, w @ y)
    y = c.local(xp.broadcast_to(ref, shape), X)
    dy = y - w @ y
    cov = arrays.mT(dy) @ (w[:, None] * dy) / (1.0 - xp.sum(w**2))
    return UncertainPose(ref, cov, c)


def monte_carlo_fuse(
    A: UncertainPose, B: UncertainPose, *, n: int = 100000, rng: np.random.Generator | None = None
) -> UncertainPose:
    """Importance-sampled counterpart of ``fuse(A, B)``: ``monte_carlo_average([A, B])``."""
    return monte_carlo_average([A, B], n=n, rng=rng)
