"""The optional compiled SO(3)/SE(3) kernels (``_lie_ext.c``), as the public functions call them.

:func:`run` validates and evaluates ``so3.exp/log``, ``se3.exp/log/adjoint`` on a float64 numpy
array in one C pass and returns the result, or None when the extension is not built, the input
is not a C-contiguous float64 array, or some element is not certified valid (see
``_validate.py``: the certificate can only accept valid input). On None the caller runs its
numpy kernel, the reference, which accepts the input or raises its usual error; results agree to
rounding (``tests/test_lie_compiled.py``).
"""

from __future__ import annotations

import math
import types

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from .series import (
    JINV_COEFF_SERIES,
    ONE_MINUS_COS_OVER_T2_SERIES,
    SINC_SERIES,
    SMALL_ANGLE,
    T_MINUS_SIN_OVER_T3_SERIES,
)

_lie_ext: types.ModuleType | None
try:
    from . import _lie_ext
except ImportError:  # pragma: no cover - the build skips it where no C compiler is found
    _lie_ext = None

#: Whether the compiled kernels were built (``liebridge/lie/_lie_ext.c``).
COMPILED = _lie_ext is not None

SO3_EXP, SO3_LOG, SE3_EXP, SE3_LOG, SE3_ADJOINT = range(5)
#: Per op: the core input shape and the core output shape.
_CORE: dict[int, tuple[tuple[int, ...], tuple[int, ...]]] = {
    SO3_EXP: ((3,), (3, 3)),
    SO3_LOG: ((3, 3), (3,)),
    SE3_EXP: ((6,), (4, 4)),
    SE3_LOG: ((4, 4), (6,)),
    SE3_ADJOINT: ((4, 4), (6, 6)),
}
#: The Maclaurin coefficients of series.py's sinc, (1 − cos θ)/θ², (θ − sin θ)/θ³, D(θ).
_COEF = np.ascontiguousarray(
    [SINC_SERIES, ONE_MINUS_COS_OVER_T2_SERIES, T_MINUS_SIN_OVER_T3_SERIES, JINV_COEFF_SERIES],
    dtype=np.float64,
)
#: Every rotation component at most this: the norm is at most MAX_ANGLE (``_validate.tangent``).
_MAX_COMPONENT = validate.MAX_ANGLE / math.sqrt(3.0)


def run(op: int, x: object) -> FloatArray | None:
    """Evaluate kernel ``op`` on ``x`` in C, or return None (then the numpy kernel decides)."""
    if _lie_ext is None or type(x) is not np.ndarray:
        return None
    core_in, core = _CORE[op]
    k = len(core_in)
    if x.shape[x.ndim - k :] != core_in or x.ndim < k:
        return None
    out = np.empty((*x.shape[: x.ndim - k], *core))
    r = _lie_ext.kernel(op, x, out, _COEF, SMALL_ANGLE, validate.ROTATION_TOL, _MAX_COMPONENT)
    return out if r == -1 else None


def run_any_layout(op: int, x: object) -> FloatArray | None:
    """:func:`run` on a numpy array of any memory layout (a C-contiguous copy where needed).

    For the unchecked kernels: the result then does not depend on whether the caller passed a
    batch or a slice of one (the compiled and the numpy pass agree to rounding, not bit for bit).
    """
    if type(x) is not np.ndarray:
        return None
    return run(op, np.ascontiguousarray(x))
