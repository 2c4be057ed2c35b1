"""``liebridge optimize`` on GTSAM's 2-D datasets: GTSAM's optimum, SE(2) marginals."""

from __future__ import annotations

from pathlib import Path

import gtsam
import numpy as np
import pytest

import liebridge as lb
from liebridge.cli import main
from liebridge.cli.optimize_2d import PRIOR_SIGMA, build_2d


def _final_error(out: str) -> float:
    return float(next(ln for ln in out.splitlines() if ln.startswith("final error:")).split()[-1])


@pytest.mark.parametrize("name", ["pose2example.txt", "noisyToyGraph.txt", "w100_30.g2o"])
def test_2d_file_reaches_gtsams_optimum(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["optimize", name]) == 0
    ours = _final_error(capsys.readouterr().out)
    graph, values = gtsam.readG2o(gtsam.findExampleDataFile(name), False)
    first = min(values.keys())
    graph.add(
        gtsam.PriorFactorPose2(
            first, values.atPose2(first), gtsam.noiseModel.Isotropic.Sigma(3, PRIOR_SIGMA)
        )
    )
    ref = gtsam.LevenbergMarquardtOptimizer(graph, values).optimize()
    assert ours == pytest.approx(graph.error(ref), rel=1e-5, abs=1e-8)


def test_toro_order_file_gtsam_refuses_is_optimized(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["optimize", "w100.graph"]) == 0
    out = capsys.readouterr().out
    assert "TORO's order" in out and "EQUIV" in out
    assert _final_error(out) < 1.0  # from 38.5: the loop closes


def test_marginals_in_an_se2_convention_match_gtsam_marginals_converted(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    m_path = tmp_path / "m.npy"
    assert (
        main(
            [
                "optimize",
                "pose2example.txt",
                "--convention",
                "ros_pose2",
                "--marginals",
                str(m_path),
            ]
        )
        == 0
    )
    capsys.readouterr()
    cov = np.load(m_path)
    assert cov.shape == (11, 6, 6)
    g = lb.io.g2o2d.read(gtsam.findExampleDataFile("pose2example.txt"))
    # the CLI's graph: custom factors in ros_pose2 (its objective), optimized by GTSAM itself
    graph, values = build_2d(g, lb.conventions.get("ros_pose2"))
    result = gtsam.LevenbergMarquardtOptimizer(graph, values).optimize()
    marg = gtsam.Marginals(graph, result)
    k = 7
    X = result.atPose2(k).matrix()
    want = lb.convert_covariance(marg.marginalCovariance(k), X, "gtsam_pose2", "ros_pose2")
    np.testing.assert_allclose(cov[k], want, rtol=1e-6, atol=1e-12)
    # GTSAM's own graph (native factors, its objective): the same to second order
    graph, values = g.to_gtsam(prior=None)
    graph.add(
        gtsam.PriorFactorPose2(
            0, values.atPose2(0), gtsam.noiseModel.Isotropic.Sigma(3, PRIOR_SIGMA)
        )
    )
    result = gtsam.LevenbergMarquardtOptimizer(graph, values).optimize()
    marg = gtsam.Marginals(graph, result)
    X = result.atPose2(k).matrix()
    native = lb.convert_covariance(marg.marginalCovariance(k), X, "gtsam_pose2", "ros_pose2")
    np.testing.assert_allclose(cov[k], native, rtol=2e-2, atol=1e-6)
    # ROS layout: (x, y, yaw) at (0, 1, 5), nothing in z, roll, pitch
    assert np.all(cov[:, 2:5, :] == 0) and np.all(cov[:, :, 2:5] == 0)


def test_plot_2d(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("matplotlib")
    out = tmp_path / "p.png"
    assert main(["optimize", "noisyToyGraph.txt", "--plot", str(out)]) == 0
    assert out.stat().st_size > 10_000


@pytest.mark.parametrize(
    "argv, message",
    [
        (["optimize", "pose2example.txt", "--convention", "sophus"], "is a convention of se3"),
        (
            ["optimize", "sphere2500.txt", "--convention", "gtsam_pose2", "--dry-run"],
            "is a 3D graph",
        ),
    ],
)
def test_a_convention_of_the_other_dimension_is_one_line(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]


@pytest.mark.parametrize(
    "convention", [c.name for c in lb.conventions.GROUP_PRESETS if c.group == "se2"]
)
@pytest.mark.parametrize("name", ["pose2example.txt", "w100_30.g2o"])
def test_every_se2_convention_builds_its_factors_and_reaches_gtsams_optimum(
    name: str, convention: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """Native factors where the conversion is exact; custom ones (their own objective) else."""
    assert main(["optimize", name, "--convention", convention]) == 0
    out = capsys.readouterr().out
    exact = lb.is_exactly_linear(lb.conventions.get(convention), lb.conventions.get("gtsam_pose2"))
    line = next(ln for ln in out.splitlines() if ln.startswith("convention:"))
    assert ("native BetweenFactorPose2" in line) == exact
    assert ("custom factors" in line) == (not exact)
    graph, values = gtsam.readG2o(gtsam.findExampleDataFile(name), False)
    first = min(values.keys())
    graph.add(
        gtsam.PriorFactorPose2(
            first, values.atPose2(first), gtsam.noiseModel.Isotropic.Sigma(3, PRIOR_SIGMA)
        )
    )
    ref = graph.error(gtsam.LevenbergMarquardtOptimizer(graph, values).optimize())
    # exact: GTSAM's objective; the others: their own, equal to GTSAM's to second order
    assert _final_error(out) == pytest.approx(ref, rel=1e-5 if exact else 1e-3, abs=1e-8)
