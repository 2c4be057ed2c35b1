"""Measure the convention a black-box retraction implements.

``detect_convention(retract)`` calls ``retract(X, d)`` at a generic pose (or rotation) for a set of
increments and compares the results with every convention of the model (2 sides × 2 orders ×
(SE(3) exp + 2 decoupled charts × 4 rotation coordinates) = 36 for poses, 8 for rotations).
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

from .. import _validate as v
from .._validate import FloatArray
from ..lie import unchecked as U
from ..lie.numdiff import numerical_jacobian
from .convention import CANONICAL, CHARTS, ORDERS, SIDES, Convention
from .registry import get, matching_presets
from .rotation_coords import ROTATION_COORDS


class ConventionNotDetected(ValueError):
    """The retraction matches no convention of the model; the message says what was measured."""


def _candidates(group: str) -> list[Convention]:
    if group == "so3":  # only side and rotation coordinates act on a rotation
        combos = [(s, "rot_first", "so3xr3_body", r) for s in SIDES for r in ROTATION_COORDS]
    else:
        combos = [
            c
            for c in itertools.product(SIDES, ORDERS, CHARTS, ROTATION_COORDS)
            if c[2] != "se3" or c[3] == "exp"
        ]
    return [
        Convention("detected:" + "/".join(c), c[0], c[1], c[2], c[3], "wxyz")  # type: ignore[arg-type]
        for c in combos
    ]


def _as_matrix(y: Any, what: str = "retract(X, d)") -> FloatArray:
    """Validate what a retraction returned (an array, or an object with ``.matrix()``)."""
    if hasattr(y, "matrix"):
        y = y.matrix()
    arr = v.as_float_array(y, what)
    v.check_finite(arr, what)
    return arr


def detect_convention(
    retract: Callable[[FloatArray, FloatArray], Any],
    *,
    group: Literal["se3", "so3"] = "se3",
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
    group : {"se3", "so3"}
        What ``X`` is.
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
    group = v.option(group, "group", ("se3", "so3"))  # type: ignore[assignment]
    n = 6 if group == "se3" else 3
    X = U.se3_exp(np.array([0.4, -0.7, 0.5, 1.5, -2.0, 0.8]))
    if group == "so3":
        X = X[:3, :3].copy()
    D = rng.uniform(-0.3, 0.3, size=(8, n))
    results = [
        _as_matrix(retract(X.copy(), d.copy()), f"retract(X, d) at probe {k}")
        for k, d in enumerate(D)
    ]
    for k, y in enumerate(results):
        if y.shape != X.shape:
            raise ConventionNotDetected(
                f"retract(X, d) at probe {k} returned shape {y.shape}, expected {X.shape}"
            )
    Y = np.stack(results)
    Y0 = _as_matrix(retract(X.copy(), np.zeros(n)), "retract(X, 0)")
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
        M = numerical_jacobian(
            lambda Z: Z, X, retract=lambda A, d: _as_matrix(retract(A, d)), local=CANONICAL._local
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
    )


def matches_so3(conv: Convention) -> list[Convention]:
    """Presets whose rotation retraction (side and rotation coordinates) equals ``conv``'s."""
    from .presets import PRESETS

    return [c for c in PRESETS if (c.side, c.rotation) == (conv.side, conv.rotation)]
