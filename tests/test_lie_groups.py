"""Group-specific checks of so2, se2, sim3, se23: expm, π, GTSAM, Pinocchio, spatialmath.

Each group is described by its module, tangent dimension, where the rotation coordinates sit in
the tangent, and an independent way to build elements (rotations from scipy, matrices assembled
by hand), so a bug in the kernel cannot corrupt the inputs. Checks: ``exp`` against
``scipy.linalg.expm(hat ξ)``, fixed edge angles (0, 1e-12, near and exactly π), the Sim(3)
coefficients against 50-digit mpmath, and the real libraries:
GTSAM 4.3 (``Rot2``, ``Pose2``, ``Similarity3``, ``NavState``), Pinocchio's SE(2) Lie group and
spatialmath's ``Twist2``. The properties every group shares (round trips, Jacobians against
central differences through the group's own retraction, identities, batching, no mutation) run in
the one harness, ``tests/test_lie_kernels.py``.

Tolerances: ``ID_TOL = 1e-11·scale`` for identities between kernel outputs and for oracles,
``FD_TOL = 2e-8·scale`` for central differences with step 1e-6 (scale = max(1, ‖ξ‖, ‖t‖)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import ModuleType
from typing import Any

import gtsam
import mpmath
import numpy as np
import pytest
import scipy.linalg
from scipy.spatial.transform import Rotation

from liebridge.lie import se2, se3, se23, sim3, so2, so3
from liebridge.lie.series import sim3_coeffs

PI = math.pi
ID_TOL = 1e-11
FD_TOL = 2e-8
EDGE = (0.0, 1e-12, 1e-8, 0.3, 0.5, 1.0, 3.0, PI - 1e-3, PI - 1e-9)


def _rot2(th: Any) -> np.ndarray:
    th = np.asarray(th, dtype=float)
    c, s = np.cos(th), np.sin(th)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


@dataclass(frozen=True)
class G:
    name: str
    mod: ModuleType
    dim: int
    rot: slice  # rotation coordinates in the tangent

    def tangent(self, rng: np.random.Generator, shape: tuple[int, ...] = (), angle: Any = None):
        xi = rng.uniform(-3.0, 3.0, size=(*shape, self.dim))
        r = xi[..., self.rot]
        nr = r.shape[-1]
        u = rng.normal(size=(*shape, nr))
        u /= np.linalg.norm(u, axis=-1, keepdims=True)
        ang = rng.uniform(0.0, 3.0, size=shape) if angle is None else np.full(shape, angle)
        xi[..., self.rot] = u * ang[..., None]
        if self.name == "sim3":
            xi[..., 6] = rng.uniform(-1.5, 1.5, size=shape)
        return xi

    def element(self, rng: np.random.Generator, shape: tuple[int, ...] = ()) -> np.ndarray:
        """Assembled by hand (scipy rotations), not with the kernel."""
        n = int(np.prod(shape)) if shape else 1
        if self.name == "so2":
            X = _rot2(rng.uniform(-PI, PI, n))
        elif self.name == "se2":
            X = np.zeros((n, 3, 3))
            X[:, :2, :2] = _rot2(rng.uniform(-PI, PI, n))
            X[:, :2, 2] = rng.uniform(-30, 30, (n, 2))
            X[:, 2, 2] = 1.0
        elif self.name == "so3":
            X = Rotation.random(n, random_state=rng).as_matrix()
        else:
            k = {"se3": 4, "sim3": 4, "se23": 5}[self.name]
            X = np.zeros((n, k, k))
            R = Rotation.random(n, random_state=rng).as_matrix()
            s = np.exp(rng.uniform(-1, 1, n)) if self.name == "sim3" else np.ones(n)
            X[:, :3, :3] = s[:, None, None] * R
            X[:, :3, 3:] = rng.uniform(-30, 30, (n, 3, k - 3))
            X[:, 3:, 3:] = np.eye(k - 3)
        return X.reshape((*shape, *X.shape[1:]))


GROUPS = [
    G("so2", so2, 1, slice(0, 1)),
    G("se2", se2, 3, slice(2, 3)),
    G("sim3", sim3, 7, slice(0, 3)),
    G("se23", se23, 9, slice(0, 3)),
    G("so3", so3, 3, slice(0, 3)),
    G("se3", se3, 6, slice(0, 3)),
]
IDS = [g.name for g in GROUPS]


def _call(g: G, fname: str, *args: Any) -> np.ndarray:
    return np.asarray(getattr(g.mod, fname)(*args))


def _inv(g: G, X: np.ndarray) -> np.ndarray:
    return np.linalg.inv(X) if g.name == "so3" else _call(g, "inverse", X)


def _scale(*xs: np.ndarray) -> float:
    return max([1.0, *(float(np.abs(x).max()) for x in xs)])


def _hat(g: G, xi: np.ndarray) -> np.ndarray:
    return _call(g, "hat", xi)


def _fd(f: Any, x: np.ndarray, h: float = 1e-6) -> np.ndarray:
    cols = []
    for k in range(x.shape[-1]):
        e = np.zeros_like(x)
        e[k] = h
        cols.append((f(x + e) - f(x - e)) / (2 * h))
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize("g", GROUPS, ids=IDS)
def test_exp_is_matrix_exponential_and_round_trips(g: G) -> None:
    rng = np.random.default_rng(1)
    for _ in range(20):
        xi = g.tangent(rng)
        E = _call(g, "exp", xi)
        np.testing.assert_allclose(E, scipy.linalg.expm(_hat(g, xi)), atol=ID_TOL * _scale(xi, E))
        np.testing.assert_allclose(_call(g, "log", E), xi, atol=ID_TOL * _scale(xi))
        np.testing.assert_allclose(_call(g, "vee", _hat(g, xi)), xi, atol=0)
        X = g.element(rng)
        np.testing.assert_allclose(_call(g, "exp", _call(g, "log", X)), X, atol=ID_TOL * _scale(X))


@pytest.mark.parametrize("angle", EDGE)
@pytest.mark.parametrize("g", GROUPS, ids=IDS)
def test_edge_angles_round_trip(g: G, angle: float) -> None:
    rng = np.random.default_rng(2)
    xi = g.tangent(rng, angle=angle)
    E = _call(g, "exp", xi)
    np.testing.assert_allclose(E, scipy.linalg.expm(_hat(g, xi)), atol=ID_TOL * _scale(xi, E))
    tol = ID_TOL if angle < PI - 1e-6 else 2e-6  # log near π: the axis is ill-conditioned
    np.testing.assert_allclose(_call(g, "log", E), xi, atol=tol * _scale(xi))
    J = _call(g, "jr", xi)
    np.testing.assert_allclose(_call(g, "jr_inv", xi) @ J, np.eye(g.dim), atol=1e-9 * _scale(xi))


@pytest.mark.parametrize("g", GROUPS, ids=IDS)
def test_exactly_pi(g: G) -> None:
    rng = np.random.default_rng(3)
    xi = g.tangent(rng, angle=PI)
    E = scipy.linalg.expm(_hat(g, xi))  # built independently
    k = {"se2": 1, "se3": 1, "sim3": 1, "se23": 2}.get(g.name, 0)
    if k:  # the constant rows exactly (expm rounds them)
        E[-k:, :] = np.eye(E.shape[-1])[-k:, :]
    if g.name in ("so2", "se2"):  # exact rotation by π
        E[..., :2, :2] = [[-1.0, 0.0], [0.0, -1.0]]
    w = _call(g, "log", E)
    assert np.isclose(np.linalg.norm(w[g.rot]), PI, atol=1e-9)
    np.testing.assert_allclose(_call(g, "exp", w), E, atol=1e-9 * _scale(E))


@pytest.mark.parametrize("g", [g for g in GROUPS if g.name != "so3"], ids=[*IDS[:4], "se3"])
def test_compose_inverse_act_interpolate(g: G) -> None:
    rng = np.random.default_rng(6)
    X, Y = g.element(rng), g.element(rng)
    k = X.shape[-1]
    np.testing.assert_allclose(_call(g, "compose", X, Y), X @ Y, atol=1e-12 * _scale(X, Y) ** 2)
    np.testing.assert_allclose(X @ _call(g, "inverse", X), np.eye(k), atol=1e-12 * _scale(X) ** 2)
    np.testing.assert_allclose(_call(g, "interpolate", X, Y, 0.0), X, atol=1e-10 * _scale(X, Y))
    np.testing.assert_allclose(_call(g, "interpolate", X, Y, 1.0), Y, atol=1e-9 * _scale(X, Y))
    p = rng.normal(size=3 if k >= 4 else 2)
    ph = np.zeros(k)
    ph[: p.size] = p
    if g.name != "so2":
        ph[p.size] = 1.0
    np.testing.assert_allclose(_call(g, "act", X, p), (X @ ph)[: p.size], atol=1e-12 * _scale(X))


# ----------------------------------------------------------------------------- series (mpmath)
@pytest.mark.parametrize(
    ("theta", "lam"),
    [
        (0, 0),
        (1e-12, 0),
        (1e-8, 1e-9),
        (0.3, 0.2),
        (0.99, 0.1),
        (1.0, 0.0),
        (0.6, -0.79),
        (0.6, 0.81),
        (1.2, 1.61),
        (1.99, 0.1),
        (2, 1),
        (3.14, -3),
        (0.5, 5),
        (1e-12, 2),
        (PI, 0),
        (PI, -1e-10),
        (0.2, -4),
    ],
)
def test_sim3_coefficients_match_mpmath(theta: float, lam: float) -> None:
    mpmath.mp.dps = 50
    t, ll = mpmath.mpf(theta), mpmath.mpf(lam)

    def integral(f: Any) -> float:
        return float(mpmath.quad(lambda x: mpmath.exp(ll * x) * f(x), [0, 1]))

    ref = (
        integral(lambda x: 1),
        integral(lambda x: mpmath.sin(x * t) / t if t else x),
        integral(lambda x: (1 - mpmath.cos(x * t)) / t**2 if t else x * x / 2),
    )
    got = sim3_coeffs(np.array(theta), np.array(lam))
    for g_, r in zip(got, ref, strict=True):
        assert abs(float(g_) - r) <= 1e-15 * abs(r)


# ----------------------------------------------------------------------------- libraries
def test_gtsam_pose2_and_rot2() -> None:
    rng = np.random.default_rng(9)
    g = GROUPS[1]
    for _ in range(10):
        xi = g.tangent(rng)
        X = g.element(rng)
        P = gtsam.Pose2(X[0, 2], X[1, 2], math.atan2(X[1, 0], X[0, 0]))
        np.testing.assert_allclose(se2.exp(xi), gtsam.Pose2.Expmap(xi).matrix(), atol=1e-12)
        np.testing.assert_allclose(se2.log(X), gtsam.Pose2.Logmap(P), atol=1e-11 * _scale(X))
        np.testing.assert_allclose(se2.adjoint(X), P.AdjointMap(), atol=1e-12 * _scale(X))
        np.testing.assert_allclose(se2.jr(xi), gtsam.Pose2.ExpmapDerivative(xi), atol=1e-11)
        np.testing.assert_allclose(
            se2.jr_inv(xi), gtsam.Pose2.LogmapDerivative(gtsam.Pose2.Expmap(xi)), atol=1e-9
        )
        np.testing.assert_allclose(P.retract(xi).matrix(), X @ se2.exp(xi), atol=1e-11 * 30)
        th = xi[2]
        R = gtsam.Rot2.fromAngle(0.7)
        np.testing.assert_allclose(
            R.retract(np.array([th])).matrix(), so2.exp([0.7]) @ so2.exp([th]), atol=1e-14
        )
        np.testing.assert_allclose(so2.log(gtsam.Rot2.fromAngle(th).matrix()), [th], atol=1e-14)


def test_gtsam_similarity3() -> None:
    rng = np.random.default_rng(10)
    g = GROUPS[2]
    for _ in range(10):
        xi = g.tangent(rng)
        X = g.element(rng)
        s = np.cbrt(np.linalg.det(X[:3, :3]))
        S = gtsam.Similarity3(gtsam.Rot3(X[:3, :3] / s), X[:3, 3] / s, s)  # GTSAM's t = t'/s
        M = S.matrix()
        np.testing.assert_allclose(M / M[3, 3], X, atol=1e-12 * _scale(X))
        E = gtsam.Similarity3.Expmap(xi).matrix()
        np.testing.assert_allclose(sim3.exp(xi), E / E[3, 3], atol=1e-12 * _scale(xi, E))
        np.testing.assert_allclose(sim3.log(X), gtsam.Similarity3.Logmap(S), atol=1e-10 * _scale(X))
        np.testing.assert_allclose(sim3.adjoint(X), S.AdjointMap(), atol=1e-12 * _scale(X))
        Y = S.retract(xi).matrix()
        np.testing.assert_allclose(Y / Y[3, 3], X @ sim3.exp(xi), atol=1e-10 * _scale(X) ** 2)
        p = rng.normal(size=3)
        np.testing.assert_allclose(sim3.act(X, p), S.transformFrom(p), atol=1e-12 * _scale(X))


def test_gtsam_navstate() -> None:
    rng = np.random.default_rng(11)
    g = GROUPS[3]
    for _ in range(10):
        xi = g.tangent(rng)
        X = g.element(rng)
        N = gtsam.NavState(gtsam.Rot3(X[:3, :3]), X[:3, 3], X[:3, 4])
        np.testing.assert_allclose(N.matrix(), X, atol=1e-15)
        np.testing.assert_allclose(
            se23.exp(xi), gtsam.NavState.Expmap(xi).matrix(), atol=1e-11 * _scale(xi)
        )
        np.testing.assert_allclose(se23.log(X), gtsam.NavState.Logmap(N), atol=1e-10 * _scale(X))
        np.testing.assert_allclose(se23.adjoint(X), N.AdjointMap(), atol=1e-12 * _scale(X))
        # the tempting identity is false: retract is component-wise, not X·Exp
        d = xi * 0.2
        assert np.abs(N.retract(d).matrix() - X @ se23.exp(d)).max() > 1e-3


def test_pinocchio_se2_liegroup() -> None:
    pin = pytest.importorskip("pinocchio")
    lg = pin.liegroups.SE2()
    rng = np.random.default_rng(12)
    g = GROUPS[1]
    for _ in range(10):
        X = g.element(rng)
        xi = g.tangent(rng)
        q = np.array([X[0, 2], X[1, 2], X[0, 0], X[1, 0]])  # Pinocchio SE(2): (x, y, cos, sin)
        q2 = lg.integrate(q, xi)  # tangent (vx, vy, ω), q·Exp(v)
        Y = X @ se2.exp(xi)
        np.testing.assert_allclose(q2, [Y[0, 2], Y[1, 2], Y[0, 0], Y[1, 0]], atol=1e-11 * 30)
        np.testing.assert_allclose(
            lg.difference(q, q2), se2.log(np.linalg.inv(X) @ Y), atol=1e-9 * 30
        )


def test_spatialmath_twist2() -> None:
    sm = pytest.importorskip("spatialmath")
    rng = np.random.default_rng(13)
    for _ in range(10):
        xi = GROUPS[1].tangent(rng)
        np.testing.assert_allclose(sm.Twist2(xi).exp().A, se2.exp(xi), atol=1e-12 * _scale(xi))


# ----------------------------------------------------------------------------- bad input
def test_bad_elements_one_clear_error() -> None:
    R3 = Rotation.from_rotvec([0.1, 0.2, 0.3]).as_matrix()
    with pytest.raises(
        ValueError, match=r"T: not a valid SE\(2\) element at batch index \(\).*3×3 rotation"
    ):
        se2.log(R3)
    batch = np.stack([np.eye(3), np.diag([1.0, 2.0, 1.0])])  # non-rigid at index 1
    with pytest.raises(
        ValueError, match=r"T: its rotation block is not a rotation at batch index \(1,\)"
    ):
        se2.log(batch)
    X = np.eye(4)
    X[:3, :3] = -2.0 * np.eye(3)
    with pytest.raises(ValueError, match=r"scale s = .*-2 ≤ 0 at batch index"):
        sim3.log(X)
    G_ = gtsam.Similarity3(gtsam.Rot3(), np.ones(3), 2.0).matrix()
    with pytest.raises(ValueError, match="divide by X"):
        sim3.exp(np.zeros(7)) @ sim3.inverse(G_)
    with pytest.raises(ValueError, match=r"X: expected shape \(\.\.\., 5, 5\)"):
        se23.log(np.eye(4))  # wrong shape
    with pytest.raises(ValueError, match=r"SE₂\(3\) element"):
        Y = np.eye(5)
        Y[4, 0] = 1.0
        se23.log(Y)
    with pytest.raises(ValueError, match=r"xi: contains NaN"):
        se2.exp([0.0, np.nan, 0.0])
    with pytest.raises(ValueError, match=r"rotation part of norm"):
        sim3.exp([1e13, 0, 0, 0, 0, 0, 0])
    with pytest.raises(ValueError, match=r"R: expected shape \(\.\.\., 2, 2\)"):
        so2.log(np.eye(3))


_SE2_ANGLES = [1e-12, 1e-6, 1e-3, 0.3, 0.4999, 0.5, 0.5001, 2.0, PI - 1e-9, -0.2]


@pytest.mark.parametrize("theta", _SE2_ANGLES)
def test_se2_closed_forms_match_mpmath(theta: float) -> None:
    """``Exp``, ``Log`` and ``jl`` of SE(2) against their closed forms in 50-digit arithmetic."""
    mpmath.mp.dps = 50
    t = mpmath.mpf(theta)
    v1, v2 = mpmath.mpf("0.7"), mpmath.mpf("-1.3")
    A, b = mpmath.sin(t) / t, (1 - mpmath.cos(t)) / t
    B, tC = (1 - mpmath.cos(t)) / t**2, (t - mpmath.sin(t)) / t**2
    ref_t = [A * v1 - b * v2, b * v1 + A * v2]
    ref_jl = [[A, -b, v1 * tC + v2 * B], [b, A, -v1 * B + v2 * tC], [0, 0, 1]]
    xi = np.array([0.7, -1.3, theta])
    E = se2.exp(xi)
    np.testing.assert_allclose(E[:2, 2], [float(x) for x in ref_t], rtol=2e-16, atol=1e-17)
    J = se2.jl(xi)
    np.testing.assert_allclose(J, [[float(x) for x in r] for r in ref_jl], rtol=4e-16, atol=1e-17)
    # Log of the exactly rounded element recovers (v, θ) to rounding
    T = np.eye(3)
    T[:2, :2] = _rot2(theta)
    T[:2, 2] = [float(x) for x in ref_t]
    np.testing.assert_allclose(se2.log(T), xi, rtol=0, atol=4e-16 * 2)
