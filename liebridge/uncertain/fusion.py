"""Fusion of several estimates of one pose: the MAP of the product of their densities.

Each estimate ``(T_i, Σ_i)`` in a convention ``c`` contributes the factor
``½‖c.local(T_i, X)‖²_{Σ_i⁻¹}`` — the cost of GTSAM's ``PriorFactor`` when ``c`` is GTSAM's
(``traits<Pose3>::Local(prior, x)``, ``gtsam/slam/PriorFactor.h``); as in every factor graph the
chart's Jacobian determinant is not part of the density. :func:`average` minimises the sum by
Gauss–Newton in ``c``'s chart at the iterate, ``X ← c.retract(X, δ)``, and returns the minimiser
with the inverse Gauss–Newton Hessian there, ``(Σ_i J_iᵀ Σ_i⁻¹ J_i)⁻¹`` with
``J_i = c.local_jacobian(T_i, X)``, as its covariance (in ``c``'s tangent at ``X``).

When the means agree this is information-weighted fusion, ``Σ = (Σ_A⁻¹ + Σ_B⁻¹)⁻¹``. Singular
covariances (a direction known exactly) are allowed for all but one estimate: the step is taken
in covariance (Kalman) form with a positive definite estimate as the prior, so nothing singular
is inverted. False: the fused mean is the weighted average of the matrices or of their
logarithms at the identity (neither is the MAP, and the first is not a pose).

On torch tensors and JAX arrays the same iteration runs with the array API (differentiable
through its steps); one estimate, positive definite at every batch index, is then the prior for
the whole batch, and under tracing a fixed :data:`TRACED_ITERATIONS` steps are taken
(docs/tensors.md).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from ..conventions import Convention, unchecked
from ..lie import unchecked as U
from .ops import _check_pair, _check_uncertain, _sym
from .pose import UncertainPose, _rot, moved, same_dtype

__all__ = ["average", "fuse"]

#: Gauss–Newton stops when the step's largest entry is below this (radians / translation units
#: relative to the poses' scale).
STEP_TOL = 1e-12
MAX_ITERATIONS = 50
#: Gauss–Newton iterations under tracing (``jax.jit``, ``torch.compile``, ``torch.func``), where
#: the step size cannot be read: a fixed count (quadratic convergence from agreeing estimates).
TRACED_ITERATIONS = 8


def _is_pd(cov: FloatArray) -> FloatArray:
    """Per batch element: positive definite (relative to its scale)."""
    lam = np.linalg.eigvalsh(_sym(cov))
    scale = np.maximum(np.abs(lam).max(axis=-1), 1e-300)
    return np.asarray(lam[..., 0] > 1e-12 * scale)


def fuse(A: UncertainPose, B: UncertainPose) -> UncertainPose:
    """Fuse two estimates of the same pose: ``average([A, B])``.

    The MAP of the product of the two densities, with the inverse Hessian there as its
    covariance; for equal means ``Σ = (Σ_A⁻¹ + Σ_B⁻¹)⁻¹`` (information-weighted fusion).
    At least one of the two covariances must be positive definite.
    """
    return _average([A, B], ("A", "B"))


def average(estimates: Sequence[UncertainPose]) -> UncertainPose:
    """MAP pose of ``n`` estimates of one pose and its covariance (see the module docstring).

    Parameters
    ----------
    estimates : sequence of UncertainPose
        Same group and convention, broadcastable batch shapes. At every batch index at least
        one covariance must be positive definite.

    Returns
    -------
    UncertainPose
        In the estimates' convention; the covariance is in its tangent at the returned pose.

    Notes
    -----
    The stationarity condition is ``Σ_i J_iᵀ Σ_i⁻¹ c.local(T_i, X) = 0``: with ``J_i ≈ I``
    (estimates close together) it is the weighted Karcher (Fréchet) mean of the ``T_i`` in the
    chart. The estimates must agree well enough for Gauss–Newton to converge (their differences
    inside the chart's domain, rotation angles below π); otherwise a ``ValueError`` says so.
    """
    est = list(estimates)
    return _average(est, tuple(f"estimates[{i}]" for i in range(len(est))))


def _average(est: list[UncertainPose], names: tuple[str, ...]) -> UncertainPose:
    if not est:
        raise ValueError("estimates: need at least one UncertainPose")
    shape = _check_uncertain(est[0], names[0]).batch_shape
    for i, E in enumerate(est[1:], 1):
        shape = validate.batch_shape(
            (names[0], shape), (names[i], _check_pair(est[0], E, names[0], names[i]))
        )
    c = est[0].convention
    n = est[0].dim
    if any(arrays.is_foreign(E.T) for E in est):
        return _average_generic(est, names, shape)
    Ts = [np.broadcast_to(E.T, (*shape, *E.T.shape[-2:])) for E in est]
    Cs = [np.broadcast_to(E.cov, (*shape, n, n)) for E in est]
    if len(est) == 1:
        return UncertainPose(Ts[0], Cs[0], c)
    pd = np.stack([_is_pd(C) for C in Cs])  # (n_est, *shape)
    if not pd.any(axis=0).all():
        bad = np.argwhere(~pd.any(axis=0))
        idx = tuple(int(i) for i in bad[0]) if bad.size else ()
        raise ValueError(
            f"estimates: every covariance is singular at batch index {idx}: the product of "
            "degenerate densities has no unique MAP and no covariance; at least one estimate "
            "must have a positive definite covariance"
        )
    # prior: per batch element the first positive definite estimate; the rest are measurements
    k = np.argmax(pd, axis=0)  # (*shape)
    sel = np.arange(len(est)).reshape((-1, *([1] * len(shape)))) == k[None]
    T_all, C_all = np.stack(Ts), np.stack(Cs)
    T_prior = np.where(sel[..., None, None], T_all, 0.0).sum(axis=0)
    C_prior = np.where(sel[..., None, None], C_all, 0.0).sum(axis=0)
    # the other estimates' indices, per batch element (a stable sort puts the prior last)
    others = np.moveaxis(np.argsort(sel, axis=0, kind="stable")[:-1], 0, -1)  # (*shape, m)
    T_oth = np.take_along_axis(
        np.moveaxis(T_all, 0, len(shape)), others[..., None, None], axis=len(shape)
    )
    C_oth = np.take_along_axis(
        np.moveaxis(C_all, 0, len(shape)), others[..., None, None], axis=len(shape)
    )
    m = len(est) - 1
    R_big = np.zeros((*shape, m * n, m * n))
    for j in range(m):
        R_big[..., j * n : (j + 1) * n, j * n : (j + 1) * n] = C_oth[..., j, :, :]

    X = T_prior.copy()
    P = C_prior
    for _ in range(MAX_ITERATIONS):
        delta, P = _step(c, X, T_prior, C_prior, T_oth, R_big, n, m)
        X = unchecked.retract(c, X, delta)
        if not np.isfinite(X).all():
            break
        if np.abs(delta).max(initial=0.0) <= STEP_TOL * max(1.0, np.abs(X).max(initial=0.0)):
            _, P = _step(c, X, T_prior, C_prior, T_oth, R_big, n, m)
            return UncertainPose(X, _sym(P), c)
    raise ValueError(
        f"estimates: Gauss–Newton did not converge in {MAX_ITERATIONS} iterations (last step "
        f"{float(np.abs(delta).max()):.3g}): the estimates disagree too much for one MAP in the "
        f"{c.name!r} chart"
    )


def _step(
    c: Convention,
    X: FloatArray,
    T_prior: FloatArray,
    C_prior: FloatArray,
    T_oth: FloatArray,
    R_big: FloatArray,
    n: int,
    m: int,
) -> tuple[FloatArray, FloatArray]:
    """One Gauss–Newton step in covariance form; returns ``δ`` and the posterior covariance."""
    r0 = unchecked.local(c, T_prior, X)
    J0 = unchecked.local_jacobian(c, T_prior, X)
    # prior on δ: r0 + J0 δ ~ N(0, Σ0)  =>  δ ~ N(−J0⁻¹ r0, J0⁻¹ Σ0 J0⁻ᵀ)
    J0i = np.linalg.inv(J0)
    mean = -np.einsum("...ij,...j->...i", J0i, r0)
    P = J0i @ C_prior @ np.swapaxes(J0i, -1, -2)
    Xb = np.broadcast_to(X[..., None, :, :], T_oth.shape)
    r = unchecked.local(c, T_oth, Xb).reshape((*X.shape[:-2], m * n))
    Jb = unchecked.local_jacobian(c, T_oth, Xb).reshape((*X.shape[:-2], m * n, n))
    # measurements: r + H δ ~ N(0, R)
    PHt = P @ np.swapaxes(Jb, -1, -2)
    S = _sym(Jb @ PHt + R_big)
    innov = -r - np.einsum("...ij,...j->...i", Jb, mean)
    K = np.swapaxes(np.linalg.solve(S, np.swapaxes(PHt, -1, -2)), -1, -2)
    delta = mean + np.einsum("...ij,...j->...i", K, innov)
    # Joseph form (I − KH) P (I − KH)ᵀ + K R Kᵀ, not P − K H P: a sum of two Gram-type products
    # stays positive semi-definite to rounding, where the difference of a zero-covariance
    # measurement's update leaves negative eigenvalues (−1e-20 next to a zero posterior)
    A = np.eye(n) - K @ Jb
    P_post = A @ P @ np.swapaxes(A, -1, -2) + K @ R_big @ np.swapaxes(K, -1, -2)
    return np.asarray(delta, dtype=np.float64), np.asarray(P_post, dtype=np.float64)


# ----------------------------------------------------------------------------- torch and JAX
# The same Gauss–Newton in covariance form, written with the array API (no in-place write, no
# host round trip: the result keeps the estimates' type, device, dtype and autograd graph). One
# difference: the prior is one estimate for the whole batch (the first whose covariance is
# positive definite at every batch index), where numpy picks one per batch element.


def _embedded(X: Any) -> Any:
    """Return a torch/JAX rotation as the pose ``[[R, 0], [0, 1]]`` (the engine maps poses).

    Exact for every SE(3) chart: a zero translation increment keeps the translation zero, and the
    rotation coordinates of a pose's chart are those of its rotation (see ``ops._map``).
    """
    return U.se3_assemble(X, arrays.zeros((*X.shape[:-2], 3), X))


def _g_local(c: Convention, X: Any, Y: Any) -> Any:
    if X.shape[-1] == 4:
        return unchecked.local(c, X, Y)
    return unchecked.local(c, _embedded(X), _embedded(Y))[..., _rot(c)]


def _g_local_jacobian(c: Convention, X: Any, Y: Any) -> Any:
    if X.shape[-1] == 4:
        return unchecked.local_jacobian(c, X, Y)
    r = _rot(c)
    return unchecked.local_jacobian(c, _embedded(X), _embedded(Y))[..., r, r]


def _g_retract(c: Convention, X: Any, d: Any) -> Any:
    if X.shape[-1] == 4:
        return unchecked.retract(c, X, d)
    xp = arrays.namespace(d)
    z = xp.zeros_like(d)
    d6 = arrays.concat([d, z] if c.order == "rot_first" else [z, d], -1)
    return unchecked.retract(c, _embedded(X), d6)[..., :3, :3]


def _is_pd_generic(cov: Any) -> Any:
    xp = arrays.namespace(cov)
    lam = xp.linalg.eigvalsh(0.5 * (cov + arrays.mT(cov)))
    scale = xp.max(xp.abs(lam), axis=-1)
    return lam[..., 0] > 1e-12 * scale


def _average_generic(
    est: list[UncertainPose], names: tuple[str, ...], shape: tuple[int, ...]
) -> UncertainPose:
    ref = next(E.T for E in est if arrays.is_foreign(E.T))
    for i, E in enumerate(est):  # numpy estimates join the tensors' type, device and dtype
        if not arrays.is_foreign(E.T):
            est[i] = E = moved(E, ref)
        same_dtype(ref, E.T, f"{names[i]}.T", "the first torch/JAX estimate's T")
    xp = arrays.namespace(ref)
    c, n = est[0].convention, est[0].dim
    Ts = [xp.broadcast_to(E.T, (*shape, *E.T.shape[-2:])) for E in est]
    Cs = [xp.broadcast_to(E.cov, (*shape, n, n)) for E in est]
    if len(est) == 1:
        return UncertainPose(Ts[0], Cs[0], c)
    pd = [arrays.all_true(_is_pd_generic(C)) for C in Cs]
    if any(p is None for p in pd):  # traced: the first estimate is the prior
        k = 0
    elif not any(pd):
        masks = np.stack([arrays.to_numpy(_is_pd_generic(C)) for C in Cs])
        bad = np.argwhere(~masks.any(axis=0))
        if bad.size:
            idx = tuple(int(i) for i in bad[0])
            raise ValueError(
                f"estimates: every covariance is singular at batch index {idx}: the product of "
                "degenerate densities has no unique MAP and no covariance; at least one estimate "
                "must have a positive definite covariance"
            )
        raise ValueError(
            "estimates: on torch/JAX arrays one estimate's covariance must be positive definite "
            "at every batch index (it is the prior of the Gauss–Newton step); none is: reorder "
            "the batch, or fuse numpy arrays (a prior per batch element)"
        )
    else:
        k = pd.index(True)
    T_prior, C_prior = Ts[k], Cs[k]
    others = [i for i in range(len(est)) if i != k]
    m = len(others)
    T_oth = xp.stack([Ts[i] for i in others], axis=-3)  # (*shape, m, d, d)
    Z = arrays.zeros((n, n), ref)
    R_big = arrays.blocks(
        [[Cs[i] if i == j else Z for j in others] for i in others]
    )  # block diagonal, (*shape, m·n, m·n)
    X = T_prior
    tol = max(STEP_TOL, 64.0 * arrays.eps(ref))  # float32: its rounding floor, not 1e-12
    for it in range(MAX_ITERATIONS):
        delta, P = _step_generic(c, X, T_prior, C_prior, T_oth, R_big, n, m)
        X = _g_retract(c, X, delta)
        if arrays.all_true(xp.isfinite(X)) is False:
            break
        small = xp.max(xp.abs(delta)) <= tol * xp.clip(xp.max(xp.abs(X)), min=1.0)
        done = arrays.all_true(small)
        if done or (done is None and it + 1 >= TRACED_ITERATIONS):
            _, P = _step_generic(c, X, T_prior, C_prior, T_oth, R_big, n, m)
            return UncertainPose(X, _sym(P), c)
    raise ValueError(
        f"estimates: Gauss–Newton did not converge in {MAX_ITERATIONS} iterations (last step "
        f"{float(arrays.to_numpy(xp.max(xp.abs(delta)))):.3g}): the estimates disagree too much "
        f"for one MAP in the {c.name!r} chart"
    )


def _step_generic(
    c: Convention, X: Any, T_prior: Any, C_prior: Any, T_oth: Any, R_big: Any, n: int, m: int
) -> tuple[Any, Any]:
    """:func:`_step` written with the array API (same formulas, Joseph form)."""
    xp = arrays.namespace(X)
    r0 = _g_local(c, T_prior, X)
    J0i = xp.linalg.inv(_g_local_jacobian(c, T_prior, X))
    mean = -arrays.matvec(J0i, r0)
    P = J0i @ C_prior @ arrays.mT(J0i)
    Xb = xp.broadcast_to(X[..., None, :, :], T_oth.shape)
    batch = tuple(X.shape[:-2])
    r = xp.reshape(_g_local(c, T_oth, Xb), (*batch, m * n))
    Jb = xp.reshape(_g_local_jacobian(c, T_oth, Xb), (*batch, m * n, n))
    PHt = P @ arrays.mT(Jb)
    S = _sym(Jb @ PHt + R_big)
    innov = -r - arrays.matvec(Jb, mean)
    K = arrays.mT(xp.linalg.solve(S, arrays.mT(PHt)))
    delta = mean + arrays.matvec(K, innov)
    A = arrays.eye(n, X) - K @ Jb
    return delta, A @ P @ arrays.mT(A) + K @ R_big @ arrays.mT(K)
