"""Lookup of conventions by name, with suggestions for a misspelt one."""

from __future__ import annotations

import difflib

from .convention import Convention
from .presets import PRESETS

_REGISTRY: dict[str, Convention] = {c.name: c for c in PRESETS}

ConventionLike = Convention | str


def names() -> list[str]:
    """Registry names of all presets, in registry order."""
    return list(_REGISTRY)


def get(name: ConventionLike) -> Convention:
    """Return the preset called ``name`` (a :class:`Convention` is returned unchanged).

    Raises
    ------
    ValueError
        For an unknown name, with the closest registered names.
    TypeError
        For anything that is neither a string nor a Convention.
    """
    if isinstance(name, Convention):
        return name
    if type(name) is str and name in _REGISTRY:  # the common case: an exact registry name
        return _REGISTRY[name]
    if not isinstance(name, str):
        raise TypeError(f"convention: expected a Convention or a name, got {type(name).__name__}")
    key = name.strip().lower().replace("-", "_")
    if key in _REGISTRY:
        return _REGISTRY[key]
    close = difflib.get_close_matches(key, _REGISTRY, n=3, cutoff=0.5)
    hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
    raise ValueError(f"convention: unknown name {name!r}{hint} (known: {', '.join(_REGISTRY)})")


def matching_presets(conv: Convention) -> list[Convention]:
    """Presets whose ``(side, order, chart, rotation)`` equal ``conv``'s (retraction-equivalent)."""
    return [c for c in PRESETS if c.fields == conv.fields]
