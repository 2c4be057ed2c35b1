"""Readers of the registration libraries' own results: Open3D, small_gicp, KISS-ICP.

Each returns a :class:`~liebridge.registration.RegistrationPose` of ``T_target_source`` in any
convention. No library is imported: objects are read by their attributes (duck typing), and a
plain ``(T, H)`` tuple of arrays works wherever a library's object does.

* Open3D: ``get_information_matrix_from_point_clouds`` is over ``(ω, t)``, left, unit noise
  (preset ``open3d``): the covariance is ``σ²·Λ⁻¹``, ``σ`` required.
* small_gicp: ``RegistrationResult.H`` is over GTSAM's chart (preset ``small_gicp``): as it is for
  GICP with metric point covariances, ``/σ²`` for ICP.
* KISS-ICP publishes no covariance: one is computed from its correspondences (point-to-point,
  ``σ`` from the residuals unless given).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions import ConventionLike, convert_information, get
from .information import RegistrationPose, information

__all__ = ["from_kiss_icp", "from_open3d", "from_small_gicp"]


def _sigma(sigma: Any) -> float:
    s = float(sigma)
    if not np.isfinite(s) or s <= 0:
        raise ValueError(f"sigma: must be finite and > 0, got {sigma!r}")
    return s


def _as_points(x: Any, name: str) -> FloatArray:
    pts = getattr(x, "points", x)  # open3d.geometry.PointCloud, small_gicp.PointCloud
    arr = validate.as_float_array(np.asarray(pts), name)
    if arr.ndim != 2 or arr.shape[1] not in (3, 4):
        raise ValueError(f"{name}: expected points of shape (N, 3), got {arr.shape}")
    arr = np.ascontiguousarray(arr[:, :3])
    if not np.isfinite(arr).all():
        i = validate.batch_index(~np.isfinite(arr))
        raise ValueError(f"{name}: NaN or Inf at point index {i[0]} of {len(arr)}; drop it first")
    return arr


def _pair(result: Any, name: str) -> tuple[Any, Any] | None:
    if isinstance(result, tuple | list) and len(result) == 2:
        return result[0], result[1]
    return None


def _from_library_matrix(
    T: Any, H: Any, library: str, scale2: float, source: str, sigma: float, convention: Any
) -> RegistrationPose:
    Tm = validate.pose(T, "T")
    Hm = validate.as_float_array(H, "H")
    if Hm.shape[-2:] != (6, 6):
        raise ValueError(f"H: expected a 6×6 matrix, got shape {Hm.shape}")
    validate.check_finite(Hm, "H", core_ndim=2)
    dst = get(convention)
    lib = get(library)
    info = convert_information(0.5 * (Hm + np.swapaxes(Hm, -1, -2)) / scale2, Tm, lib, dst)
    return RegistrationPose(
        Tm, info, dst, sigma=sigma, sigma_source=source, num_correspondences=0, model=library
    )


def from_open3d(
    result_or_information: Any,
    T: Any = None,
    *,
    sigma: Any = None,
    convention: ConventionLike = "gtsam",
    source: Any = None,
    target: Any = None,
) -> RegistrationPose:
    """Read an Open3D registration as an uncertain ``T_target_source`` in ``convention``.

    Parameters
    ----------
    result_or_information : array_like (6, 6), tuple (T, information), or RegistrationResult
        * the matrix of ``open3d.pipelines.registration.get_information_matrix_from_point_clouds``
          (``Σ GᵀG``, ``G = [−[q]ₓ | I]``: left, ``(ω, t)``, unit noise) with ``T``;
        * ``(T, information)``, the same as a pair;
        * an ``open3d.pipelines.registration.RegistrationResult`` (``transformation``,
          ``correspondence_set``) with ``source`` and ``target``: the point-to-point information
          of its correspondences at the alignment, via :func:`information` (σ from the
          residuals unless given).
    T : array_like (4, 4), optional
        ``T_target_source`` (Open3D's ``transformation``) for a bare matrix.
    sigma : float
        Residual standard deviation (m) per axis: required for a matrix (Open3D's has unit
        noise); optional for a ``RegistrationResult``.
    convention : Convention or str
    source, target : open3d.geometry.PointCloud or array_like (N, 3), optional
        The clouds a ``RegistrationResult`` was computed from.

    Returns
    -------
    RegistrationPose

    Notes
    -----
    ``Λ_conv = M⁻ᵀ (Λ_open3d / σ²) M⁻¹`` with ``M = tangent_map(T, "open3d", convention)``; to
    GTSAM ``Λ_gtsam = Ad_Tᵀ·Λ_open3d·Ad_T / σ²``. False: ``Λ_open3d / σ²`` as GTSAM information
    (side, and the ``(ω, t)`` vs ``(t, ω)`` order for g2o-ordered code).
    """
    corr = getattr(result_or_information, "correspondence_set", None)
    if corr is not None and hasattr(result_or_information, "transformation"):
        if source is None or target is None:
            raise ValueError(
                "source, target: a RegistrationResult holds correspondence indices only; pass "
                "the two point clouds it was computed from"
            )
        idx = np.asarray(corr, dtype=np.int64).reshape(-1, 2)
        p, q = _as_points(source, "source"), _as_points(target, "target")
        for name, col, n in (("source", 0, len(p)), ("target", 1, len(q))):
            if idx.size and (idx[:, col].max() >= n or idx[:, col].min() < 0):
                raise ValueError(
                    f"{name}: correspondence_set indexes point {int(idx[:, col].max())}, but "
                    f"{name} has {n} points: not the cloud the result was computed from"
                )
        Tm = np.asarray(result_or_information.transformation, dtype=np.float64)
        return information(Tm, p[idx[:, 0]], q[idx[:, 1]], sigma=sigma, convention=convention)
    pair = _pair(result_or_information, "result_or_information")
    if pair is not None:
        if T is not None:
            raise ValueError("T: given twice (in the (T, information) pair and as T)")
        T, info = pair
    else:
        info = result_or_information
    if T is None:
        raise ValueError(
            "T: Open3D's information matrix is at T_target_source (its 'transformation'); pass it"
        )
    if sigma is None:
        raise ValueError(
            "sigma: Open3D's information matrix has unit noise (entry (5, 5) is the number of "
            "correspondences); pass the residual standard deviation in metres"
        )
    s = _sigma(sigma)
    return _from_library_matrix(T, info, "open3d", s * s, "given", s, convention)


def from_small_gicp(
    result: Any, sigma: Any = None, *, convention: ConventionLike = "gtsam"
) -> RegistrationPose:
    """Read a small_gicp ``RegistrationResult`` as an uncertain ``T_target_source``.

    Parameters
    ----------
    result : small_gicp.RegistrationResult or tuple (T_target_source, H)
        ``H`` over small_gicp's tangent: ``T·Exp(δ)``, ``δ = (ω, ρ)`` (GTSAM's chart).
    sigma : float, optional
        For ``ICP`` (unit-noise residuals) the residual standard deviation in metres:
        ``Λ = H/σ²``. Not given: ``H`` is taken as the information as it is — right for GICP
        with point covariances in m² only; small_gicp's own ``estimate_covariances`` normalises
        them (then pass the scale as ``sigma`` or calibrate, see :func:`information`).
    convention : Convention or str

    Notes
    -----
    ``H`` is the linearisation before the last update: at convergence the difference is below
    the convergence threshold. False: ``H`` is a covariance, or over ``(ρ, ω)``.
    """
    pair = _pair(result, "result")
    if pair is not None:
        T, H = pair
    else:
        T = getattr(result, "T_target_source", None)
        H = getattr(result, "H", None)
        if T is None or H is None:
            raise TypeError(
                f"result: expected a small_gicp RegistrationResult (T_target_source, H) or a "
                f"(T, H) pair, got {type(result).__name__}"
            )
    if sigma is None:
        return _from_library_matrix(T, H, "small_gicp", 1.0, "library", 1.0, convention)
    s = _sigma(sigma)
    return _from_library_matrix(T, H, "small_gicp", s * s, "given", s, convention)


def from_kiss_icp(
    source: Any,
    target: Any,
    T: Any,
    *,
    max_correspondence_distance: Any = None,
    sigma: Any = None,
    convention: ConventionLike = "gtsam",
) -> RegistrationPose:
    """Read a KISS-ICP alignment as an uncertain ``T_target_source`` (covariance computed here).

    KISS-ICP publishes no covariance (its ROS node writes a fixed diagonal). This finds the
    correspondences it would use — nearest target point to each ``T·p`` within
    ``max_correspondence_distance`` — and returns their point-to-point :func:`information`
    (σ from the residuals unless given).

    Parameters
    ----------
    source : array_like (N, 3)
        The registered frame's points in its own frame (KISS-ICP's ``source`` of
        ``register_frame``).
    target : array_like (M, 3)
        The map it was registered against, in the target (map) frame
        (``local_map.point_cloud()``).
    T : array_like (4, 4)
        ``T_target_source``: KISS-ICP's ``last_pose`` (map ← frame).
    max_correspondence_distance : float, optional
        Default: three times the median nearest-neighbour distance.
    sigma, convention
        As :func:`information`.
    """
    from scipy.spatial import cKDTree

    p, q = _as_points(source, "source"), _as_points(target, "target")
    Tm = validate.pose(T, "T")
    if Tm.shape != (4, 4):
        raise ValueError(f"T: expected one (4, 4) pose, got shape {Tm.shape}")
    s = p @ Tm[:3, :3].T + Tm[:3, 3]
    dist, nn = cKDTree(q).query(s)
    if max_correspondence_distance is None:
        tau = 3.0 * float(np.median(dist))
    else:
        tau = float(max_correspondence_distance)
        if not np.isfinite(tau) or tau <= 0:
            raise ValueError(
                f"max_correspondence_distance: must be finite and > 0, got "
                f"{max_correspondence_distance!r}"
            )
    keep = dist <= tau
    if keep.sum() < 3:
        raise ValueError(
            f"max_correspondence_distance: {int(keep.sum())} of {len(p)} points have a target "
            f"point within {tau:.3g} m: not enough to estimate a covariance"
        )
    return information(Tm, p[keep], q[nn[keep]], sigma=sigma, convention=convention)
