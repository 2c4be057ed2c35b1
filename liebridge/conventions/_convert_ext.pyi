"""Type stub of the optional compiled conversion pass (``_convert_ext.c``)."""

from typing import Any

def transform(
    mode: int, plan: tuple[Any, Any, Any, Any, float], X: Any, A: Any, out: Any, /
) -> int:
    """Validate and convert a batch into ``out`` (C-contiguous float64 buffers).

    Returns -1 when done, -2 when not handled, k ≥ 0 for the first element (flat index) not
    certified (see ``_convert_ext.c``).
    """
