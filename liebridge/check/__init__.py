"""Public numerical checks: users test their own Jacobians and conversions with these.

``numerical_jacobian`` differentiates through a *given* retraction and local map — a Jacobian is
only meaningful with respect to the chart it claims, so the check must use that chart (finite
differences through raw matrix addition test nothing; see docs/common-formula-errors.md).

``numerical_jacobian`` and ``assert_jacobian`` take torch tensors and JAX arrays (the Jacobian
is returned in the caller's array type); so do the Monte Carlo references, which compute on the
device with numpy's random numbers (drawn from ``rng`` on the host and moved there): for the
same seed they equal the reference of the numpy copy, and they are differentiable.
"""

from .jacobian import assert_jacobian, numerical_jacobian
from .montecarlo import monte_carlo_covariance
from .uncertain_mc import (
    monte_carlo_act,
    monte_carlo_average,
    monte_carlo_compose,
    monte_carlo_fuse,
    monte_carlo_inverse,
    monte_carlo_relative,
    monte_carlo_transform,
)

__all__ = [
    "assert_jacobian",
    "monte_carlo_act",
    "monte_carlo_average",
    "monte_carlo_compose",
    "monte_carlo_covariance",
    "monte_carlo_fuse",
    "monte_carlo_inverse",
    "monte_carlo_relative",
    "monte_carlo_transform",
    "numerical_jacobian",
]
