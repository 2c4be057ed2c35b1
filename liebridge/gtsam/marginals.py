"""GTSAM marginal covariances expressed in any convention.

``gtsam.Marginals.marginalCovariance(key)`` is the covariance of ``δ`` in ``X̂·Exp(δ)``,
``δ = (ω, v)`` (GTSAM's tangent at the estimate; verified by Monte Carlo in
``tests/test_presets_libs.py``). :func:`marginals` converts it at each estimate ``X̂`` with
:func:`liebridge.convert_covariance` — e.g. to Sophus ``(v, ω)``: a permutation; to Barfoot
(left, ``(v, ω)``): ``P·Ad_X̂``; to ROS: ``[[0, R], [R, 0]]``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Literal

import gtsam
import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions import ConventionLike, get
from ..conventions.convert import convert_covariance
from .build import gtsam_convention
from .glue import from_values

__all__ = ["marginals"]


def marginals(
    graph: Any,
    values: Any,
    keys: Sequence[int],
    convention: ConventionLike = "gtsam",
    *,
    method: Literal["linear", "unscented"] = "linear",
    marginals_object: Any = None,
) -> FloatArray:
    """Marginal covariances of ``Pose3`` variables ``keys``, in ``convention``'s tangent.

    Parameters
    ----------
    graph : gtsam.NonlinearFactorGraph
    values : gtsam.Values
        The estimate (usually the optimum) the marginals are taken at.
    keys : sequence of int
        ``Pose3`` keys.
    convention : Convention or str
        Target convention (default: GTSAM's own, i.e. no conversion).
    method : {"linear", "unscented"}
        See :func:`liebridge.convert_covariance`.
    marginals_object : gtsam.Marginals, optional
        Reuse an existing ``gtsam.Marginals`` (it factorizes the whole graph once).

    Returns
    -------
    ndarray, shape (N, 6, 6)
    """
    keys = [validate.key(k, f"keys[{n}]") for n, k in enumerate(keys)]
    graph_keys = graph.keys()  # held: iterating a temporary KeySet reads freed memory
    used = {int(k) for k in graph_keys}
    for n, k in enumerate(keys):
        if not values.exists(k):
            raise ValueError(f"keys[{n}]: key {k} is not in values")
        if k not in used:
            raise ValueError(
                f"keys[{n}]: key {k} is used by no factor of graph: it has no marginal"
            )
    m = marginals_object if marginals_object is not None else gtsam.Marginals(graph, values)
    cov_g = np.stack([np.asarray(m.marginalCovariance(k), dtype=np.float64) for k in keys])
    cov_g = 0.5 * (cov_g + np.swapaxes(cov_g, -1, -2))
    T = from_values(values, keys)
    return convert_covariance(cov_g, T, gtsam_convention(), get(convention), method=method)
