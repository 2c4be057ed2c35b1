"""A convention's retraction, local map and first-order maps without validation.

**No validation**: ``X``, ``Y`` must already be float64 group elements of the convention's kind
(``(..., 4, 4)`` poses or ``(..., 3, 3)`` rotations, rotation parts in SO(3)) and ``d`` a finite
increment inside the chart's domain; the public methods of
:class:`~liebridge.conventions.Convention` and the conversion functions check that, then call the
same code. Nothing here raises on bad input
or checks its output. For liebridge's own layers (the GTSAM factors evaluate thousands of residuals
per iteration after validating each measurement once, at construction).

Each function is the method of the same name: ``retract(conv, X, d) == conv.retract(X, d)``,
``local(conv, X, Y) == conv.local(X, Y)``, ``local_jacobian(conv, X, Y) ==
conv.local_jacobian(X, Y)``, ``to_canonical``/``from_canonical`` likewise, and
``tangent_map(X, src, dst) == liebridge.conventions.tangent_map(X, src, dst)`` for conventions
given as objects.
"""

from __future__ import annotations

import numpy as np

from .. import arrays
from .._validate import FloatArray
from .chart import Chart
from .convention import Convention
from .groups import is_canonical
from .tangent_maps import pair_tangent_map


def retract(conv: Chart, X: FloatArray, d: FloatArray) -> FloatArray:
    """``conv.retract(X, d)`` without validation."""
    return conv._retract(X, d)


def local(conv: Chart, X: FloatArray, Y: FloatArray) -> FloatArray:
    """``conv.local(X, Y)`` without validation."""
    return conv._local(X, Y)


def local_jacobian(conv: Chart, X: FloatArray, Y: FloatArray) -> FloatArray:
    """``conv.local_jacobian(X, Y)`` without validation: ``∂ local(X, retract(Y, δ))/∂δ`` at 0."""
    return conv._local_jacobian(X, Y)


def to_canonical(conv: Chart, X: FloatArray) -> FloatArray:
    """``conv.to_canonical(X)`` without validation: ``ξ_gtsam = M d``."""
    return conv._to_canonical(X)


def from_canonical(conv: Chart, X: FloatArray) -> FloatArray:
    """``conv.from_canonical(X)`` without validation: ``d = M ξ_gtsam``."""
    return conv._from_canonical(X)


def _canonical(c: Chart) -> bool:
    """Whether ``c``'s maps to and from the canonical tangent are ``I`` (a stored pose's)."""
    return isinstance(c, Convention) and c.stores == "pose" and is_canonical(c)


def tangent_map(X: FloatArray, src: Chart, dst: Chart) -> FloatArray:
    """``tangent_map(X, src, dst)`` without validation: ``δ_dst = M δ_src`` at ``X``."""
    if (  # SE(3)/SO(3) conventions: the closed-form pair grid
        isinstance(src, Convention)
        and isinstance(dst, Convention)
        and src._engine.rotations_3d
        and dst._engine.rotations_3d
        and not (src.is_euler or dst.is_euler)
    ):
        return pair_tangent_map(src, dst, X.shape[-1] == 3)(X)
    # the maps to and from the canonical tangent (one of them I: skipped)
    if _canonical(src):
        M = dst._from_canonical(X)
    elif _canonical(dst):
        M = src._to_canonical(X)
    else:
        M = dst._from_canonical(X) @ src._to_canonical(X)
    return M if arrays.is_foreign(M) else np.asarray(M, dtype=np.float64)


__all__ = ["from_canonical", "local", "local_jacobian", "retract", "tangent_map", "to_canonical"]
