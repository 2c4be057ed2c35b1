"""GTSAM marginal covariances expressed in any convention.

``gtsam.Marginals.marginalCovariance(key)`` is the covariance of ``δ`` in ``X̂·Exp(δ)``,
``δ = (ω, v)`` (GTSAM's tangent at the estimate; verified by Monte Carlo in
``tests/test_presets_libs.py``). :func:`marginals` converts it at each estimate ``X̂`` with
:func:`liebridge.convert_covariance` — e.g. to Sophus ``(v, ω)``: a permutation; to Barfoot
(left, ``(v, ω)``): ``P·Ad_X̂``; to ROS: ``[[0, R], [R, 0]]``.

The other groups: the convention's group says which GTSAM class the keys hold, and GTSAM's
marginal is over that class's own tangent (:func:`liebridge.gtsam.build.gtsam_convention_of`):
``Pose2`` ``(vx, vy, ω)`` of ``X̂·Exp(δ)`` (preset ``gtsam_pose2``), ``Similarity3``
``(ω, u, λ)`` of ``X̂·Exp(δ)`` (``gtsam_similarity3``), ``NavState`` ``(δθ, δp, δv)`` of its
split body retraction (``gtsam_navstate``). Checked by Monte Carlo of GTSAM's own ``retract`` in
``tests/test_pose_factors.py``.
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
from .build import gtsam_convention_of
from .glue import from_values

__all__ = ["gtsam_marginals", "marginals"]


def indeterminate_message(exc: BaseException) -> str | None:
    """One line for GTSAM's multi-line "Indeterminate linear system" error (None if it is not)."""
    text = " ".join(str(exc).split())
    if "ndetermina" not in text:  # GTSAM 4.2 spells it "Indeterminant", 4.3 "Indeterminate"
        return None
    near = ""
    marker = "near variable "
    if marker in text:
        word = text.split(marker, 1)[1].split(" ", 1)[0].rstrip(".")
        near = f" near variable {word}" if word else ""
    return (
        f"the linear system is not fully determined (GTSAM stopped{near}): some direction of "
        "some variable is constrained by no factor. A pose graph of relative measurements alone "
        "has a free gauge: add a prior (G2OGraph.to_gtsam() adds one unless prior=None; "
        "lb.gtsam.prior(key, pose, cov, convention) or gtsam.PriorFactorPose3 by hand)"
    )


def gtsam_marginals(graph: Any, values: Any) -> Any:
    """``gtsam.Marginals(graph, values)``, with a one-line ``ValueError`` on a gauge-free graph.

    GTSAM raises a multi-line ``RuntimeError`` ("Indeterminate linear system") when a variable
    is not fully constrained, most often because no prior fixes the gauge; this says so in one
    line and names the remedy.
    """
    try:
        return gtsam.Marginals(graph, values)
    except RuntimeError as exc:
        msg = indeterminate_message(exc)
        if msg is None:
            raise
        raise ValueError(f"graph: {msg}") from None


def marginals(
    graph: Any,
    values: Any,
    keys: Sequence[int],
    convention: ConventionLike = "gtsam",
    *,
    method: Literal["linear", "unscented"] = "linear",
    marginals_object: Any = None,
) -> FloatArray:
    """Marginal covariances of the variables ``keys``, in ``convention``'s tangent.

    The variables are of the convention's group: ``Pose3`` for an SE(3) convention (the
    default), ``Pose2`` for an SE(2) one (``"g2o_se2"``, ``"ros_pose2"``, ...), ``Similarity3``
    for Sim(3), ``NavState`` for SE₂(3).

    Parameters
    ----------
    graph : gtsam.NonlinearFactorGraph
    values : gtsam.Values
        The estimate (usually the optimum) the marginals are taken at.
    keys : sequence of int
        Keys of variables of the convention's group.
    convention : Convention or str
        Target convention (default: GTSAM's own, i.e. no conversion).
    method : {"linear", "unscented"}
        See :func:`liebridge.convert_covariance`.
    marginals_object : gtsam.Marginals, optional
        Reuse an existing ``gtsam.Marginals`` (it factorizes the whole graph once).

    Returns
    -------
    ndarray, shape (N, n, n)
        n is the convention's tangent size (6 for SE(3), 3 for SE(2), 6 for ``ros_pose2``,
        7 for Sim(3), 9 for SE₂(3)).

    Raises
    ------
    ValueError
        A key not in ``values`` or used by no factor; a graph whose linear system is not fully
        determined (typically: no prior fixes the gauge), in one line instead of GTSAM's
        multi-line "Indeterminate linear system".
    """
    conv = get(convention)
    hub = gtsam_convention_of(conv.group)
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
    m = marginals_object if marginals_object is not None else gtsam_marginals(graph, values)
    cov_g = np.stack([np.asarray(m.marginalCovariance(k), dtype=np.float64) for k in keys])
    cov_g = 0.5 * (cov_g + np.swapaxes(cov_g, -1, -2))
    T = from_values(values, keys, group=conv.group)
    return convert_covariance(cov_g, T, hub, conv, method=method)
