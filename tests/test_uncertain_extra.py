"""liebridge.uncertain: uncertain extrinsics, plots, the Monte Carlo helpers' input checks and
the package's place in the layering (imports only _validate, lie, conventions)."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from liebridge import check
from liebridge import uncertain as u
from liebridge.lie import se3

T1 = se3.exp(np.r_[0.3, -0.2, 0.5, 2.0, -1.0, 0.5])
TF = se3.exp(np.r_[1.2, -0.7, 0.4, 0.3, -4.0, 1.0])


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


@pytest.mark.parametrize("side", ["left", "right"])
@pytest.mark.parametrize("name", ["gtsam", "ros", "barfoot"])
def test_uncertain_extrinsic_with_cross(name: str, side: str) -> None:
    L = np.random.default_rng(2).normal(size=(12, 12))
    J = 1e-4 * (L @ L.T / 12 + 0.2 * np.eye(12))
    A = u.UncertainPose(T1, J[:6, :6], name)
    F = u.UncertainPose(TF, J[6:, 6:], name)
    X = J[:6, 6:]  # E[δA δFᵀ]
    C = u.transform(A, F, side, cross=X)
    if side == "left":
        mc = check.monte_carlo_compose(F, A, X.T, n=60000)
        np.testing.assert_allclose(C.T, TF @ T1, atol=1e-12)
    else:
        mc = check.monte_carlo_compose(A, F, X, n=60000)
        np.testing.assert_allclose(C.T, T1 @ TF, atol=1e-12)
    assert _rel(C.cov, mc.cov) < 0.02
    # independence differs measurably from the correlated answer
    assert _rel(u.transform(A, F, side).cov, mc.cov) > 0.05


def test_transform_accepts_gtsam_objects_and_rejects_cross_for_known_transform() -> None:
    gtsam = pytest.importorskip("gtsam")
    A = u.UncertainPose(T1, 1e-4 * np.eye(6), "ros")
    np.testing.assert_allclose(  # entries that are 0 up to rounding: an absolute tolerance
        u.transform(A, gtsam.Pose3(TF), "right").cov, u.transform(A, TF, "right").cov, atol=1e-18
    )
    with pytest.raises(ValueError, match="cross: only meaningful"):
        u.transform(A, TF, "left", cross=np.zeros((6, 6)))
    with pytest.raises(ValueError, match="T_fixed: a"):
        u.transform(A, TF[:3, :3])


def test_ellipse_points_are_on_the_level_set() -> None:
    from liebridge.uncertain.plot import ellipse_points, ellipsoid_points, position

    C = np.array([[4.0, 1.0], [1.0, 2.0]])
    e = ellipse_points([1.0, -1.0], C, n_sigma=2.0, num=50)
    d = e - [1.0, -1.0]
    np.testing.assert_allclose(np.einsum("ki,ij,kj->k", d, np.linalg.inv(C), d), 4.0)
    x, y, z = ellipsoid_points(np.zeros(3), np.diag([1.0, 4.0, 9.0]), n_sigma=1.0, num=10)
    np.testing.assert_allclose((x**2) + (y**2) / 4 + (z**2) / 9, 1.0, atol=1e-12)
    A = u.UncertainPose(T1, 1e-4 * np.eye(6), "gtsam")
    pt = position(A)
    np.testing.assert_allclose(pt.p, T1[:3, 3])
    R = T1[:3, :3]
    np.testing.assert_allclose(pt.cov, R @ A.cov[3:, 3:] @ R.T, atol=1e-18)  # body → parent
    with pytest.raises(TypeError, match="X: expected"):
        position(u.UncertainPose(R, 1e-4 * np.eye(3), "gtsam"))


def test_plot_functions_draw(tmp_path: Path) -> None:
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from liebridge.uncertain.plot import plot_position_ellipse, plot_position_ellipsoid

    A = u.UncertainPose(np.stack([T1, TF]), 1e-3 * np.eye(6), "ros")
    fig = plt.figure()
    ax = fig.add_subplot(1, 2, 1)
    lines = plot_position_ellipse(ax, A, dims=(0, 2), label="A")
    assert len(lines) == 2
    assert lines[0].get_label() == "A"
    ax3 = fig.add_subplot(1, 2, 2, projection="3d")
    assert len(plot_position_ellipsoid(ax3, u.act(A, [1.0, 0.0, 0.0]))) == 2
    fig.savefig(tmp_path / "e.png")
    plt.close(fig)
    assert (tmp_path / "e.png").stat().st_size > 1000


def test_monte_carlo_helpers_check_input() -> None:
    A = u.UncertainPose(T1, 1e-4 * np.eye(6), "gtsam")
    B = u.UncertainPose(TF, 1e-4 * np.eye(6), "ros")
    with pytest.raises(ValueError, match="n: need at least 2"):
        check.monte_carlo_inverse(A, n=1)
    with pytest.raises(ValueError, match="convention 'ros' differs"):
        check.monte_carlo_compose(A, B)
    with pytest.raises(ValueError, match="not positive semi-definite"):
        check.monte_carlo_relative(A, A, 1e-3 * np.eye(6))
    # reproducible by default, different with another generator
    c1 = check.monte_carlo_inverse(A, n=1000).cov
    np.testing.assert_array_equal(c1, check.monte_carlo_inverse(A, n=1000).cov)
    c2 = check.monte_carlo_inverse(A, n=1000, rng=np.random.default_rng(1)).cov
    assert not np.array_equal(c1, c2)


def test_uncertain_imports_only_lower_layers() -> None:
    allowed = {"_validate", "arrays", "lie", "conventions", "uncertain"}
    root = Path(__file__).resolve().parents[1] / "liebridge" / "uncertain"
    for path in root.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.level:
                if node.level == 1:
                    continue  # inside the package
                top = (node.module or "").split(".")[0]
                names = [top] if top else [a.name for a in node.names]
                assert set(names) <= allowed, (path.name, names)
            elif isinstance(node, ast.ImportFrom | ast.Import):
                mods = (
                    [node.module]
                    if isinstance(node, ast.ImportFrom)
                    else [a.name for a in node.names]
                )
                assert not any(str(m).startswith("liebridge") for m in mods), path.name


def test_unscented_outside_the_chart_domain_names_the_covariance() -> None:
    cov = 0.01 * np.eye(6)
    cov[3:, 3:] = 0.3**2 * np.eye(3)  # g2o: (u, quaternion vector); 3.7σ leaves ‖r‖ ≤ 1
    A = u.UncertainPose(T1, cov, "g2o")
    with pytest.raises(ValueError, match=r"A\.cov: a cubature point .* 'g2o' chart's domain"):
        u.compose(A, A, method="unscented")
    assert np.isfinite(u.compose(A, A).cov).all()  # linear is fine


def test_average_of_three_against_monte_carlo_and_bad_input() -> None:
    rng = np.random.default_rng(4)
    covs = [1e-4 * (np.eye(6) + 0.3 * np.diag(rng.random(6))) for _ in range(3)]
    Ts = [T1 @ se3.exp(0.004 * rng.normal(size=6)) for _ in range(3)]
    E = [u.UncertainPose(T, C, "ros") for T, C in zip(Ts, covs, strict=True)]
    avg, mc = u.average(E), check.monte_carlo_average(E, n=100000)
    assert _rel(avg.cov, mc.cov) < 0.02
    with pytest.raises(ValueError, match="at least two"):
        check.monte_carlo_average(E[:1])
    singular = u.UncertainPose(T1, np.diag([1e-4] * 5 + [0.0]), "ros")
    with pytest.raises(ValueError, match=r"estimates\[1\]: covariance must be positive definite"):
        check.monte_carlo_average([E[0], singular])
    with pytest.raises(ValueError, match="need at least one"):
        u.average([])
