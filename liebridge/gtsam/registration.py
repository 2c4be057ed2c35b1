"""A registration result as GTSAM's ``BetweenFactorPose3``: direction, order, side and scale right.

``BetweenFactor<Pose3>(key_target, key_source, Z)`` has the error ``Log(Z⁻¹·X_t⁻¹·X_s)`` over
``(ω, v)`` (``gtsam/slam/BetweenFactor.h``), right perturbation, so ``Z = T_target_source``
(``X_t⁻¹·X_s`` with ``X = T_world_node``) and its information is the registration's in GTSAM's
tangent: for Open3D's matrix ``Λ = Ad_Zᵀ·Λ_open3d·Ad_Z / σ²``, for small_gicp's ``H`` as it is
(GICP, metric covariances) or ``H/σ²`` (ICP). False, and common: the keys swapped (the factor
then measures ``T_source_target`` with the same numbers), ``Λ_open3d`` copied as it is (wrong
side), or reordered to ``(v, ω)`` for code written for g2o.
"""

from __future__ import annotations

from typing import Any

import gtsam
import numpy as np

from .. import _validate as validate
from ..conventions import ConventionLike, get
from ..registration import RegistrationPose, from_small_gicp
from ..uncertain import UncertainPose

__all__ = ["registration_factor"]


def registration_factor(
    key_target: Any,
    key_source: Any,
    result: Any,
    *,
    sigma: Any = None,
    convention: ConventionLike | None = None,
) -> Any:
    """``gtsam.BetweenFactorPose3(key_target, key_source, T_target_source, Gaussian(Λ_gtsam))``.

    Parameters
    ----------
    key_target, key_source : int
        Keys of the poses ``T_world_target``, ``T_world_source``.
    result : UncertainPose, small_gicp.RegistrationResult or tuple (T, H)
        * an :class:`~liebridge.uncertain.UncertainPose` of ``T_target_source`` in any convention
          (what :func:`liebridge.registration.information`, ``from_open3d``, ``from_small_gicp``
          and ``from_kiss_icp`` return);
        * a small_gicp ``RegistrationResult`` (read by
          :func:`liebridge.registration.from_small_gicp` with ``sigma``);
        * ``(T, H)``: ``H`` an information matrix over ``convention``'s tangent (required then),
          divided by ``sigma²`` when given.
    sigma : float, optional
        Residual standard deviation for unit-noise matrices (small_gicp ICP, a ``(T, H)`` pair).
    convention : Convention or str, optional
        The tangent of ``H`` in a ``(T, H)`` pair (``"open3d"``, ``"small_gicp"``, ...).

    Returns
    -------
    gtsam.BetweenFactorPose3
    """
    kt, ks = validate.key(key_target, "key_target"), validate.key(key_source, "key_source")
    if kt == ks:
        raise ValueError(f"key_source: the same key as key_target ({kt})")
    if isinstance(result, tuple | list):
        if len(result) != 2:
            raise ValueError(f"result: expected a (T, H) pair, got {len(result)} items")
        if convention is None:
            raise ValueError(
                "convention: a (T, H) pair does not say which tangent H is over; pass "
                "convention='open3d', 'small_gicp', 'kiss_icp', 'gtsam', ..."
            )
        s2 = 1.0
        if sigma is not None:
            s = float(sigma)
            if not np.isfinite(s) or s <= 0:
                raise ValueError(f"sigma: must be finite and > 0, got {sigma!r}")
            s2 = s * s
        H = validate.as_float_array(result[1], "H")
        if H.shape != (6, 6):
            raise ValueError(f"H: expected shape (6, 6), got {H.shape}")
        result = RegistrationPose(result[0], H / s2, get(convention), sigma=np.sqrt(s2))
    elif not isinstance(result, UncertainPose):
        if hasattr(result, "T_target_source") and hasattr(result, "H"):
            result = from_small_gicp(result, sigma)
        else:
            raise TypeError(
                f"result: expected an UncertainPose, a small_gicp RegistrationResult or a "
                f"(T, H) pair, got {type(result).__name__} (an Open3D RegistrationResult: "
                f"read it with liebridge.registration.from_open3d(result, source=, target=))"
            )
    elif sigma is not None:
        raise ValueError("sigma: an UncertainPose already carries its scale")
    if result.is_rotation or result.batch_shape:
        raise ValueError(
            f"result: expected one pose, got batch shape {result.batch_shape}"
            + (" of rotations" if result.is_rotation else "")
        )
    cov = result.to("gtsam").cov
    info = np.linalg.inv(cov)
    info = 0.5 * (info + info.T)
    return gtsam.BetweenFactorPose3(
        kt, ks, gtsam.Pose3(np.asarray(result.T)), gtsam.noiseModel.Gaussian.Information(info)
    )
