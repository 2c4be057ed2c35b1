"""GTSAM marginals as :class:`~liebridge.uncertain.UncertainPose` objects, in any convention.

``gtsam.Marginals.marginalCovariance(key)`` is the covariance of ``ξ`` in ``X̂·Exp(ξ)``,
``ξ = (ω, v)``; ``jointMarginalCovariance([a, b]).at(a, b)`` is ``E[ξ_a ξ_bᵀ]`` (GTSAM 4.3,
``gtsam/nonlinear/Marginals.h``; checked in ``tests/test_uncertain_gtsam.py``). Converting to a
convention ``c`` maps each pose's error with its own ``M = tangent_map(X̂, "gtsam", c)``: the
marginals ``M_a Σ_a M_aᵀ``, the cross block ``M_a Σ_ab M_bᵀ``.

>>> A, B, cross = joint_marginal(marginals, values, 1, 7, "ros")     # doctest: +SKIP
>>> T_1_7 = liebridge.uncertain.relative(A, B, cross)                 # doctest: +SKIP
"""

from __future__ import annotations

from typing import Any

import gtsam
import numpy as np

from .._validate import FloatArray
from ..conventions import ConventionLike, get, tangent_map
from ..uncertain import UncertainPose
from .glue import to_gtsam

__all__ = ["joint_marginal", "marginal", "to_gtsam"]


def _check_key(values: Any, key: int) -> None:
    if not values.exists(key):
        raise ValueError(f"values: no Pose3 at key {key}")


def _pose(values: Any, key: int) -> FloatArray:
    try:
        return np.asarray(values.atPose3(key).matrix(), dtype=np.float64)
    except RuntimeError as exc:
        raise ValueError(f"values: no Pose3 at key {key} ({exc})") from None


def marginal(
    marginals: Any, values: Any, key: int, convention: ConventionLike = "gtsam"
) -> UncertainPose:
    """Return the marginal of ``Pose3`` ``key`` as an :class:`UncertainPose` in ``convention``.

    Parameters
    ----------
    marginals : gtsam.Marginals
    values : gtsam.Values
        The estimate the marginals were computed at.
    key : int
    convention : Convention or str
    """
    _check_key(values, int(key))
    cov = np.asarray(marginals.marginalCovariance(int(key)), dtype=np.float64)
    return UncertainPose(_pose(values, int(key)), 0.5 * (cov + cov.T), "gtsam").to(convention)


def joint_marginal(
    marginals: Any,
    values: Any,
    key_a: int,
    key_b: int,
    convention: ConventionLike = "gtsam",
) -> tuple[UncertainPose, UncertainPose, FloatArray]:
    """Two poses' joint marginal: ``(A, B, cross)`` with ``cross = E[δA δBᵀ]`` in ``convention``.

    Pass them to :func:`liebridge.uncertain.relative` (``relative(A, B, cross)`` is the
    covariance of ``T_a_b = T_w_a⁻¹ T_w_b``) or :func:`~liebridge.uncertain.compose`.
    """
    ka, kb = int(key_a), int(key_b)
    if ka == kb:
        raise ValueError(f"key_b: the same key as key_a ({ka}); use marginal() for one pose")
    _check_key(values, ka)
    _check_key(values, kb)
    jm = marginals.jointMarginalCovariance(gtsam.KeyVector([ka, kb]))
    Ta, Tb = _pose(values, ka), _pose(values, kb)
    caa, cbb = np.asarray(jm.at(ka, ka)), np.asarray(jm.at(kb, kb))
    cab = np.asarray(jm.at(ka, kb), dtype=np.float64)
    c = get(convention)
    A = UncertainPose(Ta, 0.5 * (caa + caa.T), "gtsam").to(c)
    B = UncertainPose(Tb, 0.5 * (cbb + cbb.T), "gtsam").to(c)
    cross = tangent_map(Ta, "gtsam", c) @ cab @ tangent_map(Tb, "gtsam", c).T
    return A, B, np.asarray(cross, dtype=np.float64)
