"""Measure the convention a black-box retraction implements.

``detect_convention(retract)`` calls ``retract(X, d)`` at a generic pose (or rotation) for a set of
increments and compares the results with every convention of the model (2 sides × 2 orders ×
(SE(3) exp + 2 decoupled charts × 4 rotation coordinates) = 36 for poses, 8 for rotations, plus
the Euler-angle charts (``euler_zyx``, ``euler_rpy``; side-free): 8 for poses, 2 for rotations).
Distinct conventions give distinct retractions at these probes, including the pairs that agree to
first order (``half_exp`` vs ``quat_vec``, ``se3`` vs ``so3xr3_body``), because the increments
are finite (‖d‖ ≈ 0.5). Nothing about the library is assumed: GTSAM's own build is checked this
way by the GTSAM glue.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import Any, Literal

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..lie import unchecked as U
from ..lie.numdiff import numerical_jacobian
from . import groups as G
from .convention import CANONICAL, CHARTS, GROUP_CHARTS, GROUP_DIMS, ORDERS, SIDES, Convention
from .registry import get, matching_presets
from .rotation_coords import EULER_COORDS, ROTATION_COORDS

#: Increment coordinates (the Euler angles are absolute and SO(3)/SE(3) only).
_INCREMENT_COORDS = tuple(r for r in ROTATION_COORDS if r not in EULER_COORDS)


class ConventionNotDetected(ValueError):
    """The retraction matches no convention of the model; the message says what was measured."""


#: Probe tangent (canonical order) of each other group: a generic element ``Exp(ξ)``.
_PROBES: dict[str, list[float]] = {
    "so2": [0.9],
    "se2": [1.5, -2.0, 0.8],
    "sim3": [0.4, -0.7, 0.5, 1.5, -2.0, 0.8, 0.3],
    "se23": [0.4, -0.7, 0.5, 1.5, -2.0, 0.8, -0.6, 1.1, 0.7],
}


def _candidates(group: str) -> list[Convention]:
    if group in G.GROUPS:
        rots = ("exp",) if group in ("so2", "se2") else _INCREMENT_COORDS
        charts = GROUP_CHARTS[group]
        return [
            Convention(
                "detected:" + "/".join(c),
                c[0],  # type: ignore[arg-type]
                c[1],  # type: ignore[arg-type]
                c[2],  # type: ignore[arg-type]
                c[3],
                "wxyz",
                group=group,
            )
            for c in itertools.product(SIDES, ORDERS, charts, rots)
            if c[2] != group or c[3] == "exp"
        ]
    if group == "so3":  # only side and rotation coordinates act on a rotation
        combos = [
            (s, "rot_first", "so3xr3_body", r)
            for s in SIDES
            for r in ROTATION_COORDS
            if s == "right" or r not in EULER_COORDS  # Euler angles ignore the side
        ]
    else:
        combos = [
            c
            for c in itertools.product(SIDES, ORDERS, CHARTS, ROTATION_COORDS)
            if (c[2] != "se3" or c[3] == "exp") and (c[0] == "right" or c[3] not in EULER_COORDS)
        ]
    return [
        Convention("detected:" + "/".join(c), c[0], c[1], c[2], c[3], "wxyz")  # type: ignore[arg-type]
        for c in combos
    ]


def _as_matrix(y: Any, what: str = "retract(X, d)", group: str = "se3") -> FloatArray:
    """Validate what a retraction returned (an array, or an object with ``.matrix()``).

    For Sim(3), an object's ``.matrix()`` of GTSAM's form ``[R t; 0 1/s]`` is normalised to
    ``[sR t'; 0 1]`` (divided by its ``[3, 3]`` entry); an array is taken as it is.
    """
    obj = hasattr(y, "matrix")
    if obj:
        y = y.matrix()
    arr = validate.as_float_array(y, what)
    validate.check_finite(arr, what)
    if obj and group == "sim3" and arr.shape == (4, 4) and arr[3, 3] > 0:
        arr = arr / arr[3, 3]
    return arr


def detect_convention(
    retract: Callable[[FloatArray, FloatArray], Any],
    *,
    group: Literal["se3", "so3", "so2", "se2", "sim3", "se23"] = "se3",
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
    group : {"se3", "so3", "so2", "se2", "sim3", "se23"}
        What ``X`` is: a ``(4, 4)`` pose, ``(3, 3)`` rotation, ``(2, 2)`` rotation, ``(3, 3)``
        SE(2) pose, ``(4, 4)`` similarity ``[sR t; 0 1]`` or ``(5, 5)`` extended pose; the
        increment has the group's dimension (1, 3, 6, 3, 7, 9). The candidates are every
        side × order × chart × rotation coordinates of the group.
    prefer : str, optional
        Among presets with the same retraction (Sophus, manif, Pinocchio, jaxlie and Theseus are
        all right/(v, ω)/SE(3) exp), return this one if it matches; else the first in registry
        order. :func:`matching_presets` lists them all.
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
    group = validate.option(group, "group", tuple(GROUP_DIMS))  # type: ignore[assignment]
    n = GROUP_DIMS[group][0]
    if group in G.GROUPS:
        X = G.GROUPS[group].exp(np.array(_PROBES[group]))
    else:
        X = U.se3_exp(np.array([0.4, -0.7, 0.5, 1.5, -2.0, 0.8]))
    if group == "so3":
        X = X[:3, :3].copy()
    D = rng.uniform(-0.3, 0.3, size=(8, n))
    results = [
        _as_matrix(retract(X.copy(), d.copy()), f"retract(X, d) at probe {k}", group)
        for k, d in enumerate(D)
    ]
    for k, y in enumerate(results):
        if y.shape != X.shape:
            raise ConventionNotDetected(
                f"retract(X, d) at probe {k} returned shape {y.shape}, expected {X.shape}"
            )
    Y = np.stack(results)
    Y0 = _as_matrix(retract(X.copy(), np.zeros(n)), "retract(X, 0)", group)
    if Y0.shape != X.shape:
        raise ConventionNotDetected(f"retract(X, 0) returned shape {Y0.shape}, expected {X.shape}")
    if np.abs(Y0 - X).max() > tol:
        raise ConventionNotDetected(
            f"retract(X, 0) != X (max |diff| {np.abs(Y0 - X).max():.3g}): not a retraction"
        )
    best: tuple[float, Convention | None] = (np.inf, None)
    for cand in _candidates(group):
        try:
            err = float(np.abs(cand._retract(X, D) - Y).max())
        except ValueError:
            continue
        if err < best[0]:
            best = (err, cand)
    err, found = best
    if found is None or err > tol * max(1.0, float(np.abs(Y).max())):
        canon = CANONICAL
        if group in G.GROUPS:  # the group's canonical tangent: right, GTSAM's order, its exp
            order = "trans_first" if group == "se2" else "rot_first"
            canon = Convention("canonical", "right", order, group, "exp", "wxyz", group=group)  # type: ignore[arg-type]
        M = numerical_jacobian(
            lambda Z: Z,
            X,
            retract=lambda A, d: _as_matrix(retract(A, d), group=group),
            local=canon._local,
            dim=n,
        )
        raise ConventionNotDetected(
            "no convention in the model reproduces this retraction. Measured first-order map "
            f"d(GTSAM local)/dd at the probe pose:\n{np.array2string(M, precision=4)}\n"
            f"closest: {found.describe() if found else 'none'} with max mismatch {err:.3g}"
        )
    cand = found
    matches = matches_so3(cand) if group == "so3" else matching_presets(cand)
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
    )


def matches_so3(conv: Convention) -> list[Convention]:
    """Presets whose rotation retraction (side and rotation coordinates) equals ``conv``'s."""
    from .presets import PRESETS

    return [c for c in PRESETS if (c.side, c.rotation) == (conv.side, conv.rotation)]
