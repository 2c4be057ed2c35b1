"""Public numerical checks: users test their own Jacobians and conversions with these.

``numerical_jacobian`` differentiates through a *given* retraction and local map — a Jacobian is
only meaningful with respect to the chart it claims, so the check must use that chart (finite
differences through raw matrix addition test nothing; see docs/common-formula-errors.md).
"""

from .jacobian import assert_jacobian, numerical_jacobian
from .montecarlo import monte_carlo_covariance

__all__ = ["assert_jacobian", "monte_carlo_covariance", "numerical_jacobian"]
