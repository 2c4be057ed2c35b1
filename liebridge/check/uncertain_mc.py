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
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from ..conventions import Convention, group_input
from ..uncertain import UncertainPoint, UncertainPose

__all__ = [
    "monte_carlo_act",
    "monte_carlo_average",
    "monte_carlo_compose",
    "monte_carlo_fuse",
    "monte_carlo_inverse",
    "monte_carlo_relative",
    "monte_carlo_transform",
]


def _numpy_only(op: str, *xs: Any) -> None:
    """Refuse torch/JAX inputs: the Monte Carlo references run on numpy (a host reference)."""
    for x in xs:
        arr = x.T if isinstance(x, UncertainPose) else x
        if arrays.is_foreign(arr):
            raise TypeError(
                f"{op}: the Monte Carlo references run on numpy arrays only, got a "
                f"{type(arr).__module__}.{type(arr).__name__}; compare a tensor result against "
                "the reference of its numpy copy (e.g. UncertainPose(T.detach().cpu().numpy(), "
                "cov.detach().cpu().numpy(), convention))"
            )


def _rng(rng: np.random.Generator | None) -> np.random.Generator:
    return rng if rng is not None else np.random.default_rng(0)


def _check_n(n: int) -> None:
    if n < 2:
        raise ValueError(f"n: need at least 2 samples, got {n}")


def _draw(joint: FloatArray, n: int, rng: np.random.Generator) -> FloatArray:
    """``(..., n, N)`` samples of ``N(0, joint)`` (eigen square root: PSD joints allowed)."""
    lam, Q = np.linalg.eigh(0.5 * (joint + np.swapaxes(joint, -1, -2)))
    S = Q * np.sqrt(np.clip(lam, 0.0, None))[..., None, :]
    z = rng.standard_normal((*joint.shape[:-2], n, joint.shape[-1]))
    return np.asarray(z @ np.swapaxes(S, -1, -2), dtype=np.float64)


def _cov(y: FloatArray) -> FloatArray:
    dy = y - y.mean(axis=-2, keepdims=True)
    return np.asarray(np.einsum("...ki,...kj->...ij", dy, dy) / (y.shape[-2] - 1), np.float64)


def _joint(A: UncertainPose, B: UncertainPose, cross: Any) -> FloatArray:
    n = A.dim
    shape = validate.batch_shape(("A", A.batch_shape), ("B", B.batch_shape))
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
    return c.retract(np.broadcast_to(T[..., None, :, :], (*d.shape[:-1], *T.shape[-2:])), d)


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
    y = c.local(np.broadcast_to(TC[..., None, :, :], Y.shape), Y)
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
    _numpy_only("monte_carlo_compose", A, B, cross)
    c, SA, SB = _joint_samples(A, B, cross, n, rng)
    Y = SA @ SB
    return _result(c, np.asarray(A.T @ B.T), Y)


def monte_carlo_inverse(
    A: UncertainPose, *, n: int = 20000, rng: np.random.Generator | None = None
) -> UncertainPose:
    """Monte Carlo of ``inverse(A)``: samples ``A_k⁻¹`` read at ``A.T⁻¹``."""
    _numpy_only("monte_carlo_inverse", A)
    _check_n(n)
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
    _numpy_only("monte_carlo_relative", A, B, cross)
    c, SA, SB = _joint_samples(A, B, cross, n, rng)
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
    _numpy_only("monte_carlo_transform", A, T_fixed)
    _check_n(n)
    F = group_input(T_fixed, "T_fixed")
    d = _draw(np.asarray(A.cov), n, _rng(rng))
    S = _samples(A.convention, A.T, d)
    Fb = F[..., None, :, :]
    Y = Fb @ S if side == "left" else S @ Fb
    return _result(A.convention, np.asarray(F @ A.T if side == "left" else A.T @ F), Y)


def monte_carlo_act(
    A: UncertainPose,
    p: Any,
    cov_p: Any = None,
    *,
    n: int = 20000,
    rng: np.random.Generator | None = None,
) -> UncertainPoint:
    """Monte Carlo of ``act(A, p, cov_p)``: points ``R_k p_k + t_k`` (``R_k p_k`` for rotations)."""
    _numpy_only("monte_carlo_act", A, p, cov_p)
    _check_n(n)
    g = _rng(rng)
    pa = validate.vector(p, "p", 3)
    Cp = np.zeros((3, 3)) if cov_p is None else validate.covariance(cov_p, "cov_p", 3)
    dA = _draw(np.asarray(A.cov), n, g)
    pk = pa[..., None, :] + _draw(np.broadcast_to(Cp, (*pa.shape[:-1], 3, 3)), n, g)
    S = _samples(A.convention, A.T, dA)
    q = np.einsum("...ij,...j->...i", S[..., :3, :3], pk)
    q0 = np.einsum("...ij,...j->...i", A.T[..., :3, :3], pa)
    if A.dim == 6:
        q = q + S[..., :3, 3]
        q0 = q0 + A.T[..., :3, 3]
    return UncertainPoint(q0, _cov(q))


def _clean(Y: FloatArray) -> FloatArray:
    """Exact bottom row after :func:`numpy.linalg.inv` (it leaves ~1e-17 entries)."""
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
    _numpy_only("monte_carlo_average", *estimates)
    if len(estimates) < 2:
        raise ValueError("estimates: need at least two UncertainPose objects")
    E0 = estimates[0]
    c = E0.convention
    for E in estimates[1:]:
        _same(E0, E)
    if E0.batch_shape or any(E.batch_shape for E in estimates):
        raise ValueError("estimates: expected unbatched UncertainPose objects")
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


def monte_carlo_fuse(
    A: UncertainPose, B: UncertainPose, *, n: int = 100000, rng: np.random.Generator | None = None
) -> UncertainPose:
    """Importance-sampled counterpart of ``fuse(A, B)``: ``monte_carlo_average([A, B])``."""
    return monte_carlo_average([A, B], n=n, rng=rng)
