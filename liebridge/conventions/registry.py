"""Lookup of conventions by name, with suggestions for a misspelt one."""

from __future__ import annotations

import difflib
from typing import Any

from .._validate import FloatArray
from .chart import Chart
from .convention import Convention
from .engine import engine_for
from .presets import ALIASES, ALL_PRESETS
from .registration_presets import REGISTRATION_PRESETS
from .state_presets import STATE_PRESETS

_REGISTRY: dict[str, Chart] = {
    c.name: c for c in (*ALL_PRESETS, *STATE_PRESETS, *REGISTRATION_PRESETS)
}
#: Conventions registered by the user (:func:`register`), in registration order.
_USER: list[Convention] = []

ConventionLike = Chart | str


def names(group: str | None = None) -> list[str]:
    """Registry names of all presets (of ``group`` only, if given), in registry order."""
    return [n for n, c in _REGISTRY.items() if group is None or c.group == group]


def get(name: ConventionLike) -> Chart:
    """Return the preset called ``name`` (a :class:`Convention` is returned unchanged).

    Raises
    ------
    ValueError
        For an unknown name, with the closest registered names.
    TypeError
        For anything that is neither a string nor a Convention.
    """
    if isinstance(name, Chart):
        return name
    if type(name) is str and name in _REGISTRY:  # the common case: an exact registry name
        return _REGISTRY[name]
    if not isinstance(name, str):
        raise TypeError(f"convention: expected a Convention or a name, got {type(name).__name__}")
    key = name.strip().lower().replace("-", "_")
    if key in _REGISTRY:
        return _REGISTRY[key]
    if key in ALIASES:  # a second name of a preset (droid_slam → dpvo)
        return _REGISTRY[ALIASES[key]]
    # near misses first (a typo), then looser ones
    known = [*_REGISTRY, *ALIASES]
    close = difflib.get_close_matches(key, known, n=3, cutoff=0.75)
    close = close or difflib.get_close_matches(key, known, n=3, cutoff=0.5)
    hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
    raise ValueError(f"convention: unknown name {name!r}{hint} (known: {', '.join(_REGISTRY)})")


def single_group(chart: Chart, what: str = "convention") -> Convention:
    """Return ``chart`` if it is a convention of one group, else raise ``ValueError``.

    For what needs one group's element and tangent (a factor, a message, a frame): a
    :class:`~liebridge.conventions.Bundle` or :class:`~liebridge.conventions.NavChart` is a
    whole-state chart.
    """
    if not isinstance(chart, Convention):
        raise ValueError(
            f"{what}: {chart.name!r} is a whole-state chart ({type(chart).__name__}); this needs "
            "a convention of one group ('liebridge conventions' lists them)"
        )
    return chart


def pose_convention(chart: Any, name: str, X: FloatArray | None = None) -> Convention:
    """Return ``chart`` if it is an SE(3)/SO(3) convention matching ``X``, else raise.

    An operation on poses that takes a convention must refuse a convention of another group
    (``"gtsam_similarity3"``, ``"gtsam_pose2"``, a bundle) before it reads the covariance with
    the wrong tangent size, and an SO(3) convention given a pose. Read from the group record:
    the conventions whose engine acts on poses and 3-D rotations.
    """
    label = getattr(chart, "name", repr(chart))
    if not isinstance(chart, Convention) or not engine_for(chart.group).rotations_3d:
        group = getattr(chart, "group", None)
        raise ValueError(
            f"{name}: {label!r} is a convention of {group}, but this operation takes poses "
            "(4×4) or rotations (3×3): use an SE(3) convention such as 'gtsam' or 'ros'"
        )
    if not chart.record.cols and X is not None and X.shape[-2:] != (3, 3):
        raise ValueError(
            f"{name}: {label!r} is an SO(3) convention, but the element has shape "
            f"{X.shape[-2:]}, not a rotation (3, 3)"
        )
    return chart


def register(convention: Convention, *, replace: bool = False) -> Convention:
    """Register ``convention`` under its name: ``get``, ``names`` and detection then know it.

    Its group must be registered (:func:`liebridge.lie.register`). A name already taken raises
    ``ValueError`` unless ``replace=True`` (a shipped preset cannot be replaced).

    Returns
    -------
    Convention
        ``convention`` itself.
    """
    if not isinstance(convention, Convention):
        raise TypeError(f"register: expected a Convention, got {type(convention).__name__}")
    old = _REGISTRY.get(convention.name)
    if old is not None and old is not convention:
        if not replace or old not in _USER:
            raise ValueError(f"register: a convention named {convention.name!r} already exists")
        _USER.remove(old)
    _REGISTRY[convention.name] = convention
    if convention not in _USER:
        _USER.append(convention)
    return convention


def matching_presets(conv: Convention) -> list[Convention]:
    """Presets (then registered conventions) of ``conv``'s group with its fields and embedding.

    Same ``(side, order, chart, rotation)``: they are retraction-equivalent to ``conv``.
    """
    return [
        c
        for c in (*ALL_PRESETS, *_USER)
        if c.group == conv.group and c.fields == conv.fields and c.embed == conv.embed
    ]
