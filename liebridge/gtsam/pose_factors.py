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

**Every group.** The group is the convention's (``convention.group``); the same two functions
build factors on GTSAM's class of that group, with the measurement as liebridge's matrix of it:

========  ===================  ==========================================================  ====
group     GTSAM variable       native factors (GTSAM 4.3.0 Python wrapper)                 dim
========  ===================  ==========================================================  ====
``se3``   ``Pose3`` (4×4)      ``BetweenFactorPose3``, ``PriorFactorPose3``                6
``se2``   ``Pose2`` (3×3)      ``BetweenFactorPose2``, ``PriorFactorPose2``                3
``sim3``  ``Similarity3``      ``BetweenFactorSimilarity3``, ``PriorFactorSimilarity3``    7
``se23``  ``NavState`` (5×5)   ``BetweenFactorNavState``, ``PriorFactorNavState``          9
========  ===================  ==========================================================  ====

GTSAM's ``Pose2`` and ``NavState`` factors linearize exactly (their Jacobians match central
differences through GTSAM's own ``retract`` to 1e-9); its ``Similarity3`` factors do **not**: GTSAM
4.3.0 linearizes them with ``(−Ad(H⁻¹), I)`` (``I`` for the prior) whatever the residual
(``Similarity3::Logmap``'s derivative is not implemented, ``gtsam/geometry/Similarity3.cpp``),
so ``native=True`` warns for Sim(3) and :class:`~liebridge.gtsam.ConventionGraph` uses the custom
factor there. GTSAM's between error is ``Local(Z, H)`` of its class
(``gtsam/slam/BetweenFactor.h``): ``Log(Z⁻¹H)`` for ``Pose2``/``Similarity3`` (presets
``gtsam_pose2``, ``gtsam_similarity3``) and the split body chart for ``NavState``
(``gtsam_navstate``; NOT ``Log(Z⁻¹H)`` with the SE₂(3) exponential). Its prior error is
``−Local(X, Z)`` (``gtsam/nonlinear/PriorFactor.h``), which is ``Log(Z⁻¹X)`` on the Lie-group
charts but, for ``NavState``, differs from liebridge's prior residual ``local(Z, X)`` at second
order (measured in ``tests/test_pose_factors.py``). A ``Similarity3`` matrix is
``[sR t; 0 1]`` (``p ↦ sRp + t``; GTSAM's constructor takes ``t/s``, the glue converts). For a
convention with an embedding (``ros_pose2``) ``cov`` is in the convention's tangent (ROS's 6×6
over ``(x, y, z, roll, pitch, yaw)``) and only its ``(x, y, yaw)`` block is used.
"""

from __future__ import annotations

import warnings
from typing import Any

import gtsam
import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions import Convention, ConventionLike, get, single_group
from ..conventions.convert import convert_covariance, is_exactly_linear
from . import factor_math
from .batch import PoseFactorSpec
from .build import gtsam_convention_of
from .custom import make_custom_factor
from .groups import GTSAM_GROUPS, GtsamGroup

__all__ = ["between", "prior"]


def _warn_first_order(conv: Convention) -> None:
    # the warnings module shows a given message once per call site (its "default" filter)
    warnings.warn(
        f"liebridge: a native GTSAM factor for convention {conv.name!r} ({conv.chart}, "
        f"{conv.rotation}) uses a first-order covariance conversion; the objective differs "
        f"from the convention's own at second order. Use native=False for its exact residual.",
        stacklevel=3,
    )


def _group_of(conv: Convention) -> GtsamGroup:
    """GTSAM's record of the convention's group (``ValueError`` where GTSAM holds none)."""
    if conv.group not in GTSAM_GROUPS:
        raise ValueError(
            f"convention: {conv.name!r} is a convention of {conv.group}; between/prior factors "
            f"exist for the groups GTSAM holds: {', '.join(GTSAM_GROUPS)} (register another with "
            f"liebridge.gtsam.register_group)"
        )
    return GTSAM_GROUPS[conv.group]


def _element(conv: Convention, X: Any, name: str) -> FloatArray:
    """Validate one element of the convention's group (liebridge's matrix of it)."""
    g = conv.record
    n = g.matrix
    Z = np.asarray(g.element(X, name), dtype=np.float64)
    if Z.shape != (n, n):
        raise ValueError(
            f"{name}: expected one {conv.group} element ({GTSAM_GROUPS[conv.group].cls}) "
            f"({n}, {n}) for convention {conv.name!r}, got {Z.shape}"
        )
    return Z


def _covariance(conv: Convention, cov: Any) -> tuple[FloatArray, FloatArray]:
    """``(cov in the convention's tangent, cov of the residual)``: equal unless embedded."""
    dim = conv.record.dim
    if conv.embed is None:
        c = validate.positive_definite(cov, "cov", dim)
        return c, c
    c = validate.covariance(cov, "cov", conv.embed.size)
    idx = list(conv.embed.index)
    block = validate.positive_definite(c[np.ix_(idx, idx)], f"cov (its block {idx})", dim)
    return c, block


def _native_noise(conv: Convention, Z: FloatArray, cov: FloatArray) -> Any:
    """GTSAM noise model of a native factor: ``cov`` converted to GTSAM's tangent at ``Z``."""
    hub = gtsam_convention_of(conv.group)
    if not is_exactly_linear(conv, hub):
        _warn_first_order(conv)
    return _noise(convert_covariance(cov, Z, conv, hub))


def _noise(cov: FloatArray) -> Any:
    return gtsam.noiseModel.Gaussian.Covariance(np.ascontiguousarray(cov))


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
    measured : array_like, shape (4, 4) (SE(3)), or the matrix of the convention's group
        The measured ``Z = T_i⁻¹·T_j`` (``T_i_j``: maps j's frame to i's); ``(3, 3)`` for an
        SE(2) convention, ``(4, 4)`` ``[sR t; 0 1]`` for Sim(3), ``(5, 5)`` for SE₂(3).
    cov : array_like, shape (n, n)
        Covariance of the residual ``convention.local(Z, T_i⁻¹T_j)``, in the convention's order
        (n = 6, 3, 7, 9 for SE(3), SE(2), Sim(3), SE₂(3); 6 for ``ros_pose2``).
    convention : Convention or str
        Its group (``convention.group``) says which GTSAM class the keys hold.
    native : bool
        ``True``: GTSAM's ``BetweenFactor{Pose3, Pose2, Similarity3, NavState}`` with the
        covariance converted at ``Z``; ``False``: a ``gtsam.CustomFactor`` with the convention's
        exact residual and Jacobians.

    Returns
    -------
    gtsam.BetweenFactorPose3 (Pose2, Similarity3, NavState) or gtsam.CustomFactor

    Raises
    ------
    ValueError
        ``measured`` not an element of the convention's group (e.g. a 3×3 rotation for SE(2), a
        Sim(3) scale ≤ 0), ``cov`` not positive definite or of the wrong size, ``i == j``.
    """
    conv = single_group(get(convention))
    g = _group_of(conv)
    Z = _element(conv, measured, "measured")
    cov_conv, cov = _covariance(conv, cov)
    i, j = validate.key(i, "i"), validate.key(j, "j")
    if i == j:
        raise ValueError(f"j: the same key as i ({i}); a between factor relates two variables")
    dim = conv.record.dim
    if native and g.between is not None:
        if g.native_warning:
            warnings.warn(g.native_warning, stacklevel=2)
        return g.between(i, j, g.to_object(Z), _native_noise(conv, Z, cov_conv))

    Zc = Z.copy()

    def evaluate(values: Any, want: bool) -> tuple[FloatArray, list[FloatArray] | None]:
        H = factor_math.relative(g.element_at(values, i), g.element_at(values, j), g.group)
        e = factor_math.residual(conv, Zc, H)
        if not want:
            return e, None
        J_e_i, J_e_j = factor_math.jacobians(conv, Zc, H, between=True)
        assert J_e_j is not None
        return e, [J_e_i, J_e_j]

    noise = _noise(cov)
    spec = _spec(conv, int(i), int(j), Zc, noise)
    return make_custom_factor(
        noise, [i, j], [dim, dim], evaluate, name=f"between[{conv.name}]({i}, {j})", spec=spec
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

    The residual is ``convention.local(pose, T_i)`` (GTSAM: ``Log(pose⁻¹·T_i)``); ``pose`` is
    an element of the convention's group; see :func:`between` for ``cov`` and ``native``.

    Returns
    -------
    gtsam.PriorFactorPose3 (Pose2, Similarity3, NavState) or gtsam.CustomFactor
    """
    conv = single_group(get(convention))
    g = _group_of(conv)
    Z = _element(conv, pose, "pose")
    cov_conv, cov = _covariance(conv, cov)
    i = validate.key(i, "i")
    dim = conv.record.dim
    if native and g.prior is not None:
        if g.native_warning:
            warnings.warn(g.native_warning, stacklevel=2)
        return g.prior(i, g.to_object(Z), _native_noise(conv, Z, cov_conv))
    Zc = Z.copy()

    def evaluate(values: Any, want: bool) -> tuple[FloatArray, list[FloatArray] | None]:
        H = factor_math.relative(g.element_at(values, i), None, g.group)
        e = factor_math.residual(conv, Zc, H)
        if not want:
            return e, None
        return e, [factor_math.jacobians(conv, Zc, H, between=False)[0]]

    noise = _noise(cov)
    spec = _spec(conv, int(i), None, Zc, noise)
    return make_custom_factor(
        noise, [i], [dim], evaluate, name=f"prior[{conv.name}]({i})", spec=spec
    )


def _spec(conv: Convention, i: int, j: int | None, Z: FloatArray, noise: Any) -> Any:
    """Return the batch spec (:mod:`liebridge.gtsam.batch`), None for an unbatched group."""
    if not GTSAM_GROUPS[conv.group].batched:
        return None  # GTSAM evaluates it through the callback
    return PoseFactorSpec(conv, i, j, Z, np.asarray(noise.R(), dtype=np.float64))
