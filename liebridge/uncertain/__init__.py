"""Uncertain poses in any convention: compose, inverse, relative, change of frame, act, fusion.

An :class:`UncertainPose` ``(T, cov, convention)`` is the random pose
``convention.retract(T, δ)``, ``δ ~ N(0, cov)``. Every operation keeps the convention and
propagates the covariance to first order (``method="linear"``: the Jacobians at the means, equal
to GTSAM's ``H`` matrices carried into the convention) or with a fifth-degree cubature
(``method="unscented"``). Monte Carlo counterparts are in :mod:`liebridge.check`
(``monte_carlo_compose``, ...); GTSAM marginals come in through
:func:`liebridge.gtsam.uncertain.joint_marginal`; plots are in :mod:`liebridge.uncertain.plot`
(``plot`` extra).

>>> import numpy as np
>>> from liebridge import uncertain as u
>>> A = u.UncertainPose(np.eye(4), 1e-4 * np.eye(6), "ros")
>>> u.inverse(A).cov.shape
(6, 6)
"""

from .fusion import average, fuse
from .ops import act, compose, inverse, relative, sigma_points, transform
from .pose import UncertainPoint, UncertainPose

__all__ = [
    "UncertainPoint",
    "UncertainPose",
    "act",
    "average",
    "compose",
    "fuse",
    "inverse",
    "relative",
    "sigma_points",
    "transform",
]
