"""g2o's two SE(2) charts, measured by running g2opy.

``VertexSE2.oplus`` adds the translation in the world frame and the angle (``g2o_se2``);
``EdgeSE2``'s error is ``toVector(Z⁻¹·Xi⁻¹·Xj)``, a body-frame chart (``g2o_se2_edge``). The
``g2o_se2`` preset once described the vertex with the edge's chart: a vertex covariance converted
with it was off by a factor of several. Inputs are built with numpy's ``cos``/``sin``, not
liebridge.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import liebridge as lb
from liebridge.conventions import detect_convention

g2o = pytest.importorskip("g2opy")
gtsam = pytest.importorskip("gtsam")

TOL = 1e-12


def _mat(x: float, y: float, th: float) -> np.ndarray:
    c, s = math.cos(th), math.sin(th)
    return np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])


def _xyt(T: np.ndarray) -> tuple[float, float, float]:
    return float(T[0, 2]), float(T[1, 2]), math.atan2(T[1, 0], T[0, 0])


def _g2o_oplus(T: np.ndarray, d: np.ndarray) -> np.ndarray:
    v = g2o.VertexSE2()
    v.set_estimate(g2o.SE2(*_xyt(T)))
    v.oplus(np.asarray(d, dtype=np.float64))
    x, y, th = v.estimate().to_vector()
    return _mat(x, y, th)


def _g2o_edge_error(Ti: np.ndarray, Tj: np.ndarray, Z: np.ndarray) -> np.ndarray:
    vi, vj = g2o.VertexSE2(), g2o.VertexSE2()
    vi.set_id(0)
    vj.set_id(1)
    vi.set_estimate(g2o.SE2(*_xyt(Ti)))
    vj.set_estimate(g2o.SE2(*_xyt(Tj)))
    e = g2o.EdgeSE2()
    e.set_vertex(0, vi)
    e.set_vertex(1, vj)
    e.set_measurement(g2o.SE2(*_xyt(Z)))
    e.compute_error()
    return np.asarray(e.error, dtype=np.float64)


def _se2_exp(vx: float, vy: float, w: float) -> np.ndarray:
    """SE(2) exponential, closed form: t = V(ω)·v."""
    a, b = math.sin(w) / w, (1.0 - math.cos(w)) / w
    return _mat(a * vx - b * vy, b * vx + a * vy, w)


def _cases() -> list[tuple[np.ndarray, np.ndarray]]:
    rng = np.random.default_rng(7)
    out = [(_se2_exp(1.0, 2.0, 0.5), np.array([0.1, 0.2, 0.3]))]  # the reported case
    for th in (0.0, 1e-9, 0.7, -2.5, math.pi - 1e-6):  # θ of the pose: 0 … near π
        for dth in (0.0, 1e-9, 0.4, -1.0):
            x, y = rng.uniform(-30, 30, size=2)
            out.append((_mat(x, y, th), np.r_[rng.normal(size=2), dth]))
    return out


def test_g2o_se2_vertex_update_adds_translation_in_world_frame() -> None:
    """The bug: g2o_se2 said X·SE2(d) (body frame); VertexSE2.oplus adds t + (dx, dy)."""
    X, d = _cases()[0]
    got = _g2o_oplus(X, d)
    np.testing.assert_allclose(got[:2, 2], [0.569181, 2.362537], atol=1e-6)  # g2opy 2.3, run
    np.testing.assert_allclose(lb.conventions.get("g2o_se2").retract(X, d), got, atol=TOL)
    # the edge chart is the other one: 0.46 m from g2o's update on this case
    body = lb.conventions.get("g2o_se2_edge").retract(X, d)
    assert np.abs(body[:2, 2] - got[:2, 2]).max() > 0.1


@pytest.mark.parametrize("case", range(len(_cases())))
def test_g2o_se2_equals_vertex_oplus(case: int) -> None:
    X, d = _cases()[case]
    want = _g2o_oplus(X, d)
    got = lb.conventions.get("g2o_se2").retract(X, d)
    np.testing.assert_allclose(got, want, atol=TOL * max(1.0, np.abs(want).max()))


@pytest.mark.parametrize("case", range(len(_cases())))
def test_g2o_se2_edge_is_the_edge_error_chart(case: int) -> None:
    """EdgeSE2.error = toVector(Z⁻¹·Xi⁻¹·Xj) = g2o_se2_edge.local(Z, Xi⁻¹·Xj)."""
    X, d = _cases()[case]
    Ti = X
    Z = _mat(0.8, -0.3, 0.6)
    Tj = Ti @ Z @ _mat(d[0], d[1], d[2])
    want = _g2o_edge_error(Ti, Tj, Z)
    got = lb.conventions.get("g2o_se2_edge").local(Z, np.linalg.solve(Ti, Tj))
    np.testing.assert_allclose(got, want, atol=1e-11)


def test_detect_names_g2o_se2_on_the_vertex_and_g2o_se2_edge_on_the_edge() -> None:
    assert detect_convention(_g2o_oplus, group="se2").name == "g2o_se2"
    # the edge error's own retraction: X·SE2(d), built with g2o's SE2 product
    edge = detect_convention(
        lambda X, d: _mat(*(g2o.SE2(*_xyt(X)) * g2o.SE2(*d)).to_vector()), group="se2"
    )
    assert edge.name == "g2o_se2_edge"


def test_g2o_vertex_covariance_in_gtsam_pose2_chart_agrees_with_monte_carlo() -> None:
    """Samples through g2o's own oplus, read back with GTSAM's own Pose2.localCoordinates."""
    X = _mat(4.0, -3.0, 2.2)
    L = np.array([[0.05, 0.0, 0.0], [0.02, 0.04, 0.0], [-0.01, 0.005, 0.03]])
    cov = L @ L.T  # over g2o's vertex update (dx, dy, dθ)
    rng = np.random.default_rng(11)
    n = 20000
    P = gtsam.Pose2(*_xyt(X))
    xi = np.empty((n, 3))
    for k, d in enumerate(rng.multivariate_normal(np.zeros(3), cov, size=n)):
        xi[k] = P.localCoordinates(gtsam.Pose2(*_xyt(_g2o_oplus(X, d))))
    mc = np.cov(xi.T)
    conv = lb.convert_covariance(cov, X, "g2o_se2", "gtsam_pose2")
    scale = np.sqrt(np.outer(np.diag(mc), np.diag(mc)))
    # sampling error of a covariance entry ≈ sqrt(2/n) ≈ 1 %; 5 % rejects a wrong chart
    assert np.abs(conv - mc).max() / scale.max() < 0.05
    assert np.all(np.abs(conv - mc) / scale < 0.05)
    # the edge chart, applied to a vertex covariance, is the reported failure
    wrong = lb.convert_covariance(cov, X, "g2o_se2_edge", "gtsam_pose2")
    assert np.max(np.abs(wrong - mc) / scale) > 0.5  # measured: 1.0 (x variance doubled)
