"""A registration result as a g2o ``EDGE_SE3:QUAT`` line, the information in g2o's edge chart."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _validate as validate
from ..conventions import convert_information
from ..io import poses as layouts
from ..uncertain import UncertainPose

__all__ = ["g2o_edge"]

_TRIU = np.triu_indices(6)


def g2o_edge(id_target: Any, id_source: Any, result: UncertainPose) -> str:
    """Return the ``EDGE_SE3:QUAT id_target id_source`` line of a registration result.

    g2o's ``EdgeSE3`` between vertices ``i = target``, ``j = source`` (poses ``T_world_i``) has
    the error ``toVectorMQT(Z⁻¹·Ti⁻¹·Tj)`` over ``(x, y, z, qx, qy, qz)`` (preset ``g2o``), so
    ``Z = T_target_source`` and the information is ``result``'s mapped into that chart
    (``Λ_g2o = M⁻ᵀΛM⁻¹``, ``M = tangent_map(Z, result.convention, "g2o")``: the translation block
    first, the rotation block over quaternion vector parts, ×4 that over angles).

    Parameters
    ----------
    id_target, id_source : int
        Vertex ids (non-negative integers).
    result : UncertainPose
        ``T_target_source`` with its covariance (e.g. from :func:`information`), unbatched.

    Returns
    -------
    str
        One line (no newline): pose as ``x y z qx qy qz qw``, then the 21 upper-triangular
        entries of the information, row by row, at full precision.
    """
    if not isinstance(result, UncertainPose) or result.is_rotation or result.batch_shape:
        raise TypeError("result: expected one UncertainPose of a pose (unbatched)")
    ids = [
        validate.key(k, name) for k, name in ((id_target, "id_target"), (id_source, "id_source"))
    ]
    info = convert_information(np.linalg.inv(result.cov), result.T, result.convention, "g2o")
    info = 0.5 * (info + info.T)
    x = layouts.from_matrix(result.T, layout="xyz_qxyzw")
    nums = [*x.tolist(), *info[_TRIU].tolist()]
    return f"EDGE_SE3:QUAT {ids[0]} {ids[1]} " + " ".join(repr(float(c)) for c in nums)
