"""Monte Carlo check of a covariance conversion through the conventions' own maps."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _validate as v
from .._validate import FloatArray
from ..conventions import ConventionLike, get, group_input, unchecked


def monte_carlo_covariance(
    X: Any,
    cov: Any,
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

    Parameters
    ----------
    X : array_like, shape (4, 4) or (3, 3)
        One pose (or rotation).
    cov : array_like, shape (6, 6) or (3, 3)
        Covariance in ``src``'s tangent.
    src, dst : Convention or str
    n : int
        Number of samples.
    rng : numpy.random.Generator, optional
        Default: ``numpy.random.default_rng(0)`` (reproducible).

    Returns
    -------
    ndarray, shape (6, 6) or (3, 3)
        Covariance about the sample mean.
    """
    a, b = get(src), get(dst)
    Xa = group_input(X)
    if Xa.ndim != 2:
        raise ValueError(f"X: expected one pose or rotation, got shape {Xa.shape}")
    dim = 3 if Xa.shape == (3, 3) else 6
    C = v.covariance(cov, "cov", dim)
    if n < 2:
        raise ValueError(f"n: need at least 2 samples, got {n}")
    rng = rng if rng is not None else np.random.default_rng(0)
    d = rng.multivariate_normal(np.zeros(dim), C, size=n)
    y = unchecked.local(b, Xa, unchecked.retract(a, Xa, d))
    return np.asarray(np.cov(y.T), dtype=np.float64)
