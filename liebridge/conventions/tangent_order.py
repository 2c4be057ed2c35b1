"""A state's tangent order as a permutation of its blocks' concatenated tangents.

Product states (:class:`~liebridge.conventions.bundle.Bundle`) and navigation charts
(:class:`~liebridge.conventions.navstate.NavChart`) define their retraction on the
*concatenated* tangent (the blocks' tangents one after the other) and store their own order as
``perm``: entry ``k`` of the state's tangent ``d`` is entry ``perm[k]`` of the concatenated one,
``d_concatenated[perm] = d``. ``perm = None`` is the concatenated order itself.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .._validate import FloatArray

Perm = Sequence[int] | None


def perm_matrix(n: int, perm: Perm) -> FloatArray:
    """Return ``P`` (``(n, n)``) with ``d_concatenated = P d``."""
    P = np.eye(n)
    return P if perm is None else np.ascontiguousarray(P[:, list(perm)])


def to_concatenated(d: FloatArray, perm: Perm) -> FloatArray:
    """Return the concatenated tangent of ``d`` (``(..., n)``); a new array if ``perm`` is set."""
    if perm is None:
        return d
    out = np.empty(d.shape)
    out[..., list(perm)] = d
    return out


def from_concatenated(c: FloatArray, perm: Perm) -> FloatArray:
    """Return the state's tangent of a concatenated tangent ``c`` (``(..., n)``)."""
    return c if perm is None else np.asarray(c[..., list(perm)], dtype=np.float64)
