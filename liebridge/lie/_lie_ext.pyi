"""Type stub of the optional compiled SO(3)/SE(3) kernels (``_lie_ext.c``)."""

from typing import Any

def kernel(
    op: int, x: Any, out: Any, coef: Any, small_angle: float, tol: float, max_component: float, /
) -> int:
    """Validate and evaluate kernel ``op`` on ``x`` into ``out`` (C-contiguous float64).

    Returns -1 when done, -2 when not handled, k ≥ 0 for the first element (flat index) not
    certified (see ``_lie_ext.c``).
    """
