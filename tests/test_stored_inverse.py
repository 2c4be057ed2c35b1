"""A convention that stores the inverse of liebridge's element (``Convention.stores="inverse"``).

Every group's coupled chart, both sides, every order: the retraction is the stored element's
update conjugated by inversion, ``local`` inverts it, and the first-order maps
(``to_canonical = −Ad_{X⁻¹}·M_Y(X⁻¹)``) and ``local_jacobian`` equal central differences through
the same retraction. The DPVO preset is the lietorch/PyPose update on ``T_cam_world``.
"""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest

import liebridge as lb
from liebridge.conventions import Convention, get, tangent_map
from liebridge.lie import GROUPS, se3

RNG_SEED = 20261127


def _canonical(group: str) -> Convention:
    g = GROUPS[group]
    order, chart = g.canonical_order, g.coupled_chart
    return Convention("canonical", "right", order, chart, "exp", "wxyz", group=group)


def _cases() -> list[tuple[str, str, str]]:
    out = []
    for name, g in GROUPS.items():
        if name not in ("so2", "se2", "so3", "se3", "sim3", "se23"):
            continue
        rotation_group = not g.vecs and g.scale is None
        orders = ("rot_first",) if rotation_group else ("rot_first", "trans_first")
        for side in ("right", "left"):
            for order in orders:
                out.append((name, side, order))
    return out


def _conv(group: str, side: str, order: str, stores: str = "inverse") -> Convention:
    g = GROUPS[group]
    return Convention(
        f"inv_{group}_{side}_{order}",
        side,
        order,
        g.coupled_chart,
        "exp",
        "wxyz",  # type: ignore[arg-type]
        group=group,
        stores=stores,  # type: ignore[arg-type]
    )


def _element(group: str, rng: np.random.Generator) -> np.ndarray:
    g = GROUPS[group]
    return np.asarray(g.exp(rng.uniform(-0.9, 0.9, g.dim)))


def _inv(group: str, X: np.ndarray) -> np.ndarray:
    return np.asarray(GROUPS[group].inverse(X))


def _fd(f, n: int, eps: float = 1e-6) -> np.ndarray:  # type: ignore[no-untyped-def]
    cols = []
    for j in range(n):
        e = np.zeros(n)
        e[j] = eps
        cols.append((f(e) - f(-e)) / (2 * eps))
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize(("group", "side", "order"), _cases())
def test_retract_is_the_stored_update_conjugated_by_inversion(
    group: str, side: str, order: str
) -> None:
    rng = np.random.default_rng(RNG_SEED)
    conv, plain = _conv(group, side, order), _conv(group, side, order, "pose")
    X = _element(group, rng)
    d = rng.uniform(-0.4, 0.4, conv.dim())
    Y = conv.retract(X, d)
    # written independently: the library's update applied to the stored inverse, inverted back
    want = _inv(group, plain.retract(_inv(group, X), d))
    assert np.abs(Y - want).max() < 1e-12
    assert np.abs(Y - plain.retract(X, d)).max() > 1e-3  # not the pose's update
    assert np.abs(conv.local(X, Y) - d).max() < 1e-10


@pytest.mark.parametrize(("group", "side", "order"), _cases())
def test_first_order_maps_equal_central_differences_through_the_retraction(
    group: str, side: str, order: str
) -> None:
    rng = np.random.default_rng(RNG_SEED + 1)
    conv, canon = _conv(group, side, order), _canonical(group)
    X = _element(group, rng)
    n = conv.dim()
    M = conv.to_canonical(X)
    M_fd = _fd(lambda d: canon.local(X, conv.retract(X, d)), n)
    assert np.abs(M - M_fd).max() < 1e-8, (M, M_fd)
    assert np.abs(conv.from_canonical(X) @ M - np.eye(n)).max() < 1e-12
    # the stored pose's map at X is a different one (the sign and the adjoint)
    assert np.abs(M - _conv(group, side, order, "pose").to_canonical(X)).max() > 0.5
    # local_jacobian: ∂ local(A, retract(B, δ)) / ∂δ at δ = 0
    A = _element(group, rng)
    B = conv.retract(A, rng.uniform(-0.3, 0.3, n))
    J_fd = _fd(lambda e: conv.local(A, conv.retract(B, e)), n)
    assert np.abs(conv.local_jacobian(A, B) - J_fd).max() < 1e-8


@pytest.mark.parametrize("group", ["so2", "se2", "so3", "se3", "sim3", "se23"])
def test_tangent_maps_to_every_coupled_convention_equal_differences(group: str) -> None:
    """``tangent_map`` both ways (the numpy path: the compiled grids are for stored poses)."""
    rng = np.random.default_rng(RNG_SEED + 2)
    X = _element(group, rng)
    for side, order in [(s, o) for (gname, s, o) in _cases() if gname == group]:
        src = _conv(group, side, order)
        for dst in (_canonical(group), _conv(group, "left", order, "pose"), src):
            n = src.dim()
            M_fd = _fd(lambda d, a=src, b=dst: b.local(X, a.retract(X, d)), n)
            assert np.abs(tangent_map(X, src, dst) - M_fd).max() < 1e-8
            M_back = _fd(lambda d, a=src, b=dst: a.local(X, b.retract(X, d)), n)
            assert np.abs(tangent_map(X, dst, src) - M_back).max() < 1e-8


def test_dpvo_on_t_world_cam_is_a_right_update_with_the_sign_flipped() -> None:
    """``retract(T, a) = T·Exp(−P·a)``, ``P``: (τ, φ) → (ω, v); droid_slam is the same preset."""
    dpvo = get("dpvo")
    assert get("droid_slam") is dpvo and get("DROID-SLAM") is dpvo
    rng = np.random.default_rng(3)
    T = se3.exp(rng.normal(size=6))
    a = rng.normal(size=6) * 0.3
    P = np.zeros((6, 6))
    P[:3, 3:] = P[3:, :3] = np.eye(3)
    assert np.abs(dpvo.retract(T, a) - T @ se3.exp(-P @ a)).max() < 1e-12
    # lietorch's own update Exp(a)·T_cam_world on the stored inverse
    T_cam_world = np.linalg.inv(T)
    lietorch_update = get("lietorch").retract(T_cam_world, a)
    assert np.abs(np.linalg.inv(dpvo.retract(T, a)) - lietorch_update).max() < 1e-12
    assert np.abs(tangent_map(T, "dpvo", "gtsam") + P).max() < 1e-12  # −P at every pose


def test_covariance_from_dpvo_to_gtsam_monte_carlo() -> None:
    """Σ_gtsam = M Σ_dpvo Mᵀ against samples pushed through the exact maps."""
    rng = np.random.default_rng(4)
    T = se3.exp(rng.normal(size=6))
    L = rng.normal(size=(6, 6)) * 0.02
    cov = L @ L.T + 1e-4 * np.eye(6)
    d = rng.multivariate_normal(np.zeros(6), cov, size=40000)
    xi = get("gtsam").local(np.broadcast_to(T, (len(d), 4, 4)), get("dpvo").retract(T, d))
    emp = np.cov(xi.T)
    got = lb.convert_covariance(cov, T, "dpvo", "gtsam")
    scale = np.sqrt(np.outer(np.diag(got), np.diag(got)))
    assert np.abs((emp - got) / scale).max() < 0.05
    back = lb.convert_covariance(got, T, "gtsam", "dpvo")
    assert np.abs(back - cov).max() < 1e-14


def test_stores_is_data_equality_description_pickle_and_fields() -> None:
    lt, dpvo = get("lietorch"), get("dpvo")
    assert dataclasses.replace(lt, name="dpvo", stores="inverse", source=dpvo.source) == dpvo
    assert lt != dataclasses.replace(lt, stores="inverse")
    assert dpvo.fields == (*lt.fields, "inverse") and "stores=inverse" in dpvo.describe()
    assert "stores" not in lt.describe()
    assert pickle.loads(pickle.dumps(dpvo)) == dpvo
    assert pickle.loads(pickle.dumps(dpvo)).retract(np.eye(4), np.ones(6) * 0.1).shape == (4, 4)
    assert lb.conventions.matching_presets(dpvo) == [dpvo]


def test_stores_rejects_bad_values_and_split_charts() -> None:
    with pytest.raises(ValueError, match="stores"):
        Convention("x", "left", "trans_first", "se3", "exp", "xyzw", stores="camera")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="coupled chart"):
        Convention("x", "left", "trans_first", "so3xr3_body", "exp", "xyzw", stores="inverse")


def test_batched_and_rotation_inputs() -> None:
    dpvo = get("dpvo")
    rng = np.random.default_rng(5)
    T = se3.exp(rng.normal(size=(2, 3, 6)))
    a = rng.normal(size=(2, 3, 6)) * 0.2
    Y = dpvo.retract(T, a)
    assert Y.shape == (2, 3, 4, 4)
    assert np.abs(dpvo.local(T, Y) - a).max() < 1e-10
    R = T[0, 0, :3, :3]
    w = np.array([0.1, -0.2, 0.3])
    assert np.abs(dpvo.retract(R, w) - R @ lb.lie.so3.exp(-w)).max() < 1e-12


@pytest.mark.parametrize("backend", ["torch", "jax"])
def test_stored_inverse_on_torch_and_jax_arrays_equals_numpy(backend: str) -> None:
    """The caller's array type comes back with the numpy path's values (float64 to 1e-12)."""
    rng = np.random.default_rng(6)
    X = se3.exp(rng.normal(size=(3, 6)))
    d = rng.normal(size=(3, 6)) * 0.3
    cov = np.eye(6) * 0.01 + 0.001
    dpvo = get("dpvo")
    if backend == "torch":
        torch = pytest.importorskip("torch")
        pytest.importorskip("array_api_compat")

        def to(a: np.ndarray):  # type: ignore[no-untyped-def]
            return torch.tensor(a, dtype=torch.float64)

        def back(a) -> np.ndarray:  # type: ignore[no-untyped-def]
            assert isinstance(a, torch.Tensor)
            return a.detach().numpy()
    else:
        jax = pytest.importorskip("jax")
        pytest.importorskip("array_api_compat")
        old = bool(jax.config.read("jax_enable_x64"))
        jax.config.update("jax_enable_x64", True)  # restored below
        import jax.numpy as jnp

        def to(a: np.ndarray):  # type: ignore[no-untyped-def]
            return jnp.asarray(a, dtype=jnp.float64)

        def back(a) -> np.ndarray:  # type: ignore[no-untyped-def]
            assert type(a).__module__.startswith("jax")
            return np.asarray(a)

    try:
        Y = dpvo.retract(to(X), to(d))
        assert np.abs(back(Y) - dpvo.retract(X, d)).max() < 1e-12
        assert np.abs(back(dpvo.local(to(X), Y)) - d).max() < 1e-12
        M = tangent_map(to(X), "dpvo", "gtsam")
        assert np.abs(back(M) - tangent_map(X, "dpvo", "gtsam")).max() < 1e-12
        S = lb.convert_covariance(to(cov), to(X), "dpvo", "theseus")
        assert np.abs(back(S) - lb.convert_covariance(cov, X, "dpvo", "theseus")).max() < 1e-12
    finally:
        if backend == "jax":
            jax.config.update("jax_enable_x64", old)


def test_the_command_line_says_what_dpvo_stores() -> None:
    import json
    import subprocess
    import sys

    def run(*args: str) -> str:
        cmd = [sys.executable, "-m", "liebridge.cli", "conventions", *args]
        return subprocess.run(cmd, capture_output=True, text=True, check=True).stdout

    one = run("droid_slam")
    assert "stores=inverse" in one and "on the stored Y = X⁻¹" in one
    rows = {r["name"]: r for r in json.loads(run("--format", "json"))}
    assert rows["dpvo"]["stores"] == "inverse" and "stores" not in rows["lietorch"]


@pytest.mark.parametrize("theta", [0.0, 1e-12, 1e-6, 2.0, np.pi - 1e-6, np.pi])
def test_dpvo_maps_at_edge_angles_and_30_m(theta: float) -> None:
    """Elements at θ = 0, 1e-12, near and exactly π, 30 m away; increments small and 3 rad."""
    dpvo, canon = get("dpvo"), _canonical("se3")
    axis = np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5])
    X = se3.exp(np.r_[theta * axis, 30.0, -30.0, 30.0])
    for d in (np.zeros(6), np.r_[0.1, 0.2, -0.3, 1e-12, 0.0, 0.0], np.r_[1.0, 0, 0, 0, 3.0, 0]):
        Y = dpvo.retract(X, d)
        assert np.abs(np.linalg.inv(Y) - get("lietorch").retract(np.linalg.inv(X), d)).max() < 1e-9
        assert np.abs(dpvo.local(X, Y) - d).max() < 1e-8
    M_fd = _fd(lambda e: canon.local(X, dpvo.retract(X, e)), 6, eps=1e-7)
    assert np.abs(dpvo.to_canonical(X) - M_fd).max() < 1e-6
