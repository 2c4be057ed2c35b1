"""NEES and ANEES of an estimated trajectory with covariances, in the estimator's convention.

The estimator reports, per pose, ``T_est`` and a covariance ``Σ`` of the error of the truth
about it **in its own convention**: ``T_ref = conv.retract(T_est, d)`` with ``d ~ N(0, Σ)``
(for GTSAM's convention ``T_ref = T_est·Exp(d)``, ``d = (ω, v)``). So the error is
``e = conv.local(T_est, T_ref)`` and

``NEES_i = e_iᵀ Σ_i⁻¹ e_i``,   ``ANEES = (1/N) Σ_i NEES_i``.

For a consistent estimator ``NEES_i ~ χ²(6)`` and ``N·ANEES ~ χ²(6N)`` (errors independent
across poses), so the two-sided bounds at confidence ``c`` are
``χ²₆⁻¹((1 ∓ c)/2)`` per pose and ``χ²₆ₙ⁻¹((1 ∓ c)/2)/N`` for the ANEES (Bar-Shalom, Li,
Kirubarajan, *Estimation with Applications to Tracking and Navigation*, 2001, §5.4.2; quantiles
from ``scipy.stats.chi2.ppf``).

NEES is invariant under a change of convention done right (``e' = M e``, ``Σ' = M Σ Mᵀ`` to
first order); it is **not** invariant under a covariance read in the wrong convention — a left
(world-frame) covariance read as a right (body-frame) one, or ``(ω, v)`` read as ``(v, ω)`` —
which is what makes it a check of the convention as much as of the estimator. Under an alignment
(:class:`~liebridge.traj.align.Alignment`) the covariances must move with the poses:
``nees(T_ref, A.apply(T_est), A.transform_covariance(T_est, Σ, conv), conv)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions import ConventionLike, get, pose_convention
from ..conventions import unchecked as cu

__all__ = ["NEESResult", "chi2_bounds", "nees"]


def chi2_bounds(dof: int, n: int = 1, confidence: float = 0.95) -> tuple[float, float]:
    """Two-sided bounds of the mean of ``n`` independent ``χ²(dof)`` draws at ``confidence``.

    ``(χ²_{n·dof}⁻¹((1 − c)/2) / n, χ²_{n·dof}⁻¹((1 + c)/2) / n)``.
    """
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence: expected a number in (0, 1), got {confidence!r}")
    if dof < 1 or n < 1:
        raise ValueError(f"dof, n: expected integers ≥ 1, got {dof!r}, {n!r}")
    a = 0.5 * (1.0 - confidence)
    lo, hi = stats.chi2.ppf([a, 1.0 - a], dof * n) / n
    return float(lo), float(hi)


@dataclass(frozen=True)
class NEESResult:
    """NEES per pose and over the trajectory, with χ² bounds.

    Attributes
    ----------
    nees : ndarray, shape (N,)
    errors : ndarray, shape (N, 6)
        ``conv.local(T_est, T_ref)`` in the convention's order.
    dof : int
    confidence : float
    pose_bounds : tuple of float
        Bounds of one ``NEES_i``.
    anees_bounds : tuple of float
        Bounds of the ANEES over ``N`` poses.
    """

    nees: FloatArray
    errors: FloatArray
    dof: int
    confidence: float
    pose_bounds: tuple[float, float]
    anees_bounds: tuple[float, float]

    @property
    def anees(self) -> float:
        """Mean NEES over the poses."""
        return float(np.mean(self.nees))

    @property
    def consistent(self) -> bool:
        """Whether the ANEES lies inside :attr:`anees_bounds`."""
        return bool(self.anees_bounds[0] <= self.anees <= self.anees_bounds[1])

    @property
    def fraction_inside(self) -> float:
        """Fraction of poses whose NEES lies inside :attr:`pose_bounds` (≈ ``confidence``)."""
        lo, hi = self.pose_bounds
        return float(np.mean((self.nees >= lo) & (self.nees <= hi)))


def nees(
    T_ref: Any,
    T_est: Any,
    cov_est: Any,
    convention: ConventionLike,
    *,
    confidence: float = 0.95,
) -> NEESResult:
    """NEES of associated (and, if wanted, aligned) poses; see the module docstring.

    Parameters
    ----------
    T_ref, T_est : array_like, shape (N, 4, 4)
        Reference (truth) and estimate, ``T_world_body``.
    cov_est : array_like, shape (N, 6, 6)
        Covariance of ``conv.local(T_est, T_ref)`` in ``convention``'s tangent at ``T_est``;
        symmetric positive definite.
    convention : Convention or str
        The estimator's convention (e.g. ``"gtsam"``, ``"ros"``, ``"sophus"``).
    confidence : float
        Of the two-sided χ² bounds (0.95).

    Raises
    ------
    ValueError
        Shapes that do not match (naming both lengths), or a covariance that is not symmetric
        positive definite (naming the pose index).
    """
    conv = get(convention)
    pose_convention(conv, "convention", np.eye(4))
    Tr = validate.pose(T_ref, "T_ref")
    Te = validate.pose(T_est, "T_est")
    if Tr.ndim != 3 or Tr.shape != Te.shape:
        raise ValueError(f"T_ref, T_est: expected two (N, 4, 4) arrays, got {Tr.shape}, {Te.shape}")
    cov = validate.as_float_array(cov_est, "cov_est")
    if cov.ndim != 3 or cov.shape[1:] != (6, 6):
        raise ValueError(f"cov_est: expected shape (N, 6, 6), got {cov.shape}")
    if cov.shape[0] != Te.shape[0]:
        raise ValueError(
            f"cov_est: {cov.shape[0]} covariances for {Te.shape[0]} poses of the estimate"
        )
    cov = validate.covariance(cov, "cov_est", 6)
    with np.errstate(over="ignore", invalid="ignore"):  # reported just below, by pose
        e = cu.local(conv, Te, Tr)
    if not np.isfinite(e).all():
        i = int(np.argmax(~np.isfinite(e).all(axis=-1)))
        raise ValueError(
            f"T_ref, T_est: the error {conv.name}.local(T_est, T_ref) at pose {i} overflows "
            "float64 (the poses are too far apart to be compared in float64)"
        )
    try:
        L = np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        lam = np.linalg.eigvalsh(cov)[:, 0]
        i = int(np.argmin(lam))
        raise ValueError(
            f"cov_est: not positive definite at pose {i} (smallest eigenvalue {lam[i]:.3g}); "
            f"the NEES needs an invertible covariance"
        ) from None
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # reported just below
        z = np.linalg.solve(L, e[..., None])[..., 0]
        values = np.einsum("ni,ni->n", z, z)
    if not np.isfinite(values).all():
        i = int(np.argmax(~np.isfinite(values)))
        lam_i = float(np.linalg.eigvalsh(cov[i])[0])
        raise ValueError(
            f"cov_est: the NEES at pose {i} overflows float64 (largest error component "
            f"{float(np.abs(e[i]).max()):.3g}, smallest covariance eigenvalue {lam_i:.3g}): the "
            "error is too large for this covariance to be represented"
        )
    n = Te.shape[0]
    return NEESResult(
        nees=np.asarray(values, dtype=np.float64),
        errors=np.asarray(e, dtype=np.float64),
        dof=6,
        confidence=confidence,
        pose_bounds=chi2_bounds(6, 1, confidence),
        anees_bounds=chi2_bounds(6, n, confidence),
    )
