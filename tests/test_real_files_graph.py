"""Pose graphs from files, as a newcomer takes them to GTSAM: the gauge prior and its absence.

A g2o file of relative measurements fixes no pose. ``G2OGraph.to_gtsam()`` adds the gauge prior
``liebridge optimize`` adds (and says so), ``prior=None`` adds none; a gauge-free graph gets a
one-line error from the marginals and ``determined=False`` (with a warning) from ``optimize``.
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Iterator
from pathlib import Path

import gtsam
import numpy as np
import pytest

import liebridge as lb
from liebridge.cli import main
from liebridge.gtsam.optimize import IndeterminateSystemWarning
from liebridge.io.g2o import GAUGE_PRIOR_SIGMA, GaugePriorNotice
from liebridge.lie import se2, se3

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
POSE3 = gtsam.findExampleDataFile("pose3example.txt")
POSE2 = gtsam.findExampleDataFile("w100.graph")


def _readme_block(heading: str) -> str:
    return README.split(heading, 1)[1].split("```python", 1)[1].split("```", 1)[0]


def _tum_file(path: Path) -> Path:
    rng = np.random.default_rng(0)
    T = se3.exp(rng.normal(size=(5, 6)) * 0.3)
    lb.io.write_tum(path, lb.io.Trajectory(np.arange(5.0) * 0.1, T))
    return path


@contextlib.contextmanager
def _no_warning(category: type[Warning]) -> Iterator[None]:
    """Turn ``category`` into an error inside the block."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", category)
        yield


# ----------------------------------------------------------------------- the README route
def test_readme_pose_graph_route_marginals_needs_gauge_prior(tmp_path, monkeypatch) -> None:
    """The README's pose-graph block runs as written: read, to_gtsam, optimize, marginals."""
    monkeypatch.chdir(tmp_path)
    block = _readme_block("## Poses, trajectories, g2o files, GTSAM glue")
    x = np.array([[1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0], [0.5, 0.0, 0.0, 0.6, 0.0, 0.0, 0.8]])
    ns = {"lb": lb, "np": np, "x": x, "g2o_path": POSE3, "tum_path": _tum_file(tmp_path / "t.txt")}
    with pytest.warns(GaugePriorNotice, match=r"gauge prior on vertex 0 .*σ = 0\.0001"):
        exec(compile(block, "README pose-graph route", "exec"), ns)
    assert ns["result"].determined and ns["result"].converged
    cov = ns["cov"]
    n = len(ns["keys"])
    assert cov.shape == (n, 6, 6) and np.all(np.linalg.eigvalsh(cov) > 0)
    # vertex 0 is held by the gauge prior: its marginal is the prior's, σ² in every direction
    np.testing.assert_allclose(np.diag(cov[0]), GAUGE_PRIOR_SIGMA**2, rtol=0.05)
    assert (tmp_path / "out.g2o").is_file() and (tmp_path / "out.txt").is_file()


def test_readme_pose_graph_route_without_prior_fails_in_one_line() -> None:
    g = lb.io.g2o.read(POSE3)
    graph, values = g.to_gtsam(prior=None)
    assert graph.size() == g.edges.shape[0]
    with pytest.raises(ValueError) as err:
        lb.gtsam.marginals(graph, values, [0, 1], "barfoot")
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("graph: the linear system is not fully determined")
    assert "near variable" in msg and "prior" in msg and "Thrown when" not in msg


def test_convention_graph_marginals_of_gauge_free_graph_fail_in_one_line() -> None:
    graph, values = lb.io.g2o.read(POSE3).to_gtsam(prior=None)
    cg = lb.gtsam.ConventionGraph("sophus", graph, values)
    with pytest.raises(ValueError, match=r"^graph: the linear system is not fully determined"):
        cg.marginal_covariance(1)


# ----------------------------------------------------------------------- the default prior
def test_to_gtsam_default_prior_is_the_cli_gauge_prior(tmp_path) -> None:
    """``to_gtsam()``'s graph, optimized, has the marginals ``liebridge optimize`` writes."""
    out = tmp_path / "m.npy"
    assert main(["optimize", POSE3, "--out-cov", str(out)]) == 0
    cli = np.load(out)
    g = lb.io.g2o.read(POSE3)
    with pytest.warns(GaugePriorNotice):
        graph, values = g.to_gtsam()
    res = lb.gtsam.optimize(graph, values, progress=False)
    ours = lb.gtsam.marginals(graph, res.values, g.vertex_ids.tolist())
    np.testing.assert_allclose(ours, cli, rtol=1e-6, atol=1e-14)


def test_to_gtsam_default_prior_equals_readg2o_graph_plus_a_prior_on_the_first_vertex() -> None:
    g = lb.io.g2o.read(POSE3, "gtsam")
    with pytest.warns(GaugePriorNotice):
        graph, values = g.to_gtsam()
    ref, ref_values = gtsam.readG2o(POSE3, True)
    noise = gtsam.noiseModel.Isotropic.Sigma(6, 1e-4)
    ref.add(gtsam.PriorFactorPose3(0, ref_values.atPose3(0), noise))
    assert graph.size() == ref.size() == g.edges.shape[0] + 1
    rng = np.random.default_rng(3)
    moved = gtsam.Values()
    for k in g.vertex_ids.tolist():
        moved.insert(k, values.atPose3(k).retract(rng.normal(size=6) * 1e-3))
    assert graph.error(moved) == pytest.approx(ref.error(moved), rel=1e-9)


def test_to_gtsam_gauge_prior_holds_the_fix_vertices(tmp_path) -> None:
    p = tmp_path / "fix.g2o"
    lines = [f"VERTEX_SE3:QUAT {k} {k}.0 0 0 0 0 0 1" for k in range(4)]
    info = " ".join(["1 0 0 0 0 0", "1 0 0 0 0", "1 0 0 0", "1 0 0", "1 0", "1"])
    lines += [f"EDGE_SE3:QUAT {k} {k + 1} 1 0 0 0 0 0 1 {info}" for k in range(3)]
    p.write_text("\n".join([*lines, "FIX 1 2", ""]))
    with pytest.warns(GaugePriorNotice, match="vertex 1, 2 "):
        graph, values = lb.io.g2o.read(p).to_gtsam()
    priors = [graph.at(n) for n in range(graph.size()) if len(graph.at(n).keys()) == 1]
    assert [int(f.keys()[0]) for f in priors] == [1, 2]
    assert all(f.prior().equals(values.atPose3(int(f.keys()[0])), 0.0) for f in priors)


@pytest.mark.parametrize(
    ("prior", "want"),
    [
        (0.5, np.eye(6) * 0.25),
        ([1.0, 2.0, 3.0, 0.1, 0.2, 0.3], np.diag([1.0, 4.0, 9.0, 0.01, 0.04, 0.09])),
        ("full", None),
    ],
)
def test_to_gtsam_user_prior_is_a_covariance_over_gtsam_tangent(prior, want) -> None:
    """The prior's covariance is GTSAM's marginal of the held vertex (its (ω, v) tangent)."""
    if want is None:
        A = np.random.default_rng(1).normal(size=(6, 6))
        prior = want = A @ A.T + 0.1 * np.eye(6)
    one = lb.io.g2o.G2OGraph(
        vertex_ids=[7],
        vertex_xyz_qxyzw=[[1.0, 2.0, 3.0, 0.0, 0.6, 0.0, 0.8]],
        edges=np.zeros((0, 2), dtype=np.uint64),
        measured_xyz_qxyzw=np.zeros((0, 7)),
        information=np.zeros((0, 6, 6)),
    )
    with _no_warning(GaugePriorNotice):  # an explicit prior is added silently
        graph, values = one.to_gtsam(prior=prior)
    got = lb.gtsam.marginals(graph, values, [7])[0]
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize(
    ("prior", "error", "match"),
    [
        ("fixed", ValueError, r"prior: expected 'gauge', None"),
        (-1.0, ValueError, r"prior: a standard deviation must be finite, > 0, got -1\.0"),
        (float("nan"), ValueError, r"prior: a standard deviation must be finite"),
        ([1, 1, 1, 1, 0, 1], ValueError, r"prior\[4\]: a standard deviation must be finite"),
        (np.ones(5), ValueError, r"prior: .*got shape \(5,\)"),
        (np.diag([1, 1, 1, 1, 1, -1.0]), ValueError, r"not positive definite .*-1"),
        (np.eye(6) + np.triu(np.ones((6, 6)), 1), ValueError, r"not symmetric"),
        (True, TypeError, r"prior: expected"),
        (object(), TypeError, r"prior: expected .* got object"),
    ],
)
def test_to_gtsam_bad_prior_names_the_argument(prior, error, match) -> None:
    g = lb.io.g2o.read(POSE3)
    with pytest.raises(error, match=match):
        g.to_gtsam(prior=prior)


# ----------------------------------------------------------------------- 2-D graphs
def test_2d_to_gtsam_default_prior_gives_marginals_and_none_fails_in_one_line() -> None:
    g = lb.io.g2o2d.read(POSE2)
    with pytest.warns(GaugePriorNotice, match=r"G2OGraph2D\.to_gtsam: .*\(vx, vy, ω\)"):
        graph, values = g.to_gtsam()
    assert graph.size() == g.edges.shape[0] + 1
    res = lb.gtsam.optimize(graph, values, progress=False)
    assert res.determined
    cov = lb.gtsam.marginals(graph, res.values, [0, 50], "gtsam_pose2")
    np.testing.assert_allclose(np.diag(cov[0]), GAUGE_PRIOR_SIGMA**2, rtol=0.05)
    free, free_values = g.to_gtsam(prior=None)
    with pytest.raises(ValueError, match=r"^graph: the linear system is not fully determined"):
        lb.gtsam.marginals(free, free_values, [50], "gtsam_pose2")


def test_2d_to_gtsam_user_prior_is_a_covariance_over_pose2_tangent() -> None:
    one = lb.io.g2o2d.G2OGraph2D(
        vertex_ids=[3],
        vertex_xytheta=[[1.0, -2.0, 0.7]],
        edges=np.zeros((0, 2), dtype=np.uint64),
        measured_xytheta=np.zeros((0, 3)),
        information=np.zeros((0, 3, 3)),
    )
    C = np.array([[0.04, 0.01, 0.002], [0.01, 0.09, -0.003], [0.002, -0.003, 0.01]])
    with _no_warning(GaugePriorNotice):
        graph, values = one.to_gtsam(prior=C)
    got = lb.gtsam.marginals(graph, values, [3], "gtsam_pose2")[0]
    np.testing.assert_allclose(got, C, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(values.atPose2(3).matrix(), se2.exp(se2.log(one.poses[0])))
    with pytest.raises(ValueError, match=r"prior: .*\(3, 3\) covariance, got shape \(6, 6\)"):
        one.to_gtsam(prior=np.eye(6))


def test_cli_optimize_2d_holds_the_fix_vertices(tmp_path, capsys) -> None:
    p = tmp_path / "fix2d.g2o"
    lines = [f"VERTEX_SE2 {k} {k}.0 0 0" for k in range(4)]
    lines += [f"EDGE_SE2 {k} {k + 1} 1 0 0 1 0 0 1 0 1" for k in range(3)]
    p.write_text("\n".join([*lines, "FIX 2", ""]))
    assert main(["optimize", str(p), "--dry-run"]) == 0
    assert "gauge: prior on vertex 2 (σ = 0.0001)" in capsys.readouterr().out


# ----------------------------------------------------------------------- optimize
def test_optimize_reports_a_gauge_free_graph_as_not_determined() -> None:
    graph, values = lb.io.g2o.read(POSE3).to_gtsam(prior=None)
    with pytest.warns(IndeterminateSystemWarning, match=r"not fully determined .*prior"):
        res = lb.gtsam.optimize(graph, values, progress=False)
    assert res.converged and not res.determined
    assert "near variable" in res.indeterminate
    assert "NOT fully determined" in repr(res)


def test_optimize_with_the_gauge_prior_is_determined_and_silent() -> None:
    g = lb.io.g2o.read(POSE3)
    graph, values = g.to_gtsam(prior=GAUGE_PRIOR_SIGMA)
    with _no_warning(IndeterminateSystemWarning):
        res = lb.gtsam.optimize(graph, values, progress=False)
    assert res.converged and res.determined and res.indeterminate == ""
    assert "NOT" not in repr(res)


def test_optimize_gauge_free_custom_factors_and_zero_iterations_are_checked_too() -> None:
    """Liebridge's batched custom factors, and a run that stops before any iteration."""
    g = lb.io.g2o.read(POSE3)
    graph = gtsam.NonlinearFactorGraph()
    cov = np.linalg.inv(g.information)
    for (i, j), Z, c in zip(g.edges.tolist(), g.measured, cov, strict=True):
        graph.add(lb.gtsam.between(int(i), int(j), Z, c, "sophus", native=False))
    values = lb.gtsam.to_values(g.poses, g.vertex_ids.tolist())
    with pytest.warns(IndeterminateSystemWarning):
        res = lb.gtsam.optimize(graph, values, progress=False)
    assert not res.determined
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(0)
    with pytest.warns(IndeterminateSystemWarning):
        res = lb.gtsam.optimize(graph, values, params, progress=False)
    assert res.iterations == 0 and not res.determined
