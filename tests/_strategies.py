"""Shared test inputs: fixed edge-case angles, hypothesis strategies and seeded batch generators.

Inputs are built independently of the code under test where that matters: rotation matrices come
from scipy's ``Rotation.from_rotvec`` (or exact constructions such as ``2uuᵀ − I`` at θ = π), and
poses are assembled by hand, so a bug in ``liebridge.lie`` cannot also corrupt the test inputs.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from liebridge.lie import SMALL_ANGLE

PI = math.pi

#: Fixed angles (radians) every kernel function is exercised at: 0, tiny, either side of the
#: series threshold, generic, and the approach to π (where the log's axis must come from the
#: symmetric part and ``±πu`` are both logarithms at π itself).
EDGE_ANGLES: tuple[float, ...] = (
    0.0,
    1e-15,
    1e-12,
    1e-8,
    float(np.nextafter(SMALL_ANGLE, 0.0)),
    SMALL_ANGLE - 1e-9,
    SMALL_ANGLE,
    SMALL_ANGLE + 1e-9,
    float(np.nextafter(SMALL_ANGLE, 4.0)),
    1.0,
    3.0,
    PI - 1e-3,
    PI - 1e-9,
    PI - 1e-12,
    PI,
)

#: The same without θ = π, where ``log(exp(ω)) == ω`` need not hold (±πu are both logs).
EDGE_ANGLES_BELOW_PI: tuple[float, ...] = tuple(a for a in EDGE_ANGLES if a < PI - 1e-9 + 1e-15)

_S2, _S3 = math.sqrt(0.5), math.sqrt(1.0 / 3.0)

#: Axes for rotations by exactly π, including ones with zero and with equal components.
PI_AXES: tuple[tuple[float, float, float], ...] = (
    (1.0, 0.0, 0.0),
    (0.0, 1.0, 0.0),
    (0.0, 0.0, 1.0),
    (_S2, _S2, 0.0),
    (_S2, 0.0, -_S2),
    (0.0, -_S2, _S2),
    (_S3, _S3, _S3),
    (-_S3, _S3, _S3),
    (0.6, 0.0, 0.8),
)


def pi_rotations() -> np.ndarray:
    """Rotations by exactly π: ``diag`` sign patterns and ``2uuᵀ − I`` for :data:`PI_AXES`."""
    diags = [np.diag(d) for d in ((1.0, -1.0, -1.0), (-1.0, 1.0, -1.0), (-1.0, -1.0, 1.0))]
    outer = [2.0 * np.outer(u, u) - np.eye(3) for u in np.asarray(PI_AXES)]
    return np.stack(diags + outer)


def rotation_from_rotvec(w: Any) -> np.ndarray:
    """Rotation matrices from rotation vectors via scipy (an oracle independent of liebridge)."""
    w = np.asarray(w, dtype=np.float64)
    return np.asarray(Rotation.from_rotvec(w.reshape(-1, 3)).as_matrix()).reshape(
        (*w.shape[:-1], 3, 3)
    )


def assemble(R: Any, t: Any) -> np.ndarray:
    """Homogeneous matrices ``[[R, t], [0, 1]]`` (broadcast), built by hand."""
    R = np.asarray(R, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    shape = np.broadcast_shapes(R.shape[:-2], t.shape[:-1])
    T = np.zeros((*shape, 4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = t
    T[..., 3, 3] = 1.0
    return T


# --------------------------------------------------------------------------- oracle accuracy

EPS = float(np.finfo(np.float64).eps)


def gtsam_near_pi_allowance(theta: float) -> float:
    """Extra error of GTSAM 4.3's ``LogmapDerivative`` / ``Logmap`` (SE(3)) / ``slerp`` near π.

    GTSAM replaces D(θ) = 1/θ² − (1 + cos θ)/(2θ sin θ) by its first-order Taylor polynomial
    about π when ``(π − θ)² < 1e-6`` (``gtsam/geometry/SO3.cpp``, ``DexpFunctor::D``). The
    neglected term is ``D''(π)/2 · δ² · θ² = 0.054 δ²`` (δ = π − θ, from mpmath): 5.4e-8 at
    δ = 1e-3. Allowance ``0.06 δ²`` (relative to the translation scale for SE(3)) for
    δ < 1.01e-3: GTSAM decides the branch on the angle *it* recovers from a matrix, which can sit
    on the other side of 1e-3 than the angle of the twist the test started from.
    """
    delta = max(PI - theta, 0.0)
    return 0.06 * delta * delta if delta < 1.01e-3 else 0.0


def pinocchio_allowance(what: str, theta: float) -> float:
    """Extra error of Pinocchio 4.1 functions, measured against 60-digit mpmath.

    * ``log3`` / ``log6`` (also inside ``Jlog3`` / ``Jlog6``): ≤ 4.5·eps/δ² for δ = π − θ between
      3.5e-3 and 1 (4.7e-11 at δ = 3.75e-3); below δ ≈ 3e-3 another branch is exact to 1e-15.
      Allowance ``8 eps/δ²`` for 2e-3 ≤ δ ≤ 1 (beyond δ = 1 it would be below 2e-15 anyway).
    * ``Jlog3`` (also ``Jlog6``) near 0: ≤ 0.5·eps/θ² for θ between 1.2e-4 and 2.5e-3 (3e-9 at
      θ = 1.9e-4). Allowance ``eps/θ²`` for 1e-4 ≤ θ ≤ 1e-2.
    * ``Jexp6`` / ``Jlog6`` translation block: series below θ ≈ eps^(1/4) ≈ 1.2e-4, closed form
      above, losing ≤ 0.5·eps/θ³ (4e-5 at θ = 1.26e-4, 7e-8 at 1e-3). Allowance ``eps/θ³``
      for θ ≥ 1e-4.

    The kernel itself is checked against mpmath at these angles (``test_lie_so3`` and
    ``test_lie_se3``: ``*_matches_mpmath``), and against GTSAM at 1e-12.
    """
    delta = PI - theta
    extra = 0.0
    if what in ("log3", "log6", "Jlog3", "Jlog6") and 2e-3 <= delta <= 1.0:
        extra += 8.0 * EPS / delta**2
    if what in ("Jlog3", "Jlog6") and 1e-4 <= theta <= 1e-2:
        extra += EPS / theta**2
    if what in ("Jexp6", "Jlog6") and theta >= 1e-4:
        extra += EPS / theta**3
    return extra


# --------------------------------------------------------------------------- hypothesis


@st.composite
def unit_vectors(draw: st.DrawFn) -> np.ndarray:
    """Random unit 3-vectors (rejecting near-zero draws before normalising)."""
    c = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
    x = np.array([draw(c), draw(c), draw(c)])
    n = float(np.linalg.norm(x))
    if n < 1e-3:
        x, n = np.array([0.0, 0.0, 1.0]), 1.0
    return x / n


def angles(max_angle: float = PI) -> st.SearchStrategy[float]:
    """Angles in ``[0, max_angle]``: the fixed edge cases or any float in between."""
    edges = [a for a in EDGE_ANGLES if a <= max_angle]
    return st.one_of(st.sampled_from(edges), st.floats(0.0, max_angle))


@st.composite
def rotvecs(draw: st.DrawFn, max_angle: float = PI) -> np.ndarray:
    """Rotation vectors ``θ u`` with ``θ ∈ [0, max_angle]`` and a random axis."""
    return draw(angles(max_angle)) * draw(unit_vectors())


@st.composite
def translations(draw: st.DrawFn, max_norm: float = 30.0) -> np.ndarray:
    """Translations of norm up to ``max_norm`` metres."""
    return draw(st.floats(0.0, max_norm)) * draw(unit_vectors())


@st.composite
def twists(draw: st.DrawFn, max_angle: float = PI, max_norm: float = 30.0) -> np.ndarray:
    """Canonical twists ``(ω, v)`` with ``‖ω‖ ≤ max_angle`` and ``‖v‖ ≤ max_norm``."""
    return np.concatenate([draw(rotvecs(max_angle)), draw(translations(max_norm))])


@st.composite
def rotations(draw: st.DrawFn) -> np.ndarray:
    """Rotation matrices at any angle in ``[0, π]``, including the exact-π constructions."""
    if draw(st.integers(0, 4)) == 0:
        return pi_rotations()[draw(st.integers(0, len(pi_rotations()) - 1))]
    return rotation_from_rotvec(draw(rotvecs()))


@st.composite
def poses(draw: st.DrawFn, max_norm: float = 30.0) -> np.ndarray:
    """Poses with rotations from :func:`rotations` and translations up to ``max_norm``."""
    return assemble(draw(rotations()), draw(translations(max_norm)))


# --------------------------------------------------------------------------- seeded batches


def random_unit(rng: np.random.Generator, shape: tuple[int, ...] = ()) -> np.ndarray:
    """Uniformly distributed unit 3-vectors, shape ``(*shape, 3)``."""
    u = rng.normal(size=(*shape, 3))
    return u / np.linalg.norm(u, axis=-1, keepdims=True)


def random_rotvecs(
    rng: np.random.Generator, shape: tuple[int, ...] = (), max_angle: float = PI
) -> np.ndarray:
    """Rotation vectors with angles uniform in ``[0, max_angle]``, shape ``(*shape, 3)``."""
    return rng.uniform(0.0, max_angle, size=shape)[..., None] * random_unit(rng, shape)


def random_twists(
    rng: np.random.Generator,
    shape: tuple[int, ...] = (),
    max_angle: float = PI,
    max_norm: float = 30.0,
) -> np.ndarray:
    """Twists ``(ω, v)`` with ``‖v‖ ≤ max_norm``, shape ``(*shape, 6)``."""
    v = rng.uniform(0.0, max_norm, size=shape)[..., None] * random_unit(rng, shape)
    return np.concatenate([random_rotvecs(rng, shape, max_angle), v], axis=-1)


def random_rotations(rng: np.random.Generator, shape: tuple[int, ...] = ()) -> np.ndarray:
    """Random rotation matrices (scipy), shape ``(*shape, 3, 3)``."""
    return rotation_from_rotvec(random_rotvecs(rng, shape))


def random_poses(
    rng: np.random.Generator, shape: tuple[int, ...] = (), max_norm: float = 30.0
) -> np.ndarray:
    """Random poses with translations up to ``max_norm``, shape ``(*shape, 4, 4)``."""
    t = rng.uniform(0.0, max_norm, size=shape)[..., None] * random_unit(rng, shape)
    return assemble(random_rotations(rng, shape), t)


def edge_rotvecs(
    rng: np.random.Generator, n_axes: int = 4, angles: tuple[float, ...] = EDGE_ANGLES
) -> np.ndarray:
    """Every angle of ``angles`` about ``n_axes`` random axes, shape ``(len(angles)·n_axes, 3)``."""
    th = np.repeat(np.asarray(angles), n_axes)
    return th[:, None] * random_unit(rng, (th.size,))


#: Batch shapes every public function is checked over (element-wise vs batched).
BATCH_SHAPES: tuple[tuple[int, ...], ...] = ((), (5,), (2, 3))


def assert_batched_equals_elementwise(
    f: Callable[..., Any], *args: np.ndarray, batch: tuple[int, ...], rtol: float = 1e-14
) -> None:
    """Check ``f(*args)`` on a batch equals ``f`` applied to each batch element.

    Every argument has the leading batch shape ``batch``. The batched and single calls run the same
    numpy code; only BLAS's blocking of batched ``matmul`` may reorder sums, so the tolerance is a
    few ulp relative to the largest entry (``rtol`` = 1e-14).
    """
    out = np.asarray(f(*args))
    assert out.dtype == np.float64
    assert out.shape[: len(batch)] == batch
    for idx in np.ndindex(*batch):
        single = np.asarray(f(*(a[idx] for a in args)))
        assert single.shape == out.shape[len(batch) :]
        scale = max(1.0, float(np.abs(single).max(initial=0.0)))
        np.testing.assert_allclose(out[idx], single, rtol=0, atol=rtol * scale, err_msg=str(idx))
