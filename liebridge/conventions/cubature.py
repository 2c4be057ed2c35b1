"""Gaussian cubature for the unscented conversions and uncertain-pose operations.

One rule serves every sigma-point computation of the package: :func:`cubature_rule_5` (Stroud's
fifth-degree rule) and :func:`sqrt_psd`, a symmetric square root that accepts a semi-definite
covariance. ``liebridge.conventions.convert_covariance(..., method="unscented")`` and
``liebridge.uncertain`` (``method="unscented"``) both use them.

The rule's points and weights are constants (numpy; move them with ``arrays.like``);
:func:`sqrt_psd` runs on numpy arrays and, with the same formula, on torch tensors and JAX arrays
(their own ``eigh``: the caller's array type, device and dtype, differentiable).
"""

from __future__ import annotations

import numpy as np

from .. import arrays
from .._validate import FloatArray

__all__ = ["cubature_rule_5", "sqrt_psd"]


def cubature_rule_5(n: int) -> tuple[FloatArray, FloatArray]:
    """Fifth-degree Gaussian cubature for ``N(0, I_n)``: ``2n² + 1`` points and weights.

    Stroud's rule En^r² 5-2 (A. H. Stroud, *Approximate Calculation of Multiple Integrals*, 1971;
    also Lu & Darmofal, SIAM J. Sci. Comput. 26(2), 2004): the origin with weight ``2/(n+2)``,
    ``±√(n+2)·e_i`` with weight ``(4−n)/(2(n+2)²)``, ``√((n+2)/2)·(±e_i ± e_j)`` (``i < j``) with
    weight ``1/(n+2)²``. It integrates every polynomial of degree ≤ 5 exactly (tested), so a
    covariance through a map quadratic in the perturbation is exact. For ``n > 4`` some weights
    are negative: it is a cubature rule, not a set of samples.

    Returns
    -------
    points : ndarray, shape (2n² + 1, n)
    weights : ndarray, shape (2n² + 1,)
    """
    if n < 1:
        raise ValueError(f"n: expected a positive dimension, got {n}")
    eye = np.eye(n)
    r = np.sqrt((n + 2.0) / 2.0)
    i, j = np.triu_indices(n, 1)
    pairs = [eye[i] * si + eye[j] * sj for si in (r, -r) for sj in (r, -r)]
    pts = np.concatenate(
        [np.zeros((1, n)), np.sqrt(n + 2.0) * eye, -np.sqrt(n + 2.0) * eye, *pairs]
    )
    w = np.concatenate(
        [
            [2.0 / (n + 2)],
            np.full(2 * n, (4.0 - n) / (2.0 * (n + 2) ** 2)),
            np.full(4 * len(i), 1.0 / (n + 2) ** 2),
        ]
    )
    return pts, w


def sqrt_psd(cov: FloatArray) -> FloatArray:
    """``S`` with ``S Sᵀ = Σ`` for symmetric positive semi-definite ``Σ`` (..., n, n).

    ``S = U √Λ`` from the eigendecomposition ``U Λ Uᵀ`` of the symmetric part, negative rounding
    eigenvalues clipped to 0 (a Cholesky factor would refuse a singular covariance). ``S`` is not
    the symmetric square root ``U √Λ Uᵀ``; its columns are the eigenvectors scaled, in LAPACK's
    order (ascending eigenvalues) and with the library's signs (numpy and JAX agree, torch's
    ``eigh`` may flip a column): a cubature rule symmetric under sign changes and permutations of
    the coordinates, such as :func:`cubature_rule_5`, gives the same result for each.

    numpy input keeps numpy's code; a torch tensor or a JAX array runs the same formula in its
    own namespace (``xp.linalg.eigh``; the clip as ``where``, with a derivative 0 at a zero
    eigenvalue instead of ``√``'s infinite one) and returns an array of its type, device and
    dtype. Differentiable where the eigenvectors are, i.e. at covariances with distinct
    eigenvalues (``eigh``'s derivative divides by their differences).
    """
    if arrays.is_foreign(cov):
        xp = arrays.namespace(cov)
        lam, U = xp.linalg.eigh(0.5 * (cov + arrays.mT(cov)))
        pos = lam > 0
        root = xp.where(pos, xp.sqrt(xp.where(pos, lam, xp.ones_like(lam))), xp.zeros_like(lam))
        return U * root[..., None, :]
    lam, U = np.linalg.eigh(0.5 * (cov + np.swapaxes(cov, -1, -2)))
    return np.asarray(U * np.sqrt(np.clip(lam, 0.0, None))[..., None, :], dtype=np.float64)
