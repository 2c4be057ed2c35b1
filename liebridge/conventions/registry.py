"""Lookup of conventions by name, with suggestions for a misspelt one."""

from __future__ import annotations

import difflib

from .convention import Convention
from .presets import ALL_PRESETS
from .registration_presets import REGISTRATION_PRESETS
from .state_presets import STATE_PRESETS

_REGISTRY: dict[str, Convention] = {
    c.name: c for c in (*ALL_PRESETS, *STATE_PRESETS, *REGISTRATION_PRESETS)
}

ConventionLike = Convention | str


def names(group: str | None = None) -> list[str]:
    """Registry names of all presets (of ``group`` only, if given), in registry order."""
    return [n for n, c in _REGISTRY.items() if group is None or c.group == group]


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
    # near misses first (a typo), then looser ones
    close = difflib.get_close_matches(key, _REGISTRY, n=3, cutoff=0.75)
    close = close or difflib.get_close_matches(key, _REGISTRY, n=3, cutoff=0.5)
    hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
    raise ValueError(f"convention: unknown name {name!r}{hint} (known: {', '.join(_REGISTRY)})")


def matching_presets(conv: Convention) -> list[Convention]:
    """Presets of ``conv``'s group with its ``(side, order, chart, rotation)`` and embedding.

    They are retraction-equivalent to ``conv``.
    """
    return [
        c
        for c in ALL_PRESETS
        if c.group == conv.group and c.fields == conv.fields and c.embed == conv.embed
    ]
