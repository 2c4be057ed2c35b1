"""Measure the convention a black-box retraction implements.

``detect_convention(retract)`` calls ``retract(X, d)`` at a generic pose (or rotation) for a set of
increments and compares the results with every convention of the model (2 sides × 2 orders ×
(SE(3) exp + 2 decoupled charts × 4 rotation coordinates) = 36 for poses, 8 for rotations, plus
the Euler-angle charts (``euler_zyx``, ``euler_rpy``; side-free): 8 for poses, 2 for rotations,
plus, for poses, the group exponential applied to the stored inverse (``stores="inverse"``,
2 sides × 2 orders: DPVO's and DROID-SLAM's world→camera poses in lietorch)).
Distinct conventions give distinct retractions at these probes, including the pairs that agree to
first order (``half_exp`` vs ``quat_vec``, ``se3`` vs ``so3xr3_body``), because the increments
are finite (‖d‖ ≈ 0.5). Nothing about the library is assumed: GTSAM's own build is checked this
way by the GTSAM glue.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import Any

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..lie import GROUPS, Group
from ..lie import group as lie_group
from ..lie.numdiff import central_differences
from .convention import ORDERS, SIDES, Convention
from .engine import engine_for
from .registry import get, matching_presets
from .rotation_coords import EULER_COORDS, ROTATION_COORDS

#: Increment coordinates (the Euler angles are absolute and SO(3)/SE(3) only).
_INCREMENT_COORDS = tuple(r for r in ROTATION_COORDS if r not in EULER_COORDS)


class ConventionNotDetected(ValueError):
    """The retraction matches no convention of the model; the message says what was measured."""


def _candidates(g: Group) -> list[Convention]:
    """Every side × order × chart × rotation coordinates of ``g`` that is a distinct convention.

    Read from the record: a rotation group has one order and perturbs its rotation only (its
    split chart); a planar or rotation-free group has only ``exp`` coordinates; the coupled chart
    needs ``exp``; Euler angles (where the group's engine has them) ignore the side.
    """
    euler = engine_for(g).euler
    if g.rot_dim == 3:
        rots: tuple[str, ...] = ROTATION_COORDS if euler else _INCREMENT_COORDS
    else:
        rots = ("exp",)
    rotation_group = not g.vecs and g.scale is None
    orders = ("rot_first",) if rotation_group or g.rot is None else ORDERS
    # a rotation group perturbs its rotation only: its first split chart, if it has one
    charts = (g.charts[min(1, len(g.charts) - 1)],) if rotation_group else g.charts
    sides = SIDES if g.rot is not None else ("right",)
    out = [
        Convention("detected:" + "/".join(c), *c, "wxyz", group=g.name)  # type: ignore[arg-type]
        for c in itertools.product(sides, orders, charts, rots)
        if (c[2] != g.coupled_chart or c[3] == "exp")
        and (c[0] == "right" or c[3] not in EULER_COORDS)
    ]
    if not rotation_group:  # a library that updates the stored inverse (world→camera poses)
        out += [
            Convention(
                f"detected:{side}/{order}/{g.coupled_chart}/exp/inverse",
                side,  # type: ignore[arg-type]
                order,  # type: ignore[arg-type]
                g.coupled_chart,
                "exp",
                "wxyz",
                group=g.name,
                stores="inverse",
            )
            for side, order in itertools.product(SIDES, orders)
        ]
    return out


def _as_matrix(y: Any, what: str = "retract(X, d)", g: Group | None = None) -> FloatArray:
    """Validate what a retraction returned (an array, or an object with ``.matrix()``).

    For a group with a scale (Sim(3)), an object's ``.matrix()`` of GTSAM's form
    ``[R t; 0 1/s]`` is normalised to ``[sR t'; 0 1]`` (divided by its corner entry); an array is
    taken as it is.
    """
    obj = hasattr(y, "matrix")
    if obj:
        y = y.matrix()
    arr = validate.as_float_array(y, what)
    validate.check_finite(arr, what)
    if obj and g is not None and g.scale is not None and arr.shape == (g.matrix, g.matrix):
        if arr[-1, -1] > 0:
            arr = arr / arr[-1, -1]
    return arr


def detect_convention(
    retract: Callable[[FloatArray, FloatArray], Any],
    *,
    group: str | Group = "se3",
    prefer: str | None = None,
    tol: float = 1e-7,
    rng: np.random.Generator | None = None,
) -> Convention:
    """Return the convention implemented by ``retract(X, d)``.

    Parameters
    ----------
    retract : callable
        ``retract(X, d)`` taking a ``(4, 4)`` pose (``(3, 3)`` rotation for ``group="so3"``) and a
        ``(6,)`` (``(3,)``) increment, returning a matrix (or an object with ``.matrix()``).
    group : str or liebridge.lie.Group
        What ``X`` is, a registered group (its name or record): ``"se3"`` a ``(4, 4)`` pose,
        ``"so3"`` a ``(3, 3)`` rotation, ``"so2"`` a ``(2, 2)`` rotation, ``"se2"`` a ``(3, 3)``
        SE(2) pose, ``"sim3"`` a ``(4, 4)`` similarity ``[sR t; 0 1]``, ``"se23"`` a ``(5, 5)``
        extended pose, or a user's group; the increment has the group's dimension. ``X`` is the
        record's probe element. The candidates are every side × order × chart × rotation
        coordinates of the group.
    prefer : str, optional
        Among presets with the same retraction (Sophus, manif, Pinocchio, jaxlie and Theseus are
        all right/(v, ω)/SE(3) exp; PyPose and lietorch left/(v, ω)), return this one if it
        matches; else the first in registry order. :func:`matching_presets` lists them all.
    tol : float
        Accepted max-abs mismatch of the probed matrices.
    rng : numpy.random.Generator, optional
        Probe generator (default: seeded, so detection is deterministic).

    Returns
    -------
    Convention
        A preset when one has the measured fields, else a new ``Convention`` named
        ``"detected"``. For ``group="so3"`` the order and chart fields are not measurable and are
        reported as those of the matching preset (or ``rot_first``/``so3xr3_body``).

    Raises
    ------
    ConventionNotDetected
        When nothing in the model matches; the message gives the measured first-order map and the
        closest candidate.
    """
    if not callable(retract):
        raise TypeError(f"retract: expected a callable retract(X, d), got {type(retract).__name__}")
    rng = rng or np.random.default_rng(20261122)
    if isinstance(group, Group):
        g = group
    else:
        g = lie_group(validate.option(group, "group", tuple(GROUPS)))
    n = g.dim
    if g.probe is None:
        raise ValueError(f"group: {g.name!r} has no probe element to detect a convention at")
    X = np.array(g.probe, dtype=np.float64)
    D = rng.uniform(-0.3, 0.3, size=(8, n))
    results = [
        _as_matrix(retract(X.copy(), d.copy()), f"retract(X, d) at probe {k}", g)
        for k, d in enumerate(D)
    ]
    for k, y in enumerate(results):
        if y.shape != X.shape:
            raise ConventionNotDetected(
                f"retract(X, d) at probe {k} returned shape {y.shape}, expected {X.shape}"
            )
    Y = np.stack(results)
    Y0 = _as_matrix(retract(X.copy(), np.zeros(n)), "retract(X, 0)", g)
    if Y0.shape != X.shape:
        raise ConventionNotDetected(f"retract(X, 0) returned shape {Y0.shape}, expected {X.shape}")
    if np.abs(Y0 - X).max() > tol:
        raise ConventionNotDetected(
            f"retract(X, 0) != X (max |diff| {np.abs(Y0 - X).max():.3g}): not a retraction"
        )
    scored: list[tuple[float, Convention]] = []
    for cand in _candidates(g):
        try:
            scored.append((float(np.abs(cand._retract(X, D) - Y).max()), cand))
        except ValueError:
            continue
    err, found = min(scored, key=lambda t: t[0], default=(np.inf, None))
    limit = tol * max(1.0, float(np.abs(Y).max()))
    if found is None or err > limit:
        canon = Convention(  # the group's canonical tangent: right, its order, its exp
            "canonical",
            "right",
            g.canonical_order,
            g.coupled_chart,
            "exp",
            "wxyz",
            group=g.name,
        )
        M = central_differences(
            lambda Z: Z,
            X,
            retract=lambda A, d: _as_matrix(retract(A, d), g=g),
            local=canon._local,
            dim=n,
        )
        raise ConventionNotDetected(
            "no convention in the model reproduces this retraction. Measured first-order map "
            f"d(GTSAM local)/dd at the probe pose:\n{np.array2string(M, precision=4)}\n"
            f"closest: {found.describe() if found else 'none'} with max mismatch {err:.3g}"
        )
    # Every candidate within the tolerance reproduces the retraction: in a group where two
    # differ by rounding only (SO(2)'s increments commute: left ≡ right), the smallest mismatch
    # is decided by the BLAS kernel's rounding. Take the first, in the model's order, that a
    # registered preset names; else the closest.
    rotation_group = not g.vecs and g.scale is None and g.rot_dim == 3
    cand, matches = found, []
    for e, c in scored:
        if e > limit:
            continue
        named = matches_so3(c) if rotation_group else matching_presets(c)
        if named:
            cand, matches = c, named
            break
    if prefer is not None:
        p = get(prefer)
        if p in matches:
            return p
    if matches:
        return matches[0]
    return Convention(
        "detected",
        cand.side,
        cand.order,
        cand.chart,
        cand.rotation,
        "wxyz",
        source="measured by liebridge.detect_convention",
        group=cand.group,
        stores=cand.stores,
    )


def matches_so3(conv: Convention) -> list[Convention]:
    """Presets whose rotation retraction (side and rotation coordinates) equals ``conv``'s."""
    from .presets import PRESETS

    return [c for c in PRESETS if (c.side, c.rotation) == (conv.side, conv.rotation)]
