"""Ceres (``pyceres``) from Python in any convention: costs, parameter blocks, covariances.

A pose in pyceres 2.6 is **two parameter blocks**: a unit quaternion ``q`` (with
``pyceres.QuaternionManifold``, storage ``[w, x, y, z]``, or ``pyceres.EigenQuaternionManifold``,
storage ``[x, y, z, w]``) and a translation ``t`` (Euclidean), ``T = [R(q), t]`` with ``t`` the
body origin in the world frame (``T_world_body``). A Python ``pyceres.Manifold`` cannot be
used by the solver and ``ProductManifold`` is not exposed by the release, so these are the only
pose parameterisations a Python user has. Their tangent is the ``ceres_pose`` preset: rotation
first, **left** perturbation with a **half-angle** vector (``Plus(q, δ) = [cos‖δ‖,
sin‖δ‖ δ/‖δ‖] ⊗ q``: the rotation angle is ``2‖δ‖``), world translation ``t + u``.

What this module gives:

* :func:`between_cost`, :func:`prior_cost`: ``pyceres.CostFunction`` s whose residual is
  ``L · conv.local(Z, ·)`` in the named convention (``LᵀL = cov⁻¹``, ``cov`` in that convention's
  tangent), with Jacobians taken with respect to the **stored** blocks (``∂r/∂q`` is
  ``(6, 4)``, ``∂r/∂t`` is ``(6, 3)``), exact: the chain rule through the quaternion. Ceres
  multiplies them by the manifold's ``PlusJacobian`` itself. The tempting false Jacobian — the
  ``(6, 6)`` tangent Jacobian padded to ``[J 0]`` — is wrong for every quaternion manifold.
* :func:`pose_blocks`, :func:`pose_from_blocks`, :func:`quaternion_manifold`: the blocks to
  register and back.
* :func:`covariance`: pyceres's **tangent-space** covariance of one pose (or the joint one of
  two poses, cross terms included) converted exactly into any convention. ``get_covariance_block``
  is ambient (``4×4`` for a quaternion) and is not a tangent covariance. Read as a full-angle
  rotation covariance, the tangent rotation block is 4× too small: the map to GTSAM's
  ``(ω, v)`` is ``blkdiag(2Rᵀ, Rᵀ)``.
* :func:`graph_from_g2o`, :func:`problem_from_values`: the same g2o or GTSAM pose graph as a
  pyceres problem with these costs, to solve one graph with both back ends and compare.

pyceres 2.6 crashes (SIGSEGV) when ``Problem.evaluate_residuals`` is the first evaluation of a
Python cost function (it reads Jacobian pointers that are not there); every cost built here has
been evaluated once with Jacobians on construction, which avoids it.

Which objective: a cost in ``gtsam``, ``sophus`` or ``barfoot`` (residuals that are exact
linear images of one another, the covariance converted with them) defines the same objective,
hence the same optimum; ``ros`` or ``symforce`` costs (split charts, world translation) define
a different one — close to it at small residuals, not equal.
"""

from __future__ import annotations

from .costs import (
    CeresProblem,
    between_cost,
    covariance,
    evaluate_residuals,
    graph_from_g2o,
    pose_blocks,
    pose_from_blocks,
    prior_cost,
    problem_from_values,
    quaternion_manifold,
)

__all__ = [
    "CeresProblem",
    "between_cost",
    "covariance",
    "evaluate_residuals",
    "graph_from_g2o",
    "pose_blocks",
    "pose_from_blocks",
    "prior_cost",
    "problem_from_values",
    "quaternion_manifold",
]
