"""Monte Carlo check of a covariance conversion through the conventions' own maps.

On torch tensors and JAX arrays the reference runs on their device, with the same formula and
the same random numbers as numpy: the standard normals are drawn on the host by the numpy
``Generator`` (``rng``) and moved to the array's type, dtype and device (``arrays.like``); the
factor of the covariance is computed there (its own ``svd``/``eigh``), so the result is
differentiable with respect to the pose and the covariance (reparameterised samples).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from ..conventions import ConventionLike, get, unchecked


def _aligned(S: Any, V: Any, host_vectors: Callable[[], np.ndarray]) -> Any:
    """``S`` with its columns ordered and signed as numpy's factor (a torch/JAX factor).

    ``S = V √Λ`` was computed on the device; numpy's vectors ``host_vectors()`` (from a
    detached host copy) differ from ``V``'s columns by LAPACK's choices: signs (torch's ``eigh``
    flips some that numpy's and JAX's do not) and, for a factor built block by block, the
    order. Each numpy column is matched with the device column most parallel to it, giving a
    signed permutation ``P`` (a constant: no gradient is cut) and the factor ``S P``, whose
    draws ``z (S P)ᵀ`` are numpy's. Where the match is not a permutation (a repeated
    eigenvalue, whose vectors each library chooses freely) ``P = I``: the draws are still from
    the right distribution, not numpy's numbers. Under tracing the values are unknown and
    ``S`` is returned as it is.
    """
    if arrays.is_traced(S):
        return S
    Vh = host_vectors()
    D = np.swapaxes(arrays.to_numpy(V).astype(np.float64), -1, -2) @ Vh  # (j device, i numpy)
    j = np.argmax(np.abs(D), axis=-2)  # (..., N): the device column of each numpy column
    N = D.shape[-1]
    P = np.zeros(D.shape)
    np.put_along_axis(P, j[..., None, :], 1.0, axis=-2)
    P = P * np.sign(D)
    ok = np.all(np.sort(j, axis=-1) == np.arange(N), axis=-1) & np.all(np.abs(P).sum(-2) == 1, -1)
    P = np.where(ok[..., None, None], P, np.eye(N))
    return S @ arrays.like(P, S)


def _root(lam: Any) -> Any:
    """``√max(λ, 0)`` with the derivative 0 (not ∞) at ``λ ≤ 0`` (torch/JAX arrays)."""
    xp = arrays.namespace(lam)
    pos = lam > 0
    return xp.where(pos, xp.sqrt(xp.where(pos, lam, xp.ones_like(lam))), xp.zeros_like(lam))


def _element(X: Any, name: str) -> Any:
    """Validate a torch/JAX pose ``(..., 4, 4)`` or rotation ``(..., 3, 3)`` (returned as is)."""
    shape = tuple(X.shape[-2:])
    if shape == (4, 4):
        return validate.pose(X, name)
    if shape == (3, 3):
        return validate.rotation(X, name)
    raise ValueError(
        f"{name}: expected a pose (..., 4, 4) or a rotation (..., 3, 3), got {tuple(X.shape)}"
    )


def _cov_generic(y: Any) -> Any:
    """Covariance about the sample mean of ``(..., n, k)`` samples (torch/JAX; ``numpy.cov``)."""
    xp = arrays.namespace(y)
    dy = y - xp.mean(y, axis=-2, keepdims=True)
    return arrays.mT(dy) @ dy / (y.shape[-2] - 1)


def monte_carlo_covariance(
    cov: Any,
    X: Any,
    src: ConventionLike,
    dst: ConventionLike,
    *,
    n: int = 20000,
    rng: np.random.Generator | None = None,
) -> FloatArray:
    """Empirical covariance of ``dst.local(X, src.retract(X, δ))`` for ``δ ~ N(0, cov)``.

    The reference a conversion must reproduce: compare it with
    ``liebridge.convert_covariance(cov, X, src, dst)`` (first order) or ``method="unscented"``.
    The sampling error of each entry is about ``√(2/n)`` relative.

    The arguments are in the order of every covariance function of the package,
    ``(cov, X, src, dst)`` (as :func:`liebridge.convert_covariance`); before 0.2 this function
    took ``(X, cov, ...)``, and a pose given first is reported as that mistake.

    Parameters
    ----------
    cov : array_like, shape (6, 6) or (3, 3)
        Covariance in ``src``'s tangent.
    X : array_like, shape (4, 4) or (3, 3)
        One pose (or rotation).
    src, dst : Convention or str
    n : int
        Number of samples.
    rng : numpy.random.Generator, optional
        Default: ``numpy.random.default_rng(0)`` (reproducible).

    Returns
    -------
    ndarray, shape (6, 6) or (3, 3)
        Covariance about the sample mean.

    Notes
    -----
    torch tensors and JAX arrays give a result of their type, dtype and device, equal to
    numpy's for the same ``rng`` (the normals are numpy's, drawn on the host and moved to the
    device; ``numpy.random.Generator.multivariate_normal``'s factor ``U √s`` of the covariance's
    SVD is computed on the device, its column signs aligned to numpy's from a detached host
    copy), and differentiable with respect to ``cov`` and ``X`` through the samples
    (reparameterisation; ``svd``'s derivative needs distinct singular values).
    """
    a, b = get(src), get(dst)
    if np.shape(cov) == (4, 4) and np.shape(X) == (6, 6):
        raise TypeError(
            "monte_carlo_covariance: the arguments are (cov, X, src, dst); got a pose as cov and "
            "a 6×6 matrix as X (the order before 0.2)"
        )
    if arrays.any_foreign(cov, X):
        return _covariance_generic(cov, X, a, b, n, rng)
    Xa = a.element(X)  # the group is the conventions' (SE(3) ones also take a rotation)
    if Xa.ndim != 2:
        raise ValueError(f"X: expected one pose or rotation, got shape {Xa.shape}")
    dim = a.dim(Xa)
    C = validate.covariance(cov, "cov", dim)
    if n < 2:
        raise ValueError(f"n: need at least 2 samples, got {n}")
    rng = rng if rng is not None else np.random.default_rng(0)
    d = rng.multivariate_normal(np.zeros(dim), C, size=n)
    y = unchecked.local(b, Xa, unchecked.retract(a, Xa, d))
    return np.asarray(np.cov(y.T), dtype=np.float64)


def _covariance_generic(
    cov: Any, X: Any, a: Any, b: Any, n: int, rng: np.random.Generator | None
) -> Any:
    """:func:`monte_carlo_covariance` on torch/JAX arrays (numpy's draws, on the device)."""
    cov, X = arrays.common(cov, X)
    Xa = _element(X, "X")
    if Xa.ndim != 2:
        raise ValueError(f"X: expected one pose or rotation, got shape {tuple(Xa.shape)}")
    dim = 6 if Xa.shape[-1] == 4 else 3
    C = validate.covariance(cov, "cov", dim)
    if n < 2:
        raise ValueError(f"n: need at least 2 samples, got {n}")
    rng = rng if rng is not None else np.random.default_rng(0)
    z = arrays.like(rng.standard_normal((n, dim)), C)  # multivariate_normal's draws
    xp = arrays.namespace(C)
    U, s, _ = xp.linalg.svd(C)
    S = _aligned(
        U * _root(s)[None, :], U, lambda: np.linalg.svd(arrays.to_numpy(C).astype(np.float64))[0]
    )
    d = z @ arrays.mT(S)
    y = b.local(Xa, a.retract(Xa, d))
    return _cov_generic(y)
