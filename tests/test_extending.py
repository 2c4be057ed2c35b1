"""Groups liebridge does not ship, registered through the public API only, run every layer.

Two user groups, declared here from scratch (their kernels are written below, not borrowed):

* ``t3``: the translation group of ℝ³ as ``[[I, x], [0, 1]]`` — no rotation block;
* ``planar``: SE(2) re-declared under another name, tangent ``(vx, vy, ω)`` (the order of GTSAM's
  ``Pose2``, which holds it in a graph).

After ``lie.register`` and ``conventions.register`` (and ``gtsam.register_group`` for factors),
``Convention(group=...)``, ``tangent_map``, ``convert_covariance`` (checked against Monte Carlo),
``detect_convention(group=...)`` on a retraction written by hand, ``check.numerical_jacobian`` and
a between factor optimized by GTSAM all work, with no edit to liebridge.
"""

from __future__ import annotations

from typing import Any

import gtsam
import numpy as np
import pytest

import liebridge as lb
from liebridge import check, conventions, lie
from liebridge import gtsam as lbg

pytestmark = pytest.mark.filterwarnings("error")


# --------------------------------------------------------------------------- the translation group
def _t3_element(X: Any, name: str) -> np.ndarray:
    arr = np.asarray(X, dtype=np.float64)
    if arr.ndim < 2 or arr.shape[-2:] != (4, 4):
        raise ValueError(f"{name}: expected shape (..., 4, 4), got {arr.shape}")
    off = np.abs(arr[..., :3, :3] - np.eye(3)).max(axis=(-1, -2))
    off = np.maximum(off, np.abs(arr[..., 3, :] - [0, 0, 0, 1]).max(axis=-1))
    if not (off <= 1e-12).all():
        i = np.unravel_index(np.argmax(off), off.shape)
        raise ValueError(f"{name}: not a translation at batch index {i} (off by {off[i]:.3g})")
    return arr


def _t3_exp(x: np.ndarray) -> np.ndarray:
    out = np.zeros((*x.shape[:-1], 4, 4))
    out[..., :3, :3] = np.eye(3)
    out[..., :3, 3] = x
    out[..., 3, 3] = 1.0
    return out


def _t3_log(X: np.ndarray) -> np.ndarray:
    return np.array(X[..., :3, 3], dtype=np.float64)


def _t3_inverse(X: np.ndarray) -> np.ndarray:
    return _t3_exp(-X[..., :3, 3])


def _eye3(x: np.ndarray) -> np.ndarray:
    return np.broadcast_to(np.eye(3), (*x.shape[:-2], 3, 3)).copy()


def _eye3_t(x: np.ndarray) -> np.ndarray:
    return np.broadcast_to(np.eye(3), (*x.shape[:-1], 3, 3)).copy()


T3 = lie.Group(
    name="t3", dim=3, matrix=4, rot=None, vecs=(slice(0, 3),), cols=(3,), scale=None,
    element=_t3_element,
    kernels=lie.Kernels(
        exp=_t3_exp, log=_t3_log, inverse=_t3_inverse, adjoint=_eye3, jr_inv=_eye3_t,
        jl_inv=_eye3_t,
    ),
    probe=_t3_exp(np.array([1.0, -2.0, 3.0])), label="T(3)", tangent_doc="(x, y, z)",
)  # fmt: skip


# --------------------------------------------------------------------------- SE(2) by another name
def _planar_element(X: Any, name: str) -> np.ndarray:
    arr = np.asarray(X, dtype=np.float64)
    if arr.ndim < 2 or arr.shape[-2:] != (3, 3):
        raise ValueError(f"{name}: expected shape (..., 3, 3), got {arr.shape}")
    R = arr[..., :2, :2]
    off = np.abs(R @ np.swapaxes(R, -1, -2) - np.eye(2)).max(axis=(-1, -2))
    off = np.maximum(off, np.abs(arr[..., 2, :] - [0, 0, 1]).max(axis=-1))
    bad = ~(off <= 1e-9) | (np.linalg.det(R) <= 0)
    if bad.any():
        i = np.unravel_index(np.argmax(bad), bad.shape)
        raise ValueError(f"{name}: not a planar pose at batch index {i} (off by {off[i]:.3g})")
    return arr


def _rot2(th: np.ndarray) -> np.ndarray:
    c, s = np.cos(th), np.sin(th)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def _v(th: np.ndarray) -> np.ndarray:
    """``V(θ)`` with ``t = V(θ) v``: ``[[sin θ/θ, −(1 − cos θ)/θ], [(1 − cos θ)/θ, sin θ/θ]]``."""
    small = np.abs(th) < 1e-4
    t = np.where(small, 1.0, th)
    a = np.where(small, 1.0 - th**2 / 6.0, np.sin(t) / t)
    b = np.where(small, th / 2.0 - th**3 / 24.0, (1.0 - np.cos(t)) / t)
    return np.stack([np.stack([a, -b], -1), np.stack([b, a], -1)], -2)


def _planar_exp(xi: np.ndarray) -> np.ndarray:
    th = xi[..., 2]
    out = np.zeros((*xi.shape[:-1], 3, 3))
    out[..., :2, :2] = _rot2(th)
    out[..., :2, 2] = np.einsum("...ij,...j->...i", _v(th), xi[..., :2])
    out[..., 2, 2] = 1.0
    return out


def _planar_log(X: np.ndarray) -> np.ndarray:
    th = np.arctan2(X[..., 1, 0], X[..., 0, 0])
    v = np.linalg.solve(_v(th), X[..., :2, 2][..., None])[..., 0]
    return np.concatenate([v, th[..., None]], axis=-1)


def _planar_inverse(X: np.ndarray) -> np.ndarray:
    Rt = np.swapaxes(X[..., :2, :2], -1, -2)
    out = np.zeros(X.shape)
    out[..., :2, :2] = Rt
    out[..., :2, 2] = -np.einsum("...ij,...j->...i", Rt, X[..., :2, 2])
    out[..., 2, 2] = 1.0
    return out


def _planar_adjoint(X: np.ndarray) -> np.ndarray:
    """``Ad = [[R, (t_y, −t_x)ᵀ], [0, 1]]`` in ``(vx, vy, ω)``."""
    out = np.zeros(X.shape)
    out[..., :2, :2] = X[..., :2, :2]
    out[..., 0, 2], out[..., 1, 2] = X[..., 1, 2], -X[..., 0, 2]
    out[..., 2, 2] = 1.0
    return out


def _numeric_jr_inv(xi: np.ndarray) -> np.ndarray:
    """``∂ Log(Exp(ξ)·Exp(δ)) / ∂δ`` by central differences (a user's lazy but honest kernel)."""
    eps = 1e-6
    cols = []
    for k in range(3):
        d = np.zeros(3)
        d[k] = eps
        hi = _planar_log(_planar_exp(xi) @ _planar_exp(np.broadcast_to(d, xi.shape)))
        lo = _planar_log(_planar_exp(xi) @ _planar_exp(np.broadcast_to(-d, xi.shape)))
        cols.append((hi - lo) / (2 * eps))
    return np.stack(cols, axis=-1)


def _numeric_jl_inv(xi: np.ndarray) -> np.ndarray:
    return _numeric_jr_inv(-xi)


PLANAR = lie.Group(
    name="planar", dim=3, matrix=3, rot=slice(2, 3), vecs=(slice(0, 2),), cols=(2,), scale=None,
    element=_planar_element,
    kernels=lie.Kernels(
        exp=_planar_exp, log=_planar_log, inverse=_planar_inverse, adjoint=_planar_adjoint,
        jr_inv=_numeric_jr_inv, jl_inv=_numeric_jl_inv,
    ),
    probe=_planar_exp(np.array([1.5, -2.0, 0.8])), label="SE(2)'", tangent_doc="(vx, vy, ω)",
)  # fmt: skip


# registered at import, as a user's package would (replace=True: the module may be imported twice)
lie.register(T3, replace=True)
lie.register(PLANAR, replace=True)


def _conv(name: str, side: str, order: str, chart: str, group: lie.Group) -> conventions.Convention:
    return conventions.Convention(name, side, order, chart, "exp", "wxyz", group=group)  # type: ignore[arg-type]


USER_CONVENTIONS = [
    _conv("user_t3", "right", "rot_first", "t3", T3),
    _conv("user_planar", "right", "trans_first", "planar", PLANAR),  # Pose2's retract
    _conv("user_planar_left", "left", "rot_first", "planar", PLANAR),
    _conv("user_planar_split_world", "left", "trans_first", "split_world", PLANAR),
    _conv("user_planar_split_body", "right", "rot_first", "split_body", PLANAR),
]
for _c in USER_CONVENTIONS:
    conventions.register(_c, replace=True)
PLANAR_NAMES = [c.name for c in USER_CONVENTIONS if c.record is PLANAR]


def test_the_registry_knows_the_user_groups() -> None:
    assert lie.group("t3") is T3 and lie.GROUPS["planar"] is PLANAR
    assert PLANAR.charts == ("planar", "split_body", "split_world")
    assert T3.charts == ("t3",) and T3.rot_dim == 0
    assert conventions.get("user_planar_left").record is PLANAR
    assert "user_t3" in conventions.names("t3")
    with pytest.raises(ValueError, match="already exists"):
        conventions.register(_conv("gtsam", "right", "rot_first", "t3", T3))


def test_a_numpy_only_group_copies_tensors_to_the_host_and_refuses_a_gradient() -> None:
    """A user's group without ``array_api=True`` runs torch/JAX input on host copies (numpy out)
    and refuses, rather than silently cutting, a tensor that requires grad."""
    torch = pytest.importorskip("torch")
    X = PLANAR.exp(np.array([0.3, -0.2, 0.5]))
    ref = lb.tangent_map(X, "user_planar", "user_planar_left")
    out = lb.tangent_map(torch.tensor(X), "user_planar", "user_planar_left")
    assert isinstance(out, np.ndarray)
    np.testing.assert_array_equal(out, ref)
    with pytest.raises(TypeError, match=r"runs on numpy arrays only"):
        lb.tangent_map(torch.tensor(X, requires_grad=True), "user_planar", "user_planar_left")


def test_an_unregistered_group_and_a_chart_it_lacks_are_clear_errors() -> None:
    stray = lie.Group(
        name="stray", dim=3, matrix=4, rot=None, vecs=(slice(0, 3),), cols=(3,), scale=None,
        element=_t3_element, kernels=T3.kernels,
    )  # fmt: skip
    with pytest.raises(ValueError, match=r"not registered; call liebridge\.lie\.register"):
        _conv("x", "right", "rot_first", "stray", stray)
    with pytest.raises(ValueError, match="chart: expected one of \\('t3',\\)"):
        _conv("x", "right", "rot_first", "split_body", T3)
    with pytest.raises(ValueError, match="no rotation coordinates"):
        conventions.Convention("x", "right", "rot_first", "t3", "half_exp", "wxyz", group="t3")


def test_record_methods_validate_and_compute() -> None:
    X = PLANAR.exp([[1.0, 2.0, 0.5], [0.0, 0.0, 3.0]])
    np.testing.assert_allclose(PLANAR.log(X), [[1.0, 2.0, 0.5], [0.0, 0.0, 3.0]], atol=1e-12)
    np.testing.assert_allclose(
        PLANAR.interpolate(X[0], X[1], 0.0), X[0], atol=1e-12
    )  # τ = 0 gives X0
    np.testing.assert_allclose(PLANAR.interpolate(X[0], X[1], 1.0), X[1], atol=1e-12)
    np.testing.assert_allclose(PLANAR.act(X[0], [1.0, 0.0]), X[0, :2, :2] @ [1, 0] + X[0, :2, 2])
    with pytest.raises(ValueError, match="X: not a planar pose at batch index"):
        PLANAR.log(np.ones((3, 3)))
    with pytest.raises(ValueError, match="xi: expected shape"):
        PLANAR.exp([1.0, 2.0])


@pytest.mark.parametrize("src", PLANAR_NAMES)
@pytest.mark.parametrize("dst", PLANAR_NAMES)
def test_covariance_conversion_matches_monte_carlo(src: str, dst: str) -> None:
    X = PLANAR.exp([3.0, -1.0, 2.5])
    cov = np.diag([0.02, 0.01, 0.004])
    cov[0, 1] = cov[1, 0] = 0.005
    ut = lb.convert_covariance(cov, X, src, dst, method="unscented")
    mc = check.monte_carlo_covariance(cov, X, src, dst, n=40000)
    scale = np.sqrt(np.outer(np.diag(mc), np.diag(mc)))
    assert np.abs((ut - mc) / scale).max() < 0.05
    # first order: exact for a linear pair, else good while the spread is small (σ ≈ 0.01)
    small = cov * 0.01
    first = lb.convert_covariance(small, X, src, dst)
    mc = check.monte_carlo_covariance(small, X, src, dst, n=40000)
    scale = np.sqrt(np.outer(np.diag(mc), np.diag(mc)))
    assert np.abs((first - mc) / scale).max() < 0.05


def test_tangent_maps_are_derivatives_of_local_retract() -> None:
    X = PLANAR.exp([3.0, -1.0, 2.5])
    for a in PLANAR_NAMES:
        for b in PLANAR_NAMES:
            ca, cb = conventions.get(a), conventions.get(b)
            num = check.numerical_jacobian(lambda Y, cb=cb: cb.local(X, Y), X, retract=ca.retract)
            np.testing.assert_allclose(lb.tangent_map(X, a, b), num, atol=1e-8)


def test_local_jacobian_against_finite_differences_through_the_same_retraction() -> None:
    X, Y = PLANAR.exp([3.0, -1.0, 2.5]), PLANAR.exp([2.0, 0.5, 1.0])
    for name in PLANAR_NAMES:
        c = conventions.get(name)
        num = check.numerical_jacobian(lambda Z, c=c: c.local(X, Z), Y, retract=c.retract)
        np.testing.assert_allclose(c.local_jacobian(X, Y), num, atol=1e-7)


def test_detection_names_the_registered_convention_of_a_hand_written_retraction() -> None:
    def left_split_world(X: np.ndarray, d: np.ndarray) -> np.ndarray:
        """A user's update: translation added in the world frame, angle on the left."""
        out = X.copy()
        out[:2, 2] += d[:2]
        out[:2, :2] = _rot2(np.array(d[2])) @ X[:2, :2]
        return out

    found = lb.detect_convention(left_split_world, group="planar")
    assert found.name == "user_planar_split_world"
    found = lb.detect_convention(lambda X, d: X @ _t3_exp(d), group=T3)
    assert found.name == "user_t3"


def test_the_translation_group_converts_trivially_and_says_so() -> None:
    X = T3.exp([1.0, 2.0, 3.0])
    np.testing.assert_allclose(lb.tangent_map(X, "user_t3", "user_t3"), np.eye(3), atol=1e-15)
    cov = np.diag([1.0, 2.0, 3.0])
    np.testing.assert_allclose(lb.convert_covariance(cov, X, "user_t3", "user_t3"), cov)
    with pytest.raises(ValueError, match="cannot be converted"):
        lb.convert_covariance(cov, X, "user_t3", "user_planar")


def _register_gtsam() -> None:
    lbg.register_group(
        lbg.GtsamGroup(
            PLANAR, "Pose2",
            lambda X: gtsam.Pose2(X[0, 2], X[1, 2], np.arctan2(X[1, 0], X[0, 0])),
            lambda p: np.asarray(p.matrix(), dtype=np.float64),
            conventions.get("user_planar"), gtsam.BetweenFactorPose2, gtsam.PriorFactorPose2,
        )
    )  # fmt: skip
    lbg.register_group(
        lbg.GtsamGroup(
            T3, "Point3", lambda X: np.array(X[:3, 3]), lambda p: _t3_exp(np.asarray(p)),
            conventions.get("user_t3"), gtsam.BetweenFactorPoint3, gtsam.PriorFactorPoint3,
        )
    )  # fmt: skip


@pytest.mark.parametrize("name", [*PLANAR_NAMES, "user_t3"])
def test_a_between_factor_on_a_user_group_reaches_the_optimum(name: str) -> None:
    _register_gtsam()
    c = conventions.get(name)
    g = c.record
    truth = [g.probe, g.probe @ g.exp([0.5, -0.3, 0.2])]
    Z = g.inverse(truth[0]) @ truth[1]
    graph = gtsam.NonlinearFactorGraph()
    graph.add(lbg.prior(0, truth[0], np.eye(c.dim()) * 1e-6, c, native=False))
    graph.add(lbg.between(0, 1, Z, np.eye(c.dim()) * 1e-2, c, native=False))
    values = gtsam.Values()
    rec = lbg.gtsam_group(g)
    values.insert(0, rec.to_object(truth[0] @ g.exp([0.1, 0.1, 0.05])))
    values.insert(1, rec.to_object(truth[1] @ g.exp([-0.2, 0.1, -0.1])))
    result = gtsam.LevenbergMarquardtOptimizer(graph, values).optimize()
    for k in (0, 1):
        np.testing.assert_allclose(rec.element_at(result, k), truth[k], atol=1e-6)
    assert graph.error(result) < 1e-12


def test_custom_factor_jacobians_match_finite_differences() -> None:
    _register_gtsam()
    c = conventions.get("user_planar_split_world")
    Xi, Xj = PLANAR.exp([1.0, 2.0, 0.3]), PLANAR.exp([2.0, 1.0, 1.3])
    Z = PLANAR.exp([0.9, -1.1, 0.8])
    f = lbg.between(0, 1, Z, np.eye(3) * 0.01, c, native=False)
    values = gtsam.Values()
    rec = lbg.gtsam_group(PLANAR)
    values.insert(0, rec.to_object(Xi))
    values.insert(1, rec.to_object(Xj))
    lin = f.linearize(values)
    A = lin.jacobian()[0] * 0.1  # whitened by the 0.1 sigma
    hub = conventions.get("user_planar")  # Pose2's own perturbation X·Exp(vx, vy, ω)

    def e_of(Xi_: np.ndarray, Xj_: np.ndarray) -> np.ndarray:
        return c.local(Z, PLANAR.inverse(Xi_) @ Xj_)

    Ji = check.numerical_jacobian(
        lambda X: e_of(X, Xj), Xi, retract=hub.retract, out_local="euclidean"
    )
    Jj = check.numerical_jacobian(
        lambda X: e_of(Xi, X), Xj, retract=hub.retract, out_local="euclidean"
    )
    np.testing.assert_allclose(A, np.hstack([Ji, Jj]), atol=1e-6)
