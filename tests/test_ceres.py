"""liebridge.ceres against pyceres and GTSAM: stored-block Jacobians, optima, marginals."""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

pyceres = pytest.importorskip("pyceres")
gtsam = pytest.importorskip("gtsam")

import liebridge as lb  # noqa: E402
from liebridge import ceres as lbc  # noqa: E402
from liebridge.conventions import PRESETS  # noqa: E402
from liebridge.lie import se3  # noqa: E402

SE3_PRESETS = sorted(c.name for c in PRESETS if c.record is se3.GROUP)


def _random_pose(rng: np.random.Generator, scale: float = 1.0) -> np.ndarray:
    return se3.exp(rng.normal(size=6) * scale)


def _spd(rng: np.random.Generator, n: int = 6) -> np.ndarray:
    A = rng.normal(size=(n, n)) * 0.1
    return A @ A.T + 0.01 * np.eye(n)


def _quat_plus(q: np.ndarray, d: np.ndarray, order: str) -> np.ndarray:
    """Ceres's QuaternionManifold::Plus (include/ceres/manifold.h), written independently."""
    qw = q if order == "wxyz" else q[[3, 0, 1, 2]]
    n = np.linalg.norm(d)
    dq = np.array([np.cos(n), *(np.sin(n) / n * d)]) if n > 0 else np.array([1.0, 0, 0, 0])
    w1, v1 = dq[0], dq[1:]
    w2, v2 = qw[0], qw[1:]
    out = np.array([w1 * w2 - v1 @ v2, *(w1 * v2 + w2 * v1 + np.cross(v1, v2))])
    return out if order == "wxyz" else out[[1, 2, 3, 0]]


def _central(f, x: np.ndarray, h: float = 1e-6) -> np.ndarray:
    cols = []
    for k in range(x.size):
        e = np.zeros_like(x)
        e[k] = h
        cols.append((f(x + e) - f(x - e)) / (2 * h))
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize("order", ["wxyz", "xyzw"])
@pytest.mark.parametrize("name", SE3_PRESETS)
def test_stored_block_jacobians_match_central_differences(name: str, order: str) -> None:
    rng = np.random.default_rng(abs(hash((name, order))) % 2**32)
    Ti, Tj = _random_pose(rng, 0.5), _random_pose(rng, 0.5)
    Z = se3.inverse(Ti) @ Tj @ se3.exp(rng.normal(size=6) * 0.05)
    cost = lbc.between_cost(Z, _spd(rng), name, quat_order=order)
    prior = lbc.prior_cost(
        Ti @ se3.exp(rng.normal(size=6) * 0.05), _spd(rng), name, quat_order=order
    )
    blocks = [*lbc.pose_blocks(Ti, order), *lbc.pose_blocks(Tj, order)]
    for c, bl in ((cost, blocks), (prior, blocks[:2])):
        _, J = c.residual_and_jacobians(bl)
        for k, b in enumerate(bl):

            def f(x, k=k, c=c, bl=bl):
                args = [x if m == k else bl[m] for m in range(len(bl))]
                return c.residual_and_jacobians(args)[0]

            # ambient (the function extended as r(q/|q|)), and through Ceres's own Plus
            np.testing.assert_allclose(J[k], _central(f, b), atol=1e-6, rtol=1e-6)
            if b.size == 4:
                P = _central(lambda d, b=b: _quat_plus(b, d, order), np.zeros(3))
                fd = _central(lambda d, f=f, b=b: f(_quat_plus(b, d, order)), np.zeros(3))
                np.testing.assert_allclose(J[k] @ P, fd, atol=1e-6, rtol=1e-6)


def test_pyceres_receives_flat_row_major_jacobians() -> None:
    rng = np.random.default_rng(3)
    Ti, Tj = _random_pose(rng), _random_pose(rng)
    c = lbc.between_cost(se3.inverse(Ti) @ Tj, np.eye(6), "sophus")
    blocks = [*lbc.pose_blocks(Ti), *lbc.pose_blocks(Tj)]
    p = pyceres.Problem()
    p.add_residual_block(c, None, blocks)  # no manifold: pyceres returns ambient Jacobians
    crs = p.evaluate_jacobian()
    dense = np.zeros((crs.num_rows, crs.num_cols))
    rows = np.asarray(crs.rows)
    for r in range(crs.num_rows):
        for k in range(rows[r], rows[r + 1]):
            dense[r, crs.cols[k]] = crs.values[k]
    _, J = c.residual_and_jacobians(blocks)
    np.testing.assert_allclose(dense, np.hstack(J), atol=1e-12)


def test_tangent_jacobian_padded_with_zeros_is_wrong() -> None:
    """The forum fix ``[J 0]`` (tangent Jacobian as an ambient one) gives wrong derivatives."""
    rng = np.random.default_rng(5)
    Ti, Tj = _random_pose(rng), _random_pose(rng)
    c = lbc.between_cost(se3.inverse(Ti) @ Tj, np.eye(6), "gtsam")
    bl = [*lbc.pose_blocks(Ti), *lbc.pose_blocks(Tj)]
    _, J = c.residual_and_jacobians(bl)
    order = "wxyz"
    P = _central(lambda d: _quat_plus(bl[2], d, order), np.zeros(3))
    right = J[2] @ P
    # what a user hands over: ∂r/∂ω_right (GTSAM's), padded [J 0]
    G = c.sqrt_information @ lb.conventions.get("gtsam").local_jacobian(
        c.measured, se3.inverse(Ti) @ Tj
    )
    wrong = np.hstack([G[:, :3], np.zeros((6, 1))]) @ P
    assert np.max(np.abs(wrong - right)) > 0.1 * np.max(np.abs(right))


GUARD = textwrap.dedent(
    """
    import numpy as np, pyceres, sys
    from liebridge.lie import se3
    from liebridge import ceres as lbc
    class Raw(pyceres.CostFunction):
        def __init__(self):
            super().__init__(); self.set_num_residuals(1); self.set_parameter_block_sizes([1])
        def Evaluate(self, p, r, j):
            r[0] = p[0][0]
            if j is not None and j[0] is not None: j[0][0] = 1.0
            return True
    x = np.array([2.0])
    prob = pyceres.Problem()
    if sys.argv[1] == "raw":
        prob.add_residual_block(Raw(), None, [x])
    else:
        T = se3.exp([0.1, 0.2, 0.3, 1, 2, 3])
        prob.add_residual_block(lbc.prior_cost(T, np.eye(6)), None, list(lbc.pose_blocks(T)))
    print(sum(v * v for v in prob.evaluate_residuals()))
    """
)


@pytest.mark.parametrize("which", ["raw", "liebridge"])
def test_evaluate_residuals_first_call(which: str) -> None:
    """pyceres 2.6 crashes on evaluate_residuals before any Jacobian evaluation; ours are primed."""
    out = subprocess.run(
        [sys.executable, "-c", GUARD, which], capture_output=True, text=True, timeout=120
    )
    if which == "raw":
        assert out.returncode != 0  # the library fact the guard exists for
    else:
        assert out.returncode == 0, out.stderr
        assert float(out.stdout) == pytest.approx(0.0, abs=1e-20)


# ------------------------------------------------------------------ one graph, two back ends
def _graph(seed: int = 0):
    rng = np.random.default_rng(seed)
    n = 6
    truth = [np.eye(4)]
    for _ in range(n - 1):
        truth.append(truth[-1] @ se3.exp([0.1, -0.05, 0.3, 1.0, 0.2, 0.0]))
    edges = [(k, k + 1) for k in range(n - 1)] + [(0, n - 1), (1, 4)]
    graph = gtsam.NonlinearFactorGraph()
    C0 = np.diag([1e-4, 2e-4, 1e-4, 1e-3, 1e-3, 2e-3])
    graph.add(
        gtsam.PriorFactorPose3(0, gtsam.Pose3(truth[0]), gtsam.noiseModel.Gaussian.Covariance(C0))
    )
    for i, j in edges:
        C = _spd(rng) * 0.1
        Z = se3.inverse(truth[i]) @ truth[j] @ se3.exp(rng.multivariate_normal(np.zeros(6), C))
        graph.add(
            gtsam.BetweenFactorPose3(i, j, gtsam.Pose3(Z), gtsam.noiseModel.Gaussian.Covariance(C))
        )
    init = gtsam.Values()
    for k, T in enumerate(truth):
        init.insert(k, gtsam.Pose3(T @ se3.exp(rng.normal(size=6) * 0.1)))
    return graph, init


@pytest.fixture(scope="module")
def gtsam_solution():
    graph, init = _graph()
    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(1e-14)
    params.setAbsoluteErrorTol(1e-14)
    params.setMaxIterations(200)
    result = gtsam.LevenbergMarquardtOptimizer(graph, init, params).optimize()
    return graph, init, result, gtsam.Marginals(graph, result)


@pytest.mark.parametrize(
    ("convention", "order"),
    [("gtsam", "wxyz"), ("gtsam", "xyzw"), ("sophus", "wxyz"), ("barfoot", "xyzw")],
)
def test_pyceres_reaches_gtsams_optimum_and_marginals(
    gtsam_solution, convention: str, order: str
) -> None:
    graph, init, result, marginals = gtsam_solution
    cp = lbc.problem_from_values(graph, init, convention=convention, quat_order=order)
    summary = cp.solve()
    assert summary.termination_type == pyceres.TerminationType.CONVERGENCE, summary.BriefReport()
    f_gtsam = graph.error(result)
    assert abs(cp.cost() - f_gtsam) <= 1e-6 * f_gtsam
    poses = cp.poses()
    for k in poses:
        T = result.atPose3(k).matrix()
        np.testing.assert_allclose(poses[k], T, atol=1e-7)
    for k in (0, 3, 5):
        ref = marginals.marginalCovariance(k)
        got = cp.covariance(k)
        assert np.linalg.norm(got - ref) <= 1e-6 * np.linalg.norm(ref)
    keys = gtsam.KeyVector([2, 4])
    ref = marginals.jointMarginalCovariance(keys).fullMatrix()
    got = cp.covariance(2, 4)
    assert np.linalg.norm(got - ref) <= 1e-6 * np.linalg.norm(ref)


def test_covariance_read_into_another_convention_and_wrong_reading(gtsam_solution) -> None:
    graph, init, result, marginals = gtsam_solution
    cp = lbc.problem_from_values(graph, init)
    cp.solve()
    T3 = result.atPose3(3).matrix()
    ref = lb.convert_covariance(marginals.marginalCovariance(3), T3, "gtsam", "sophus")
    got = cp.covariance(3, convention="sophus")
    assert np.linalg.norm(got - ref) <= 1e-6 * np.linalg.norm(ref)
    # the raw tangent block of the quaternion: half-angle, left — read as GTSAM's ω it is 4× small
    q, _ = cp.blocks[3]
    cov = pyceres.Covariance(pyceres.CovarianceOptions())
    assert cov.compute([(q, q)], cp.problem)
    raw = np.asarray(cov.get_covariance_block_tangent_space(q, q, cp.problem)).reshape(3, 3)
    ambient = np.asarray(cov.get_covariance_block(q, q)).reshape(4, 4)
    ratio = np.trace(marginals.marginalCovariance(3)[:3, :3]) / np.trace(raw)
    assert ratio == pytest.approx(4.0, rel=1e-6)
    assert ambient.shape == (4, 4)


@pytest.mark.parametrize("convention", ["barfoot", "sophus", "ros"])
@pytest.mark.parametrize("order", ["wxyz", "xyzw"])
def test_a_lone_prior_reads_back_its_own_covariance(convention: str, order: str) -> None:
    """One pose, one prior of covariance C in a convention: the posterior there is exactly C."""
    rng = np.random.default_rng(11)
    T0 = _random_pose(rng)
    C = _spd(rng) * 0.01
    q, t = lbc.pose_blocks(T0, order)
    p = pyceres.Problem()
    p.add_residual_block(lbc.prior_cost(T0, C, convention, quat_order=order), None, [q, t])
    p.set_manifold(q, lbc.quaternion_manifold(order))
    got = lbc.covariance(p, (q, t), convention=convention, quat_order=order)
    assert np.linalg.norm(got - C) <= 1e-9 * np.linalg.norm(C)


def test_bad_input_names_the_argument() -> None:
    with pytest.raises(ValueError, match="quat_order"):
        lbc.pose_blocks(np.eye(4), quat_order="xyz")
    with pytest.raises(ValueError, match="se2"):
        lbc.between_cost(np.eye(4), np.eye(6), "sophus_se2")
    with pytest.raises(ValueError, match="cov"):
        lbc.prior_cost(np.eye(4), -np.eye(6))
    with pytest.raises(TypeError, match="graph"):
        lbc.problem_from_values([1, 2])
    values = gtsam.Values()
    values.insert(9, gtsam.Point3(1, 2, 3))
    with pytest.raises(TypeError, match="key 9"):
        lbc.problem_from_values(gtsam.NonlinearFactorGraph(), values)
    T = _random_pose(np.random.default_rng(1), 1.0)
    np.testing.assert_allclose(
        lbc.pose_from_blocks(*lbc.pose_blocks(T, "xyzw"), "xyzw"), T, atol=1e-12
    )


def test_split_chart_costs_define_a_different_objective(gtsam_solution) -> None:
    """``ros`` residuals are not a linear image of GTSAM's: their optimum is another point."""
    graph, init, result, _ = gtsam_solution
    cp = lbc.problem_from_values(graph, init, convention="ros")
    cp.solve()
    values = gtsam.Values()
    for k, T in cp.poses().items():
        values.insert(k, gtsam.Pose3(T))
    f, f_gtsam = graph.error(values), graph.error(result)
    assert f > f_gtsam * (1 + 1e-6)


def test_g2o_graph_as_a_pyceres_problem() -> None:
    """The g2o route (FIX as constant blocks) reaches the optimum of the GTSAM route."""
    path = gtsam.findExampleDataFile("pose3example.txt")
    g = lbc.graph_from_g2o(path)
    graph, init = g.to_gtsam(prior=None)
    first = int(g.vertex_ids[0])
    T0 = init.atPose3(first).matrix()
    prior = 1e-6 * np.eye(6)
    graph.add(
        gtsam.PriorFactorPose3(first, gtsam.Pose3(T0), gtsam.noiseModel.Gaussian.Covariance(prior))
    )
    a = lbc.problem_from_values(graph, init, quat_order="xyzw")
    b = lbc.problem_from_values(g, quat_order="xyzw")
    c = lbc.prior_cost(T0, prior, quat_order="xyzw")
    b.costs.append(c)
    b.problem.add_residual_block(c, None, list(b.blocks[first]))
    a.solve(), b.solve()
    assert b.cost() == pytest.approx(a.cost(), rel=1e-9)
    for k in a.blocks:
        np.testing.assert_allclose(b.poses()[k], a.poses()[k], atol=1e-6)


def test_the_example_runs_and_its_numbers_hold() -> None:
    script = Path(__file__).resolve().parents[1] / "examples" / "ceres_pose_graph.py"
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    diffs = [float(x) for x in re.findall(r"relative difference ([0-9.e+-]+)", out.stdout)]
    assert len(diffs) == 4 and max(diffs[:3]) <= 1e-6 and diffs[3] > 0.1
    marg = float(re.search(r"max relative error ([0-9.e+-]+)", out.stdout).group(1))
    assert marg <= 1e-6
    wrong = float(
        re.search(r"full angle \(Rᵀ Σ R\): relative error ([0-9.]+)", out.stdout).group(1)
    )
    assert wrong == pytest.approx(0.75, abs=0.01)


def test_the_docs_page_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    page = Path(__file__).resolve().parents[1] / "docs" / "ceres.md"
    blocks = re.findall(r"^```python\n(.*?)^```", page.read_text(encoding="utf-8"), re.M | re.S)
    assert blocks
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": "docs_ceres"}
    for code in blocks:
        exec(compile(code, str(page), "exec"), namespace)


def test_monte_carlo_spread_of_ceres_estimates_matches_covariance() -> None:
    """Re-solve one small graph under sampled measurement noise: the estimates' spread (GTSAM's
    tangent about the truth) is the covariance read back from Ceres."""
    rng = np.random.default_rng(21)
    truth = [np.eye(4), se3.exp([0.1, 0.2, -0.1, 1, 0, 0]), se3.exp([0.3, -0.1, 0.2, 2, 1, 0])]
    edges = [(0, 1), (1, 2), (0, 2)]
    C = np.diag([1e-4, 2e-4, 1e-4, 4e-4, 1e-4, 2e-4])
    C0 = 1e-4 * np.eye(6)

    def solve(noisy: bool):
        graph = gtsam.NonlinearFactorGraph()
        d0 = rng.multivariate_normal(np.zeros(6), C0) if noisy else np.zeros(6)
        prior = gtsam.noiseModel.Gaussian.Covariance(C0)
        graph.add(gtsam.PriorFactorPose3(0, gtsam.Pose3(truth[0] @ se3.exp(d0)), prior))
        for i, j in edges:
            d = rng.multivariate_normal(np.zeros(6), C) if noisy else np.zeros(6)
            Z = se3.inverse(truth[i]) @ truth[j] @ se3.exp(d)
            noise = gtsam.noiseModel.Gaussian.Covariance(C)
            graph.add(gtsam.BetweenFactorPose3(i, j, gtsam.Pose3(Z), noise))
        init = gtsam.Values()
        for k, T in enumerate(truth):
            init.insert(k, gtsam.Pose3(T))
        cp = lbc.problem_from_values(graph, init, quat_order="xyzw")
        cp.solve()
        return cp

    xi = np.array([se3.log(se3.inverse(truth[2]) @ solve(True).poses()[2]) for _ in range(400)])
    predicted = solve(False).covariance(2, convention="gtsam")
    sampled = np.cov(xi.T)
    assert np.linalg.norm(sampled - predicted) <= 0.2 * np.linalg.norm(predicted)
    # the half-angle tangent block read as GTSAM's: 4x off in rotation, far outside sampling noise
    wrong = predicted.copy()
    wrong[:3, :] /= 2
    wrong[:, :3] /= 2
    rot = np.s_[:3, :3]
    assert np.linalg.norm(sampled[rot] - predicted[rot]) <= 0.2 * np.linalg.norm(predicted[rot])
    assert np.linalg.norm(sampled[rot] - wrong[rot]) > 0.5 * np.linalg.norm(predicted[rot])
