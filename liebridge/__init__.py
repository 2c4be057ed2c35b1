"""liebridge: explicit Lie-group conventions and exact translation between them.

The canonical form is GTSAM's: poses ``(..., 4, 4)``, rotation-first twists ``ξ = (ω, v)``,
right perturbation ``X·Exp(ξ)``, true SE(3) exponential.
"""

from . import check, lie

__version__ = "0.1.0"

__all__ = ["__version__", "check", "lie"]
