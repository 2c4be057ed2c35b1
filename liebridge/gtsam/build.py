"""Which convention the *installed* GTSAM implements — measured once, never assumed.

GTSAM's ``Pose3`` chart depends on build flags: the PyPI wheel retracts with the SE(3)
exponential (preset ``gtsam``); builds with ``GTSAM_POSE3_EXPMAP=OFF`` (the default before
mid-2020) use the decoupled Cayley chart (preset ``gtsam_cayley``). :func:`gtsam_convention`
runs :func:`liebridge.detect_convention` on ``gtsam.Pose3.retract`` at first use and caches the
answer; the factor glue, marginals and :class:`~liebridge.gtsam.ConventionGraph` use it as
"GTSAM's tangent". Both charts agree to first order, so Jacobians are unaffected; what changes is
whether a side/order conversion is *exact* and what a marginal covariance means at second order.
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable
from typing import Any

import gtsam
import numpy as np

from .._validate import FloatArray
from ..conventions import GTSAM, GTSAM_CAYLEY, Convention, detect_convention
from .groups import gtsam_group

__all__ = ["gtsam_convention", "gtsam_convention_of", "measure_pose3_convention"]


def gtsam_convention_of(group: str) -> Convention:
    """GTSAM's tangent of ``group``'s GTSAM class: the preset its ``retract`` implements.

    Read from the group's GTSAM record (:mod:`liebridge.gtsam.groups`): ``"se3"``:
    :func:`gtsam_convention` (measured); ``"se2"``: ``gtsam_pose2``; ``"sim3"``:
    ``gtsam_similarity3``; ``"se23"``: ``gtsam_navstate``; a user's registered group: its hub.
    Marginals and native factors of that class are over this tangent (fixed by GTSAM's code, not
    by build flags, except ``Pose3``'s; checked against the installed GTSAM by the tests).
    """
    return gtsam_group(group).hub_convention()


def _pose3_retract(X: FloatArray, d: FloatArray) -> FloatArray:
    return np.asarray(gtsam.Pose3(X).retract(d).matrix(), dtype=np.float64)


@functools.lru_cache(maxsize=1)
def gtsam_convention() -> Convention:
    """Return the preset matching the installed ``gtsam.Pose3.retract`` (measured, cached).

    Raises
    ------
    liebridge.conventions.ConventionNotDetected
        If the installed GTSAM implements neither known chart (the message says what it does).
    """
    return measure_pose3_convention(_pose3_retract)


def measure_pose3_convention(retract: Callable[[FloatArray, FloatArray], Any]) -> Convention:
    """Return ``gtsam`` or ``gtsam_cayley`` for a ``Pose3.retract``-like callable (not cached).

    :func:`gtsam_convention` applies it to the installed GTSAM; given a Cayley-chart retraction
    (``liebridge.conventions.GTSAM_CAYLEY.retract``, what a ``GTSAM_POSE3_EXPMAP=OFF`` build
    does) it warns and returns ``gtsam_cayley``.
    """
    found = detect_convention(retract, prefer="gtsam")
    if found.fields == GTSAM.fields:
        return GTSAM
    if found.fields == GTSAM_CAYLEY.fields:
        warnings.warn(
            "liebridge: the installed GTSAM retracts Pose3 with the decoupled Cayley chart "
            "(built with GTSAM_POSE3_EXPMAP=OFF); using preset 'gtsam_cayley' as GTSAM's tangent",
            stacklevel=2,
        )
        return GTSAM_CAYLEY
    raise ValueError(
        f"the installed GTSAM's Pose3.retract implements {found.describe()}, which is neither "
        f"'gtsam' nor 'gtsam_cayley'"
    )
