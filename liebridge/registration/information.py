"""The information of an alignment: Gauss–Newton Hessian, noise scale, degeneracy, calibration.

``information(T, p, q, ...)`` returns a :class:`RegistrationPose`: an
:class:`~liebridge.uncertain.UncertainPose` of ``T_target_source`` (the random pose
``convention.retract(T, δ)``, ``δ ~ N(0, cov)``) with ``cov = (Σ JᵀWJ / σ²)⁻¹``, the Jacobians
``J`` of :mod:`liebridge.registration.residuals` in the requested convention, plus what the
number rests on (``sigma``, where it came from, the correspondence count). It is the
Gauss–Newton Hessian *at the alignment* (``T·p``, not the target points Open3D uses).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions import Convention, ConventionLike, get, single_group
from ..uncertain import UncertainPose
from .residuals import gicp, point_to_plane, point_to_point

__all__ = ["RegistrationPose", "information", "nees_scale", "unobservable_directions"]

#: Eigenvalues of the Hessian below this fraction of the largest are unobservable directions.
DEGENERATE_RTOL = 1e-9

_INFLATE = ("residual", "nees")


class RegistrationPose(UncertainPose):
    """An :class:`~liebridge.uncertain.UncertainPose` of ``T_target_source`` from a registration.

    Attributes
    ----------
    T, cov, convention
        As :class:`~liebridge.uncertain.UncertainPose`: ``convention.retract(T, δ)``,
        ``δ ~ N(0, cov)``.
    information : ndarray, shape (..., 6, 6)
        ``cov⁻¹`` in ``convention``'s tangent (the Hessian divided by ``sigma²`` and any
        inflation).
    sigma : float or ndarray
        The noise scale used: the residual's standard deviation (point-to-point per axis,
        point-to-plane along the normal), or the scale of GICP's point covariances.
    sigma_source : str
        ``"given"`` (the caller's ``sigma``), ``"residual"`` (estimated from the residuals,
        ``σ² = Σ rᵀWr / (m − 6)`` over ``m`` scalar residuals), ``"metric"`` (GICP point
        covariances taken as m², no scaling) or ``"library"`` (a library's matrix as it is).
    inflation : float
        Extra covariance factor (``inflate="nees"`` or a number), 1 if none.
    num_correspondences : int
        ``N`` (0 where a library's matrix was read without its correspondences).
    model : str
        ``"point_to_point"``, ``"point_to_plane"``, ``"gicp"`` or the library's name.

    Notes
    -----
    :meth:`to` and indexing return a plain :class:`~liebridge.uncertain.UncertainPose`.
    """

    __slots__ = (
        "inflation",
        "information",
        "model",
        "num_correspondences",
        "sigma",
        "sigma_source",
    )
    information: FloatArray
    sigma: Any
    sigma_source: str
    inflation: float
    num_correspondences: int
    model: str

    def __init__(
        self,
        T: Any,
        information: Any,
        convention: ConventionLike,
        *,
        sigma: Any = 1.0,
        sigma_source: str = "given",
        inflation: float = 1.0,
        num_correspondences: int = 0,
        model: str = "",
    ) -> None:
        info = np.asarray(information, dtype=np.float64)
        _raise_if_degenerate(info, single_group(get(convention)), "information")
        cov = np.linalg.inv(info)
        super().__init__(T, 0.5 * (cov + np.swapaxes(cov, -1, -2)), convention)
        frozen = np.array(0.5 * (info + np.swapaxes(info, -1, -2)), copy=True)
        frozen.setflags(write=False)
        object.__setattr__(self, "information", frozen)
        s = np.asarray(sigma, dtype=np.float64)
        object.__setattr__(self, "sigma", float(s) if s.ndim == 0 else s)
        object.__setattr__(self, "sigma_source", sigma_source)
        object.__setattr__(self, "inflation", float(inflation))
        object.__setattr__(self, "num_correspondences", int(num_correspondences))
        object.__setattr__(self, "model", model)

    def __repr__(self) -> str:
        s = self.sigma if isinstance(self.sigma, float) else "per batch"
        return (
            f"RegistrationPose({self.model}, N={self.num_correspondences}, sigma={s} "
            f"({self.sigma_source}), convention={self.convention.name!r})"
        )


def _labels(conv: Convention) -> list[str]:
    rot, trans = ["ωx", "ωy", "ωz"], ["vx", "vy", "vz"]
    return rot + trans if conv.order == "rot_first" else trans + rot


def unobservable_directions(H: Any, convention: ConventionLike = "gtsam") -> list[str]:
    """Describe the near-null directions of a 6×6 Hessian in ``convention``'s coordinates.

    A direction is an eigenvector whose eigenvalue is below :data:`DEGENERATE_RTOL` times the
    largest; each is written as its components above 0.1, e.g. ``"+1.00·vx +0.00·vy"``.
    """
    A = validate.square(H, "H", 6)
    A = 0.5 * (A + A.T)
    lam, V = np.linalg.eigh(A)
    labels = _labels(single_group(get(convention)))
    out = []
    for k in np.flatnonzero(lam <= DEGENERATE_RTOL * max(float(lam[-1]), 1e-300)):
        v = V[:, k] * np.sign(V[np.argmax(np.abs(V[:, k])), k])
        out.append(" ".join(f"{v[i]:+.2f}·{labels[i]}" for i in range(6) if abs(v[i]) > 0.1))
    return out


def _raise_if_degenerate(H: FloatArray, conv: Convention, name: str) -> None:
    if H.shape[-2:] != (6, 6):
        raise ValueError(f"{name}: expected shape (..., 6, 6), got {H.shape}")
    validate.check_finite(H, name, core_ndim=2)
    A = 0.5 * (H + np.swapaxes(H, -1, -2))
    lam = np.linalg.eigvalsh(A)
    bad = lam[..., 0] <= DEGENERATE_RTOL * np.maximum(lam[..., -1], 1e-300)
    if bad.any():
        i = validate.batch_index(bad)
        dirs = unobservable_directions(A[i], conv)
        where = f" at batch index {i}" if i else ""
        raise ValueError(
            f"{name}: singular{where} (degenerate geometry: eigenvalues "
            f"{np.array2string(lam[i], precision=3)}); unobservable directions in the "
            f"{conv.name} tangent: {'; '.join(f'[{d}]' for d in dirs)}"
        )


def nees_scale(errors: Any, covariances: Any) -> float:
    """Return the covariance factor that makes a held-out set consistent: ``mean(eᵀΣ⁻¹e)/dim``.

    Parameters
    ----------
    errors : array_like, shape (K, dim)
        Estimation errors ``local(T_true, T_est)`` in the covariances' convention.
    covariances : array_like, shape (K, dim, dim) or (dim, dim)
        The (uncalibrated) covariances the method reported.

    Returns
    -------
    float
        ``k`` such that ``k·Σ`` has average NEES ``dim`` on this set (pass it as
        ``inflate=k``, or the set as ``holdout=`` with ``inflate="nees"``).
    """
    e = validate.as_float_array(errors, "errors")
    if e.ndim != 2 or e.shape[0] < 1:
        raise ValueError(f"errors: expected shape (K, dim) with K ≥ 1, got {e.shape}")
    validate.check_finite(e, "errors", core_ndim=1)
    C = validate.covariance(covariances, "covariances", e.shape[1])
    sol = np.linalg.solve(np.broadcast_to(C, (e.shape[0], *C.shape[-2:])), e[..., None])[..., 0]
    return float(np.mean(np.einsum("ki,ki->k", e, sol)) / e.shape[1])


def _inflation(inflate: Any, holdout: Any) -> float:
    if inflate is None:
        return 1.0
    if isinstance(inflate, str):
        key = validate.option(inflate, "inflate", _INFLATE)
        if key == "nees":
            if holdout is None:
                raise ValueError(
                    "holdout: inflate='nees' needs a held-out set (errors (K, 6), covariances "
                    "(K, 6, 6)) of registrations with known truth"
                )
            errors, covs = holdout
            return nees_scale(errors, covs)
        return 1.0  # "residual" is handled with sigma
    k = float(inflate)
    if not np.isfinite(k) or k <= 0:
        raise ValueError(f"inflate: a factor must be finite and > 0, got {inflate!r}")
    return k


def information(
    T: Any,
    p_src: Any,
    q_tgt: Any,
    *,
    n_tgt: Any = None,
    C_src: Any = None,
    C_tgt: Any = None,
    sigma: Any = None,
    convention: ConventionLike = "gtsam",
    inflate: Any = None,
    holdout: Any = None,
) -> RegistrationPose:
    """Return the information of an alignment: an uncertain ``T_target_source`` in ``convention``.

    ``Λ = Σᵢ JᵢᵀWᵢJᵢ / σ²`` — the Gauss–Newton Hessian of ``½Σ rᵀWr/σ²`` at ``T`` with the
    Jacobians over ``convention``'s tangent (:func:`point_to_point`, :func:`point_to_plane`,
    :func:`gicp`; ``W = I``, 1 or GICP's per-correspondence information).

    Parameters
    ----------
    T : array_like, shape (..., 4, 4)
        ``T_target_source`` at the alignment.
    p_src, q_tgt : array_like, shape (..., N, 3)
        Corresponding points (the inliers the registration used).
    n_tgt : array_like, shape (..., N, 3), optional
        Target normals: point-to-plane.
    C_src, C_tgt : array_like, shape (..., N, 3, 3), optional
        Point covariances (both, or neither): GICP.
    sigma : float, optional
        Noise scale. Point-to-point/plane (unit-noise residuals): the residual's standard
        deviation in metres; when not given it is estimated, ``σ² = Σ rᵀr / (m − 6)`` over the
        ``m`` scalar residuals, and reported (``sigma_source="residual"``). GICP: the scale of
        the point covariances (noise ``σ²·(C_tgt + R·C_src·Rᵀ)``); not given: 1, covariances in m².
    convention : Convention or str
        The tangent of the result (``"gtsam"``, ``"open3d"``, ``"small_gicp"``, ``"kiss_icp"``,
        any SE(3) preset).
    inflate : {None, "residual", "nees"} or float
        ``"residual"``: σ² from the residuals for GICP too (the remedy when the point covariances
        carry no scale). ``"nees"``: multiply the covariance by :func:`nees_scale` of ``holdout``.
        A number: multiply the covariance by it. Correlated correspondences (Censi) make the
        unit-noise Hessian over-confident: calibrate.
    holdout : tuple (errors, covariances), optional
        For ``inflate="nees"``: errors ``local(T_true, T_est)`` ``(K, 6)`` of registrations with
        known truth, in ``convention``, and the covariances this function returned for them
        *without* ``inflate`` (same ``sigma``, same model): the factor is relative to those.

    Returns
    -------
    RegistrationPose

    Raises
    ------
    ValueError
        Bad points (see :func:`point_to_point`), too few correspondences to estimate σ, an
        exact alignment with no ``sigma``, a singular Hessian (degenerate geometry, e.g. one plane
        under point-to-plane), naming the unobservable directions in ``convention``'s coordinates.
    """
    conv = single_group(get(convention))
    if (C_src is None) != (C_tgt is None):
        raise ValueError("C_src, C_tgt: GICP needs both point covariances (or neither)")
    if n_tgt is not None and C_src is not None:
        raise ValueError("n_tgt: give normals (point-to-plane) or covariances (GICP), not both")
    k = _inflation(inflate, holdout)
    if C_src is not None:
        model = "gicp"
        r, J, W = gicp(T, p_src, q_tgt, C_src, C_tgt, conv)
        H = np.einsum("...nia,...nij,...njb->...ab", J, W, J)
        chi2 = np.einsum("...ni,...nij,...nj->...", r, W, r)
        m = 3 * r.shape[-2]
    elif n_tgt is not None:
        model = "point_to_plane"
        r, J = point_to_plane(T, p_src, q_tgt, n_tgt, conv)
        H = np.einsum("...na,...nb->...ab", J, J)
        chi2 = np.einsum("...n,...n->...", r, r)
        m = r.shape[-1]
    else:
        model = "point_to_point"
        r, J = point_to_point(T, p_src, q_tgt, conv)
        H = np.einsum("...nia,...nib->...ab", J, J)
        chi2 = np.einsum("...ni,...ni->...", r, r)
        m = 3 * r.shape[-2]
    _raise_if_degenerate(H, conv, "information")
    residual = isinstance(inflate, str) and inflate.strip().lower() == "residual"
    if residual and sigma is not None:
        raise ValueError("sigma: give sigma or inflate='residual' (which estimates it), not both")
    if sigma is not None:
        s = float(sigma)
        if not np.isfinite(s) or s <= 0:
            raise ValueError(f"sigma: must be finite and > 0, got {sigma!r}")
        s2: Any = s * s
        source = "given"
    elif model != "gicp" or residual:
        if m <= 6:
            raise ValueError(
                f"p_src: {m} scalar residuals cannot estimate σ (need more than 6); pass sigma"
            )
        s2 = chi2 / (m - 6)
        if (s2 <= 0).any():
            raise ValueError(
                "sigma: the residuals are all zero (an exact alignment): σ cannot be estimated; "
                "pass sigma"
            )
        source = "residual"
    else:
        s2 = 1.0
        source = "metric"
    s2a = np.asarray(s2, dtype=np.float64)
    info = H / (s2a[..., None, None] * k)
    return RegistrationPose(
        np.broadcast_to(validate.pose(T, "T"), (*info.shape[:-2], 4, 4)),
        info,
        conv,
        sigma=np.sqrt(s2a),
        sigma_source=source,
        inflation=k,
        num_correspondences=r.shape[-2] if model != "point_to_plane" else r.shape[-1],
        model=model,
    )
