"""Between and prior factors on ``Pose3`` written in any convention.

A measurement ``Z`` is a pose matrix (convention-free); the convention says what the covariance
is over: the residual is ``conv.local(Z, T_i⁻¹·T_j)`` (between) or ``conv.local(Z, T_i)``
(prior), so for ``barfoot`` it is ``Log(T_i⁻¹T_j·Z⁻¹)`` in (v, ω), for ``g2o``
``(t, qvec)`` of ``Z⁻¹·T_i⁻¹T_j``, for ``gtsam`` GTSAM's own ``Log(Z⁻¹·T_i⁻¹T_j)`` in (ω, v).

``native=True`` returns GTSAM's ``BetweenFactorPose3``/``PriorFactorPose3`` with the covariance
converted to GTSAM's tangent at ``Z`` — exact (the same objective) when
:func:`liebridge.is_exactly_linear` holds between the convention and GTSAM, first order
otherwise (a warning says so, once per convention). ``native=False`` returns a
``gtsam.CustomFactor`` whose residual is the convention's own, with **analytic, exact**
Jacobians in GTSAM's tangent columns (GTSAM retracts its variables its own way):

``J_j = D·M(H)``, ``J_i = −D·M(H)·Ad(H⁻¹)`` with ``H = T_i⁻¹T_j``, ``D = conv.local_jacobian(Z, H)``
and ``M(H) = tangent_map(H, "gtsam", conv)``. For ``gtsam`` this is GTSAM's own
``H2 = Jr⁻¹(e)``, ``H1 = −Jr⁻¹(e)·Ad(H⁻¹)`` (docs/common-formula-errors.md E6). False, and tempting:
``(−Ad(H⁻¹), I)`` — exact only at zero residual; on sphere2500 it converges elsewhere.
"""

from __future__ import annotations

import warnings
from typing import Any

import gtsam
import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions import Convention, ConventionLike, get
from ..conventions.convert import convert_covariance, is_exactly_linear
from . import factor_math
from .batch import PoseFactorSpec
from .build import gtsam_convention
from .custom import make_custom_factor

__all__ = ["between", "prior"]


def _warn_first_order(conv: Convention) -> None:
    # the warnings module shows a given message once per call site (its "default" filter)
    warnings.warn(
        f"liebridge: a native GTSAM factor for convention {conv.name!r} ({conv.chart}, "
        f"{conv.rotation}) uses a first-order covariance conversion; the objective differs "
        f"from the convention's own at second order. Use native=False for its exact residual.",
        stacklevel=3,
    )


def _native_noise(conv: Convention, Z: FloatArray, cov: FloatArray) -> Any:
    """GTSAM noise model of a native factor: ``cov`` converted to GTSAM's tangent at ``Z``."""
    hub = gtsam_convention()
    if not is_exactly_linear(conv, hub):
        _warn_first_order(conv)
    return _noise(convert_covariance(cov, Z, conv, hub))


def _noise(cov: FloatArray) -> Any:
    return gtsam.noiseModel.Gaussian.Covariance(np.ascontiguousarray(cov))


def _pose_at(values: Any, key: int) -> FloatArray:
    return np.asarray(values.atPose3(key).matrix(), dtype=np.float64)


def between(
    i: int,
    j: int,
    measured: Any,
    cov: Any,
    convention: ConventionLike = "gtsam",
    *,
    native: bool = True,
) -> Any:
    """Relative-pose factor between keys ``i`` and ``j`` with a covariance in ``convention``.

    Parameters
    ----------
    i, j : int
        GTSAM keys of ``T_world_i`` and ``T_world_j``.
    measured : array_like, shape (4, 4)
        The measured ``Z = T_i⁻¹·T_j`` (``T_i_j``: maps j's frame to i's).
    cov : array_like, shape (6, 6)
        Covariance of the residual ``convention.local(Z, T_i⁻¹T_j)``, in the convention's order.
    convention : Convention or str
    native : bool
        ``True``: ``gtsam.BetweenFactorPose3`` with the covariance converted at ``Z``;
        ``False``: a ``gtsam.CustomFactor`` with the convention's exact residual and Jacobians.

    Returns
    -------
    gtsam.BetweenFactorPose3 or gtsam.CustomFactor
    """
    conv = get(convention)
    Z = validate.pose(measured, "measured")
    if Z.shape != (4, 4):
        raise ValueError(f"measured: expected one pose (4, 4), got {Z.shape}")
    cov = validate.positive_definite(cov, "cov", 6)
    i, j = validate.key(i, "i"), validate.key(j, "j")
    if i == j:
        raise ValueError(f"j: the same key as i ({i}); a between factor relates two variables")
    if native:
        return gtsam.BetweenFactorPose3(i, j, gtsam.Pose3(Z), _native_noise(conv, Z, cov))

    Zc = Z.copy()

    def evaluate(values: Any, want: bool) -> tuple[FloatArray, list[FloatArray] | None]:
        H = factor_math.relative(_pose_at(values, i), _pose_at(values, j))
        e = factor_math.residual(conv, Zc, H)
        if not want:
            return e, None
        J_e_i, J_e_j = factor_math.jacobians(conv, Zc, H, between=True)
        assert J_e_j is not None
        return e, [J_e_i, J_e_j]

    noise = _noise(cov)
    spec = PoseFactorSpec(conv, int(i), int(j), Zc, np.asarray(noise.R(), dtype=np.float64))
    return make_custom_factor(
        noise, [i, j], [6, 6], evaluate, name=f"between[{conv.name}]({i}, {j})", spec=spec
    )


def prior(
    i: int,
    pose: Any,
    cov: Any,
    convention: ConventionLike = "gtsam",
    *,
    native: bool = True,
) -> Any:
    """Prior on ``T_world_i`` at ``pose`` with a covariance in ``convention``.

    The residual is ``convention.local(pose, T_i)`` (GTSAM: ``Log(pose⁻¹·T_i)``); see
    :func:`between` for ``native``.

    Returns
    -------
    gtsam.PriorFactorPose3 or gtsam.CustomFactor
    """
    conv = get(convention)
    Z = validate.pose(pose, "pose")
    if Z.shape != (4, 4):
        raise ValueError(f"pose: expected one pose (4, 4), got {Z.shape}")
    cov = validate.positive_definite(cov, "cov", 6)
    i = validate.key(i, "i")
    if native:
        return gtsam.PriorFactorPose3(i, gtsam.Pose3(Z), _native_noise(conv, Z, cov))
    Zc = Z.copy()

    def evaluate(values: Any, want: bool) -> tuple[FloatArray, list[FloatArray] | None]:
        H = factor_math.relative(_pose_at(values, i), None)
        e = factor_math.residual(conv, Zc, H)
        if not want:
            return e, None
        return e, [factor_math.jacobians(conv, Zc, H, between=False)[0]]

    noise = _noise(cov)
    spec = PoseFactorSpec(conv, int(i), None, Zc, np.asarray(noise.R(), dtype=np.float64))
    return make_custom_factor(noise, [i], [6], evaluate, name=f"prior[{conv.name}]({i})", spec=spec)
