"""Autodiff factors: a residual written in torch or JAX, Jacobians in GTSAM's tangent columns.

Oracles: GTSAM's own ``BetweenFactorPose3`` (error and Jacobians), central differences through
GTSAM's own ``Pose3.retract``, liebridge's numpy retraction (for the array retraction), and the
optimum of the same graph with native factors.
"""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import gtsam
import numpy as np
import pytest

import liebridge as lb
from liebridge.conventions import Convention
from liebridge.gtsam.custom import FactorEvaluationError
from liebridge.gtsam.optimize import _SplitGraph

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "autodiff_factor.py"
_spec = importlib.util.spec_from_file_location("autodiff_example", EXAMPLE)
assert _spec is not None and _spec.loader is not None
example = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(example)

BACKENDS = ["torch", "jax"]
SPLIT_BODY = Convention(
    name="split_body_test",
    side="right",
    order="trans_first",
    chart="so3xr3_body",
    rotation="exp",
    quat_order="wxyz",
)
EULER = Convention(  # absolute Euler angles (ZYX), world-frame translation, translation first
    name="euler_test",
    side="right",
    order="trans_first",
    chart="so3xr3_world",
    rotation="euler_zyx",
    quat_order="wxyz",
)
# GTSAM's own, PyPose (left, translation first), Sophus (right, translation first), SymForce
# (split chart, world-frame translation), a split chart with body-frame translation
CONVENTIONS = ["gtsam", "pypose", "sophus", "symforce", SPLIT_BODY, EULER]


def _framework(backend: str) -> Any:
    return pytest.importorskip(backend)


def _xp(backend: str) -> Any:
    if backend == "torch":
        return pytest.importorskip("torch")
    pytest.importorskip("jax")
    import jax.numpy as jnp

    return jnp


def _pose(rng: np.random.Generator, angle: float, trans: float = 1.0) -> np.ndarray:
    axis = rng.normal(size=3)
    xi = np.concatenate([angle * axis / np.linalg.norm(axis), trans * rng.normal(size=3)])
    return lb.lie.se3.exp(xi)


def _values(poses: dict[int, np.ndarray]) -> Any:
    v = gtsam.Values()
    for k, T in poses.items():
        v.insert(k, gtsam.Pose3(T))
    return v


def _linear(factor: Any, values: Any) -> tuple[np.ndarray, np.ndarray]:
    A, b = factor.linearize(values).jacobian()
    return np.asarray(A), np.asarray(b)


# ---------------------------------------------------------------------------- BetweenFactorPose3
def _between_cases() -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    rng = np.random.default_rng(7)
    cases = []
    for angle, trans in [(0.3, 1.0), (2.5, 3.0), (1e-3, 30.0)]:
        Xi, Xj = _pose(rng, 1.2, 2.0), _pose(rng, 0.7, 5.0)
        Z = np.linalg.inv(Xi) @ Xj @ _pose(rng, angle, 0.1 * trans)
        cases.append((Xi, Xj, Z))
    Xi, Xj = _pose(rng, 1.0), _pose(rng, 2.0)
    cases.append((Xi, Xj, np.linalg.inv(Xi) @ Xj))  # zero residual: Log and exp at 0
    return cases


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("convention", CONVENTIONS, ids=lambda c: getattr(c, "name", c))
def test_between_factor_equals_gtsams_error_and_jacobians(backend: str, convention: Any) -> None:
    _framework(backend)
    sigmas = np.array([0.01, 0.02, 0.03, 0.1, 0.2, 0.3])
    noise = gtsam.noiseModel.Diagonal.Sigmas(sigmas)
    for Xi, Xj, Z in _between_cases():
        values = _values({1: Xi, 2: Xj})
        mine = lb.gtsam.autodiff_factor(
            example.BETWEEN[backend], [1, 2], noise, convention, backend, data=(Z,)
        )
        ref = gtsam.BetweenFactorPose3(1, 2, gtsam.Pose3(Z), noise)
        np.testing.assert_allclose(
            mine.unwhitenedError(values), ref.unwhitenedError(values), rtol=0, atol=1e-9
        )
        (A, b), (A_ref, b_ref) = _linear(mine, values), _linear(ref, values)
        # whitened: A = R·J; compare the unwhitened Jacobians (J = σ·A, row by row)
        np.testing.assert_allclose(sigmas[:, None] * A, sigmas[:, None] * A_ref, atol=1e-9)
        np.testing.assert_allclose(sigmas * b, sigmas * b_ref, atol=1e-9)


# ---------------------------------------------------------------------------- finite differences
def _transfer(xp: Any) -> Any:
    """A three-key residual: the point ``p`` of frame c seen from frame a, minus ``q``."""

    def residual(Xa: Any, Xb: Any, Xc: Any, p: Any, q: Any) -> Any:
        T = example.se3_inverse(Xa, xp) @ Xb @ Xc
        return T[:3, :3] @ p + T[:3, 3] - q

    return residual


_TRANSFER: dict[str, Any] = {}


def _central_differences(factor: Any, poses: dict[int, np.ndarray], h: float = 1e-6) -> np.ndarray:
    """``∂e/∂ξ`` through GTSAM's own ``Pose3.retract``, columns key by key."""
    cols = []
    for k in poses:
        for n in range(6):
            d = np.zeros(6)
            d[n] = h
            plus, minus = dict(poses), dict(poses)
            plus[k] = gtsam.Pose3(poses[k]).retract(d).matrix()
            minus[k] = gtsam.Pose3(poses[k]).retract(-d).matrix()
            e_p = factor.unwhitenedError(_values(plus))
            e_m = factor.unwhitenedError(_values(minus))
            cols.append((e_p - e_m) / (2 * h))
    return np.stack(cols, axis=1)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("convention", ["pypose", "symforce", "ceres_pose"])
def test_jacobians_match_central_differences_through_gtsams_retract(
    backend: str, convention: str
) -> None:
    xp = _xp(backend)
    fn = _TRANSFER.setdefault(backend, _transfer(xp))
    rng = np.random.default_rng(3)
    poses = {10: _pose(rng, 0.9, 2.0), 11: _pose(rng, 2.0, 1.0), 12: _pose(rng, 0.4, 3.0)}
    p, q = np.array([1.0, -2.0, 0.5]), np.array([0.3, 0.1, -0.2])
    factor = lb.gtsam.autodiff_factor(fn, list(poses), np.eye(3), convention, backend, data=(p, q))
    A, _ = _linear(factor, _values(poses))  # unit covariance: A = J
    np.testing.assert_allclose(A, _central_differences(factor, poses), atol=1e-7)


# ---------------------------------------------------------------------------- d = 0
def test_exp_derivative_at_zero_is_finite_not_nan() -> None:
    """Regression: ``sin θ / θ`` with ``θ = ‖ω‖`` has a NaN derivative at ω = 0.

    The Jacobian of a residual at an identity pose goes through the retraction's derivative at
    ``d = 0`` exactly; the naive formula (as in the pypose/kornia NaN-gradient reports) gives NaN
    there, the factor must give the generators.
    """
    torch = pytest.importorskip("torch")
    from torch.func import jacfwd

    def naive(w: Any) -> Any:
        th = torch.linalg.norm(w)
        return torch.sin(th) / th * w

    assert torch.isnan(jacfwd(naive)(torch.zeros(3, dtype=torch.float64))).any()

    def entries(X: Any) -> Any:
        return X[:3, :].reshape(-1)

    I4 = np.eye(4)
    for convention in ["gtsam", "pypose", "symforce"]:
        factor = lb.gtsam.autodiff_factor(entries, [0], np.eye(12), convention, "torch")
        A, _ = _linear(factor, _values({0: I4}))
        assert np.isfinite(A).all()
        np.testing.assert_allclose(A, _central_differences(factor, {0: I4}), atol=1e-8)


# ---------------------------------------------------------------------------- optimization
def _pose_graph(n: int = 25) -> tuple[dict[tuple[int, int], np.ndarray], Any, list[np.ndarray]]:
    rng = np.random.default_rng(5)
    truth = [np.eye(4)]
    step = lb.lie.se3.exp(np.array([0.05, 0.02, 0.25, 1.0, 0.1, 0.0]))
    for _ in range(n - 1):
        truth.append(truth[-1] @ step)
    edges = [(k, k + 1) for k in range(n - 1)] + [(0, n - 1), (2, n // 2), (4, n - 3)]
    Zs = {
        (i, j): np.linalg.inv(truth[i]) @ truth[j] @ lb.lie.se3.exp(0.02 * rng.normal(size=6))
        for i, j in edges
    }
    init = _values({k: T @ lb.lie.se3.exp(0.1 * rng.normal(size=6)) for k, T in enumerate(truth)})
    return Zs, init, truth


def _graphs(backend: str, convention: str, noise: Any) -> tuple[Any, Any, Any]:
    Zs, init, truth = _pose_graph()
    native, auto = gtsam.NonlinearFactorGraph(), gtsam.NonlinearFactorGraph()
    prior = gtsam.noiseModel.Isotropic.Sigma(6, 1e-3)
    for g in (native, auto):
        g.add(gtsam.PriorFactorPose3(0, gtsam.Pose3(truth[0]), prior))
    for (i, j), Z in Zs.items():
        native.add(gtsam.BetweenFactorPose3(i, j, gtsam.Pose3(Z), noise))
        auto.add(
            lb.gtsam.autodiff_factor(
                example.BETWEEN[backend], [i, j], noise, convention, backend, data=(Z,)
            )
        )
    return native, auto, init


def _max_pose_difference(a: Any, b: Any) -> float:
    return max(float(np.abs(a.atPose3(k).matrix() - b.atPose3(k).matrix()).max()) for k in a.keys())


@pytest.mark.parametrize("backend", BACKENDS)
def test_pose_graph_with_autodiff_factors_reaches_the_native_optimum(backend: str) -> None:
    _framework(backend)
    noise = gtsam.noiseModel.Diagonal.Sigmas(np.array([0.02, 0.02, 0.02, 0.1, 0.1, 0.1]))
    native, auto, init = _graphs(backend, "pypose", noise)
    split = _SplitGraph(auto, init, batch=True)
    assert split.n_batched == auto.size() - 1 and split.rest.size() == 1  # the native prior
    r_native = lb.gtsam.optimize(native, init)
    r_auto = lb.gtsam.optimize(auto, init)
    assert r_auto.final_error == pytest.approx(r_native.final_error, rel=1e-9)
    assert r_native.final_error < 1e-3 * r_native.initial_error  # it did optimize
    assert _max_pose_difference(r_native.values, r_auto.values) < 1e-8
    # GTSAM's own optimizer calls each factor's callback: the same optimum
    r_gtsam = gtsam.LevenbergMarquardtOptimizer(auto, init).optimize()
    assert _max_pose_difference(r_native.values, r_gtsam) < 1e-6


def test_isam2_with_autodiff_factors_tracks_the_native_one() -> None:
    _framework("torch")
    noise = gtsam.noiseModel.Isotropic.Sigma(6, 0.05)
    native, auto, init = _graphs("torch", "sophus", noise)
    estimates = []
    for graph in (native, auto):
        isam = lb.gtsam.ISAM2()
        isam.update(graph, init)
        isam.update()
        estimates.append(isam.calculate_estimate())
    assert _max_pose_difference(*estimates) < 1e-8


def test_batched_pass_calls_the_residual_once_per_evaluation_not_per_factor() -> None:
    pytest.importorskip("torch")
    calls = []

    def between(Xi: Any, Xj: Any, Z: Any) -> Any:
        calls.append(1)
        return example.between_torch(Xi, Xj, Z)

    Zs, init, _ = _pose_graph()
    graph = gtsam.NonlinearFactorGraph()
    graph.add(gtsam.PriorFactorPose3(0, gtsam.Pose3(), gtsam.noiseModel.Unit.Create(6)))
    noise = gtsam.noiseModel.Isotropic.Sigma(6, 0.05)
    for (i, j), Z in Zs.items():
        graph.add(lb.gtsam.autodiff_factor(between, [i, j], noise, "gtsam", "torch", data=(Z,)))
    calls.clear()
    result = lb.gtsam.optimize(graph, init)
    # one call per error evaluation and one per linearization, whatever the number of factors
    assert result.iterations >= 2
    assert len(calls) < len(Zs)
    assert len(calls) <= 4 * (result.iterations + 1)


def test_robust_noise_is_left_to_gtsam_and_matches_native() -> None:
    pytest.importorskip("torch")
    base = gtsam.noiseModel.Isotropic.Sigma(6, 0.05)
    robust = gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Huber.Create(1.0), base)
    native, auto, init = _graphs("torch", "sophus", robust)
    assert _SplitGraph(auto, init, batch=True).n_batched == 0  # weighting: GTSAM's own
    r_native, r_auto = lb.gtsam.optimize(native, init), lb.gtsam.optimize(auto, init)
    assert r_auto.final_error == pytest.approx(r_native.final_error, rel=1e-9)
    assert _max_pose_difference(r_native.values, r_auto.values) < 1e-8


def test_four_keys_are_evaluated_by_gtsam_through_the_callback() -> None:
    torch = pytest.importorskip("torch")

    def chain(Xa: Any, Xb: Any, Xc: Any, Xd: Any) -> Any:
        return example.se3_log(example.se3_inverse(Xa, torch) @ Xb @ Xc @ Xd, torch)

    rng = np.random.default_rng(1)
    poses = {k: _pose(rng, 0.5, 1.0) for k in range(4)}
    factor = lb.gtsam.autodiff_factor(chain, list(poses), np.eye(6), "barfoot", "torch")
    graph = gtsam.NonlinearFactorGraph()
    graph.add(factor)
    assert _SplitGraph(graph, _values(poses), batch=True).n_batched == 0
    A, _ = _linear(factor, _values(poses))
    np.testing.assert_allclose(A, _central_differences(factor, poses), atol=1e-7)


def test_residuals_are_not_kept_alive_by_the_kernel_cache() -> None:
    import gc
    import weakref

    torch = _torch()
    from liebridge.gtsam import autodiff

    class Offset:
        def __init__(self, c: float) -> None:
            self.c = c

        def residual(self, X: Any) -> Any:
            return X[:3, 3] - self.c

    def make(c: float) -> Any:
        def residual(X: Any) -> Any:
            return X[:3, 3] - c * torch.ones(3, dtype=X.dtype)

        return residual

    values = _values({0: np.eye(4)})
    for build in (lambda: make(1.0), lambda: Offset(1.0).residual):
        fn = build()  # not from a list: the list would hold it
        f = lb.gtsam.autodiff_factor(fn, [0], np.eye(3), "gtsam", "torch")
        np.testing.assert_allclose(f.unwhitenedError(values), -np.ones(3))
        A, _ = _linear(f, values)
        np.testing.assert_allclose(A[:, 3:], np.eye(3), atol=1e-12)  # ∂t/∂v = R = I
        probe = weakref.ref(getattr(fn, "__self__", fn))
        n = len(autodiff._KERNELS)
        del f, fn
        gc.collect()
        assert probe() is None and len(autodiff._KERNELS) < n


def test_jax_global_precision_is_left_as_it_was() -> None:
    jax = pytest.importorskip("jax")
    before = bool(jax.config.jax_enable_x64)
    noise = gtsam.noiseModel.Unit.Create(6)
    Z = np.eye(4)
    f = lb.gtsam.autodiff_factor(example.between_jax, [1, 2], noise, "gtsam", "jax", data=(Z,))
    f.linearize(_values({1: np.eye(4), 2: np.eye(4)}))
    assert bool(jax.config.jax_enable_x64) == before


# ---------------------------------------------------------------------------- bad input
def _ok(Xi: Any, Xj: Any) -> Any:
    return example.se3_log(example.se3_inverse(Xi, _torch()) @ Xj, _torch())


def _torch() -> Any:
    return pytest.importorskip("torch")


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"backend": "numpy"}, ValueError, r"backend: expected one of \('jax', 'torch'\)"),
        ({"convention": "ros_pose2"}, ValueError, r"convention: 'ros_pose2' .*longer vector"),
        ({"convention": "nope"}, ValueError, r"nope"),
        ({"keys": [1, 1]}, ValueError, r"key 1 appears twice"),
        ({"keys": []}, ValueError, r"keys: a factor needs at least one key"),
        ({"keys": 3}, TypeError, r"keys: expected a sequence"),
        ({"keys": [1, -2]}, ValueError, r"keys\[1\]"),
        ({"noise": "sigma"}, TypeError, r"noise: expected a gtsam noise model"),
        ({"noise": np.eye(5)}, ValueError, r"residual: _ok returned shape \(6,\); expected \(5,\)"),
        ({"noise": np.diag([1.0, 1, 1, 1, 1, 0])}, ValueError, r"noise"),
        ({"residual": 3}, TypeError, r"residual: expected a callable"),
        ({"data": (np.array([1.0, np.nan]),)}, ValueError, r"data\[0\]: not finite at index \[1\]"),
        ({"data": (np.eye(4),)}, TypeError, r"residual: _ok\(\*poses, \*data\) with 2 poses"),
    ],
)
def test_bad_input_names_the_argument(kwargs: dict[str, Any], error: type, match: str) -> None:
    _torch()
    args: dict[str, Any] = {
        "residual": _ok,
        "keys": [1, 2],
        "noise": np.eye(6),
        "convention": "gtsam",
        "backend": "torch",
    }
    args.update(kwargs)
    with pytest.raises(error, match=match):
        lb.gtsam.autodiff_factor(**args)


def test_non_finite_residual_in_the_batched_pass_names_keys_and_batch_index() -> None:
    torch = _torch()

    def blows_up(Xi: Any, Xj: Any, s: Any) -> Any:
        return torch.log(s) * (Xi[:3, 3] - Xj[:3, 3])

    graph = gtsam.NonlinearFactorGraph()
    for n, s in enumerate([1.0, 2.0, 0.0]):
        graph.add(
            lb.gtsam.autodiff_factor(
                blows_up, [n, n + 1], np.eye(3), "gtsam", "torch", data=(np.array(s),)
            )
        )
    values = _values({k: np.eye(4) for k in range(4)})
    with pytest.raises(FactorEvaluationError, match=r"keys \[2, 3\].*batch index 2 of 3"):
        lb.gtsam.optimize(graph, values)


# ---------------------------------------------------------------------------- the example
def test_example_runs_and_matches_gtsam() -> None:
    pytest.importorskip("torch")
    out = subprocess.run(
        [sys.executable, str(EXAMPLE), "--max-poses", "60", "--convention", "pypose"],
        capture_output=True,
        text=True,
        timeout=600,
        check=True,
    ).stdout
    dA = float(re.search(r"max \|ΔA\| = (\S+),", out).group(1))  # type: ignore[union-attr]
    errors = re.findall(r"-> (\S+), (\d+) iterations", out)
    dT = float(re.search(r"optima: (\S+)", out).group(1))  # type: ignore[union-attr]
    assert dA < 1e-9
    assert len(errors) == 2 and float(errors[0][0]) == pytest.approx(float(errors[1][0]), 1e-9)
    assert float(errors[0][0]) > 0  # a graph with loops: a nonzero optimum to agree on
    assert dT < 1e-6


def test_docs_section_runs() -> None:
    pytest.importorskip("torch")
    text = (Path(__file__).resolve().parents[1] / "docs" / "tensors.md").read_text("utf-8")
    start = text.index("## Autodiff factors for GTSAM")
    end = text.find("\n## ", start + 1)
    section = text[start : None if end < 0 else end]
    blocks = re.findall(r"^```python\n(.*?)^```", section, re.M | re.S)
    assert blocks
    namespace: dict[str, Any] = {"__name__": "docs_tensors_autodiff"}
    for n, code in enumerate(blocks):
        exec(compile(code, f"tensors.md[autodiff block {n}]", "exec"), namespace)


def test_bench_autodiff_quick_runs(tmp_path: Path) -> None:
    pytest.importorskip("jax")
    import json

    root = Path(__file__).resolve().parents[1]
    out = tmp_path / "autodiff.json"
    script = str(root / "benchmarks" / "bench_autodiff.py")
    subprocess.run(
        [sys.executable, script, "--quick", "--backends", "jax", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=600,
        check=True,
    )
    (row,) = json.loads(out.read_text())["rows"]
    assert row["backend"] == "jax" and row["factors"] > row["poses"]  # loops: a real optimum
    assert row["final_error"][0] == pytest.approx(row["final_error"][1], rel=1e-9)
    assert row["speedup_batched_vs_callbacks"] > 0 and row["ratio_batched_vs_native"] > 0
