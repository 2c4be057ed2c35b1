"""Monte Carlo check of a covariance conversion through the conventions' own maps."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from ..conventions import ConventionLike, get, unchecked


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

    Raises
    ------
    TypeError
        For torch/JAX arrays (a numpy-only reference).
    """
    a, b = get(src), get(dst)
    if arrays.any_foreign(cov, X):
        raise TypeError(
            "monte_carlo_covariance: the Monte Carlo reference runs on numpy arrays only; pass "
            "host copies (x.detach().cpu().numpy(), numpy.asarray(x)) and compare the tensor "
            "conversion with it"
        )
    if np.shape(cov) == (4, 4) and np.shape(X) == (6, 6):
        raise TypeError(
            "monte_carlo_covariance: the arguments are (cov, X, src, dst); got a pose as cov and "
            "a 6×6 matrix as X (the order before 0.2)"
        )
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
