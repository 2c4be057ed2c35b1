"""The convention doctor: diagnose a user's own Jacobian, residual, covariance and trajectory.

liebridge translates between named conventions; the bug a user has is usually in their own code,
written against no preset. Each function here runs one diagnostic of the failure table in
``docs/doctor.md`` and returns a :class:`Diagnosis` (``verdict``, ``explanation``, ``evidence``):

- :func:`diagnose_jacobian`: which convention, or which known mistake, an analytic Jacobian
  matches (finite differences through every candidate retraction; 0°, 90°, 170°, 179°);
- :func:`diagnose_residual`: a one-edge graph with a known 1 m and 10° error: the first
  Gauss–Newton step, the residual at the measurement, invariance under frame changes;
- :func:`diagnose_covariance`: a covariance transformation against Monte Carlo through
  conventions;
- :func:`scan_trajectory`: branch-cut crossings, quaternion sign flips, non-orthonormal
  rotations, time gaps and duplicates, and the quaternion storage order;
- :func:`diagnose_interpolation`: ``T(0) = T_0``, ``T(1) = T_1``, and which curve it follows.
"""

from .covariance import diagnose_covariance
from .interpolation import diagnose_interpolation
from .jacobian import diagnose_jacobian
from .residual import diagnose_residual
from .result import Diagnosis
from .trajectory import scan_trajectory

__all__ = [
    "Diagnosis",
    "diagnose_covariance",
    "diagnose_interpolation",
    "diagnose_jacobian",
    "diagnose_residual",
    "scan_trajectory",
]
