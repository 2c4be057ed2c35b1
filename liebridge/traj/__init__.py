"""Trajectory evaluation with covariances: association, interpolation, alignment, APE/RPE, NEES.

evo's core (``evo.core.sync``, ``geometry``, ``metrics``; evo 1.38) with the same definitions
and defaults, batched, plus what evo has no notion of: covariances carried in the estimator's
convention through interpolation and alignment, and their consistency (NEES/ANEES with χ²
bounds). Poses are ``T_world_body`` ``(N, 4, 4)``, timestamps seconds, covariances
``(N, 6, 6)`` in a named :class:`~liebridge.conventions.Convention`.

Modules: :mod:`~liebridge.traj.association` (timestamps), :mod:`~liebridge.traj.interpolate`,
:mod:`~liebridge.traj.align` (Umeyama SE(3)/Sim(3)/4-DoF), :mod:`~liebridge.traj.metrics`
(APE, RPE, KITTI segments, statistics), :mod:`~liebridge.traj.nees`,
:mod:`~liebridge.traj.sync` (association + optional resampling, with covariances).
"""

from .align import ALIGNMENTS, Alignment, align, umeyama
from .association import MAX_DIFF, associate, check_timestamps
from .interpolate import METHODS, interpolate_covariances, interpolate_poses
from .metrics import (
    KITTI_LENGTHS,
    POSE_RELATIONS,
    KittiSegments,
    Statistics,
    ape,
    kitti_segment_errors,
    rpe,
    rpe_pairs,
    statistics,
)
from .nees import NEESResult, chi2_bounds, nees
from .sync import Synchronized, synchronize

__all__ = [
    "ALIGNMENTS",
    "KITTI_LENGTHS",
    "MAX_DIFF",
    "METHODS",
    "POSE_RELATIONS",
    "Alignment",
    "KittiSegments",
    "NEESResult",
    "Statistics",
    "Synchronized",
    "align",
    "ape",
    "associate",
    "check_timestamps",
    "chi2_bounds",
    "interpolate_covariances",
    "interpolate_poses",
    "kitti_segment_errors",
    "nees",
    "rpe",
    "rpe_pairs",
    "statistics",
    "synchronize",
    "umeyama",
]
