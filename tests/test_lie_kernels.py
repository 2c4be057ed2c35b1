"""One harness for every kernel group: the properties each group's kernel must have.

Each group is described once by a :class:`Kernel` (its module, how to draw tangents and
elements, its right/left local maps and the scale of its translation-like part); every test
below runs over all of them. Library oracles (GTSAM, Pinocchio, mpmath) stay in the per-group
files (``test_lie_so3.py``, ``test_lie_se3.py``): they are what differs between groups.

Tolerances are in units of ``scale = max(1, ‖translation-like part‖)`` (exact for SO(3)):
every quantity that carries a translation is linear in it (see ``test_lie_se3.py``).

Also here (folded in from its twin file): Group-specific checks of so2, se2, sim3, se23: expm, π,
GTSAM, Pinocchio, spatialmath.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

import _strategies as S
import gtsam
import mpmath
import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from liebridge import lie
from liebridge.check import assert_jacobian, numerical_jacobian
from liebridge.lie import se2, se3, se23, sim3, so2, so3
from liebridge.lie.series import sim3_coeffs

pytestmark = pytest.mark.filterwarnings("error")

PI = math.pi
FD_TOL = 1e-8  # central differences, step 1e-6 (see test_lie_se3.py's docstring)
ID_TOL = 1e-12  # identities between kernel outputs
ROUNDTRIP_TOL = 1e-12

Maker = Callable[[np.random.Generator, tuple[int, ...]], np.ndarray]


@dataclass(frozen=True)
class Kernel:
    """What the harness needs to know about one group's kernel module."""

    name: str
    module: ModuleType
    dim: int
    tangent: Maker  # random tangents (rotation angle up to π), translations up to 30 m
    element: Maker  # random elements
    tangent_at_angles: Callable[[np.ndarray, np.random.Generator], np.ndarray]  # from rot vecs
    scale: Callable[[np.ndarray], np.ndarray]  # (..., dim) -> (...,) translation-like scale
    inverse: Callable[[np.ndarray], np.ndarray]
    #: public function -> makers of its arguments (every public function must be listed)
    public: dict[str, tuple[Callable[..., Any], list[Maker]]] = field(default_factory=dict)

    def right_local(self, Y0: np.ndarray, Y: np.ndarray) -> np.ndarray:
        return self.module.log(self.inverse(Y0) @ Y)

    def left_local(self, Y0: np.ndarray, Y: np.ndarray) -> np.ndarray:
        return self.module.log(Y @ self.inverse(Y0))


def _rot3(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    return S.random_rotations(rng, shape)


def _vec3(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    return S.random_rotvecs(rng, shape)


def _mat3(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    return rng.normal(size=(*shape, 3, 3))


def _twist(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    return S.random_twists(rng, shape)


def _pose(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    return S.random_poses(rng, shape)


def _point(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    return rng.uniform(-30.0, 30.0, size=(*shape, 3))


def _alg4(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    X = np.zeros((*shape, 4, 4))
    X[..., :3, :] = rng.normal(size=(*shape, 3, 4))
    return X


def _tau(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    return rng.uniform(-0.5, 1.5, size=shape)


def _so3_inverse(R: np.ndarray) -> np.ndarray:
    return np.swapaxes(R, -1, -2)


SO3 = Kernel(
    name="so3",
    module=so3,
    dim=3,
    tangent=_vec3,
    element=_rot3,
    tangent_at_angles=lambda w, rng: w,
    scale=lambda w: np.ones(w.shape[:-1]),
    inverse=_so3_inverse,
    public={
        "hat": (so3.hat, [_vec3]),
        "vee": (so3.vee, [_mat3]),
        "exp": (so3.exp, [_vec3]),
        "log": (so3.log, [_rot3]),
        "jr": (so3.jr, [_vec3]),
        "jl": (so3.jl, [_vec3]),
        "jr_inv": (so3.jr_inv, [_vec3]),
        "jl_inv": (so3.jl_inv, [_vec3]),
        "adjoint": (so3.adjoint, [_rot3]),
        "project": (so3.project, [_mat3]),
        "inverse": (so3.inverse, [_rot3]),
        "compose": (so3.compose, [_rot3, _rot3]),
        "act": (so3.act, [_rot3, _point]),
        "interpolate": (so3.interpolate, [_rot3, _rot3, _tau]),
    },
)
SE3 = Kernel(
    name="se3",
    module=se3,
    dim=6,
    tangent=_twist,
    element=_pose,
    tangent_at_angles=lambda w, rng: np.concatenate(
        [w, S.random_twists(rng, w.shape[:-1])[..., 3:]], axis=-1
    ),
    scale=lambda xi: np.maximum(1.0, np.linalg.norm(xi[..., 3:], axis=-1)),
    inverse=se3.inverse,
    public={
        "act": (se3.act, [_pose, _point]),
        "ad": (se3.ad, [_twist]),
        "adjoint": (se3.adjoint, [_pose]),
        "compose": (se3.compose, [_pose, _pose]),
        "exp": (se3.exp, [_twist]),
        "hat": (se3.hat, [_twist]),
        "interpolate": (se3.interpolate, [_pose, _pose, _tau]),
        "inverse": (se3.inverse, [_pose]),
        "jl": (se3.jl, [_twist]),
        "jl_inv": (se3.jl_inv, [_twist]),
        "jr": (se3.jr, [_twist]),
        "jr_inv": (se3.jr_inv, [_twist]),
        "log": (se3.log, [_pose]),
        "vee": (se3.vee, [_alg4]),
    },
)


# --------------------------------------------------------------------------- the other groups
def _rot2(th: np.ndarray) -> np.ndarray:
    c, s = np.cos(th), np.sin(th)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def _element_maker(name: str) -> Maker:
    """Elements assembled by hand (scipy rotations), not with the kernel under test."""

    def make(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
        n = int(np.prod(shape)) if shape else 1
        if name == "so2":
            X = _rot2(rng.uniform(-PI, PI, n))
        elif name == "se2":
            X = np.zeros((n, 3, 3))
            X[:, :2, :2] = _rot2(rng.uniform(-PI, PI, n))
            X[:, :2, 2] = rng.uniform(-30, 30, (n, 2))
            X[:, 2, 2] = 1.0
        else:
            k = {"sim3": 4, "se23": 5}[name]
            X = np.zeros((n, k, k))
            R = Rotation.random(n, random_state=rng).as_matrix()
            s = np.exp(rng.uniform(-1, 1, n)) if name == "sim3" else np.ones(n)
            X[:, :3, :3] = s[:, None, None] * R
            X[:, :3, 3:] = rng.uniform(-30, 30, (n, 3, k - 3))
            X[:, 3:, 3:] = np.eye(k - 3)
        return X.reshape((*shape, *X.shape[1:]))

    return make


def _planar_angles(w: np.ndarray) -> np.ndarray:
    """A signed angle per rotation vector (its norm, the sign of its z)."""
    return np.where(w[..., 2:3] < 0, -1.0, 1.0) * np.linalg.norm(w, axis=-1, keepdims=True)


def _tangent_from_angles(name: str) -> Callable[[np.ndarray, np.random.Generator], np.ndarray]:
    def make(w: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        b = w.shape[:-1]
        if name == "so2":
            return _planar_angles(w)
        if name == "se2":
            return np.concatenate([rng.uniform(-30, 30, (*b, 2)), _planar_angles(w)], axis=-1)
        if name == "sim3":
            return np.concatenate(
                [w, rng.uniform(-30, 30, (*b, 3)), rng.uniform(-1.5, 1.5, (*b, 1))], axis=-1
            )
        return np.concatenate([w, rng.uniform(-30, 30, (*b, 6))], axis=-1)  # se23

    return make


def _tangent_maker(name: str) -> Maker:
    at_angles = _tangent_from_angles(name)

    def make(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
        return at_angles(S.random_rotvecs(rng, shape), rng)

    return make


def _point_maker(dim: int) -> Maker:
    return lambda rng, shape: rng.uniform(-30.0, 30.0, size=(*shape, dim))


def _algebra_maker(module: ModuleType, tangent: Maker) -> Maker:
    return lambda rng, shape: module.hat(tangent(rng, shape))


def _generic_kernel(name: str, module: ModuleType, dim: int, point_dim: int, rot: slice) -> Kernel:
    tangent, element = _tangent_maker(name), _element_maker(name)

    def scale(xi: np.ndarray) -> np.ndarray:
        rest = np.delete(xi, np.arange(dim)[rot], axis=-1)
        return (
            np.maximum(1.0, np.abs(rest).max(axis=-1)) if rest.shape[-1] else np.ones(xi.shape[:-1])
        )

    args: dict[str, list[Maker]] = {
        "exp": [tangent],
        "jr": [tangent],
        "jl": [tangent],
        "jr_inv": [tangent],
        "jl_inv": [tangent],
        "hat": [tangent],
        "log": [element],
        "adjoint": [element],
        "inverse": [element],
        "compose": [element, element],
        "act": [element, _point_maker(point_dim)],
        "interpolate": [element, element, _tau],
        "vee": [_algebra_maker(module, tangent)],
    }
    return Kernel(
        name=name,
        module=module,
        dim=dim,
        tangent=tangent,
        element=element,
        tangent_at_angles=_tangent_from_angles(name),
        scale=scale,
        inverse=module.inverse,
        public={f: (getattr(module, f), args[f]) for f in module.__all__},
    )


SO2 = _generic_kernel("so2", so2, 1, 2, slice(0, 1))
SE2 = _generic_kernel("se2", se2, 3, 2, slice(2, 3))
SIM3 = _generic_kernel("sim3", sim3, 7, 3, slice(0, 3))
SE23 = _generic_kernel("se23", se23, 9, 3, slice(0, 3))

KERNELS = [SO3, SE3, SO2, SE2, SIM3, SE23]
PUBLIC_CASES = [(k, name) for k in KERNELS for name in sorted(k.public)]


def _ids(case: tuple[Kernel, str]) -> str:
    return f"{case[0].name}.{case[1]}"


# --------------------------------------------------------------------------- API shape


@pytest.mark.parametrize("kernel", KERNELS, ids=lambda k: k.name)
def test_every_public_function_is_covered(kernel: Kernel) -> None:
    assert set(kernel.public) == set(kernel.module.__all__)


@pytest.mark.parametrize("batch", S.BATCH_SHAPES, ids=str)
@pytest.mark.parametrize("case", PUBLIC_CASES, ids=_ids)
def test_batched_equals_elementwise(case: tuple[Kernel, str], batch: tuple[int, ...]) -> None:
    kernel, name = case
    fn, makers = kernel.public[name]
    rng = np.random.default_rng(len(name) + 7 * len(batch))
    S.assert_batched_equals_elementwise(fn, *(m(rng, batch) for m in makers), batch=batch)


@pytest.mark.parametrize("case", PUBLIC_CASES, ids=_ids)
def test_inputs_not_mutated_and_outputs_float64(case: tuple[Kernel, str]) -> None:
    kernel, name = case
    fn, makers = kernel.public[name]
    rng = np.random.default_rng(3)
    args = [m(rng, (4,)) for m in makers]
    copies = [a.copy() for a in args]
    for a in args:
        a.setflags(write=False)  # an in-place write would raise
    out = fn(*args)
    for a, c in zip(args, copies, strict=True):
        np.testing.assert_array_equal(a, c)
        assert not np.shares_memory(out, a), "output aliases the input"
    assert out.dtype == np.float64
    assert fn(*(a.astype(np.float32) for a in args)).dtype == np.float64


@pytest.mark.parametrize("kernel", KERNELS, ids=lambda k: k.name)
def test_integer_inputs_give_float64(kernel: Kernel) -> None:
    m = kernel.module
    n = kernel.element(np.random.default_rng(0), ()).shape[-1]
    assert m.exp(np.arange(kernel.dim) % 2).dtype == np.float64
    assert m.log(np.eye(n, dtype=int)).dtype == np.float64


# --------------------------------------------------------------------------- exp/log


@pytest.mark.parametrize("kernel", KERNELS, ids=lambda k: k.name)
def test_log_exp_roundtrip_at_edge_angles_batched(kernel: Kernel) -> None:
    rng = np.random.default_rng(11)
    w = S.edge_rotvecs(rng, 8, S.EDGE_ANGLES_BELOW_PI)
    xi = kernel.tangent_at_angles(w, rng)
    err = np.abs(kernel.module.log(kernel.module.exp(xi)) - xi).max(axis=-1)
    assert (err <= ROUNDTRIP_TOL * kernel.scale(xi)).all()


@pytest.mark.parametrize("kernel", KERNELS, ids=lambda k: k.name)
@settings(max_examples=40)
@given(seed=st.integers(0, 2**32 - 1))
def test_exp_log_roundtrip_everywhere(kernel: Kernel, seed: int) -> None:
    rng = np.random.default_rng(seed)
    X = kernel.element(rng, (8,))
    back = kernel.module.exp(kernel.module.log(X))
    scale = np.maximum(1.0, np.abs(X).max(axis=(-1, -2)))
    assert (np.abs(back - X).max(axis=(-1, -2)) <= ROUNDTRIP_TOL * scale).all()


@pytest.mark.parametrize("kernel", KERNELS, ids=lambda k: k.name)
def test_no_nan_at_any_angle(kernel: Kernel) -> None:
    rng = np.random.default_rng(9)
    th = np.concatenate([np.linspace(0.0, PI, 1001), np.asarray(S.EDGE_ANGLES)])
    w = th[:, None] * S.random_unit(rng, th.shape)
    w = np.concatenate([w, PI * np.asarray(S.PI_AXES), so3.log(S.pi_rotations())])
    xi = kernel.tangent_at_angles(w, rng)
    m = kernel.module
    X = m.exp(xi)
    for name in ("exp", "jr", "jl", "jr_inv", "jl_inv"):
        assert np.isfinite(getattr(m, name)(xi)).all(), name
    assert np.isfinite(m.log(X)).all() and np.isfinite(m.jr_inv(m.log(X))).all()


# --------------------------------------------------------------------------- Jacobians


def _fd_tangents(kernel: Kernel) -> np.ndarray:
    # every edge angle (FD of Exp has no branch cut: the output chart is taken at Exp(ξ)) and a
    # few angles beyond π, where the closed forms must still hold
    rng = np.random.default_rng(5)
    w = np.concatenate([S.edge_rotvecs(rng, 3), S.random_rotvecs(rng, (6,), 2 * PI - 0.5)])
    return kernel.tangent_at_angles(w, rng)


def _assert_fd(kernel: Kernel, analytic: np.ndarray, fd: np.ndarray, xi: np.ndarray, name: str):
    s = kernel.scale(xi)[..., None, None]
    assert_jacobian(analytic / s, fd / s, atol=FD_TOL, rtol=0, name=f"{kernel.name}.{name}")


@pytest.mark.parametrize("kernel", KERNELS, ids=lambda k: k.name)
def test_jr_jl_against_finite_differences(kernel: Kernel) -> None:
    m, xi = kernel.module, _fd_tangents(kernel)
    fd_r = numerical_jacobian(m.exp, xi, out_local=kernel.right_local)
    fd_l = numerical_jacobian(m.exp, xi, out_local=kernel.left_local)
    _assert_fd(kernel, m.jr(xi), fd_r, xi, "jr")
    _assert_fd(kernel, m.jl(xi), fd_l, xi, "jl")
    # the test can fail: at generic angles the right and left Jacobians are far apart (except in
    # SO(2), which is abelian: there jr = jl = 1)
    if kernel.name != "so2":
        generic = np.linalg.norm(xi[..., :3], axis=-1) > 0.1
        assert np.abs(m.jr(xi) - fd_l)[generic].max() > 1e-2


@pytest.mark.parametrize("kernel", KERNELS, ids=lambda k: k.name)
def test_jr_inv_jl_inv_against_finite_differences_of_log(kernel: Kernel) -> None:
    # d Log(X·Exp(δ))/dδ = Jr⁻¹(Log X), d Log(Exp(δ)·X)/dδ = Jl⁻¹(Log X); stay 1e-3 below the
    # branch cut at π so that the 1e-6 steps do not cross it
    rng = np.random.default_rng(6)
    angles = tuple(a for a in S.EDGE_ANGLES if a <= PI - 1e-3)
    m = kernel.module
    X = m.exp(kernel.tangent_at_angles(S.edge_rotvecs(rng, 3, angles), rng))
    xi = m.log(X)
    fd_r = numerical_jacobian(m.log, X, retract=lambda A, d: A @ m.exp(d), dim=kernel.dim)
    fd_l = numerical_jacobian(m.log, X, retract=lambda A, d: m.exp(d) @ A, dim=kernel.dim)
    _assert_fd(kernel, m.jr_inv(xi), fd_r, xi, "jr_inv")
    _assert_fd(kernel, m.jl_inv(xi), fd_l, xi, "jl_inv")


@pytest.mark.parametrize("kernel", KERNELS, ids=lambda k: k.name)
@settings(max_examples=40)
@given(seed=st.integers(0, 2**32 - 1))
def test_jacobian_identities(kernel: Kernel, seed: int) -> None:
    m = kernel.module
    xi = kernel.tangent(np.random.default_rng(seed), (8,))
    s = kernel.scale(xi)[:, None, None]
    eye = np.eye(kernel.dim)

    def close(a: np.ndarray, b: np.ndarray, power: int) -> None:
        assert (np.abs(a - b) <= ID_TOL * s**power).all()

    close(m.jl(xi), m.jr(-xi), 1)
    close(m.jl_inv(xi), m.jr_inv(-xi), 1)
    close(m.jl(xi), m.adjoint(m.exp(xi)) @ m.jr(xi), 2)
    close(m.jr_inv(xi) @ m.jr(xi), np.broadcast_to(eye, s.shape[:-2] + eye.shape), 2)
    close(m.jl_inv(xi) @ m.jl(xi), np.broadcast_to(eye, s.shape[:-2] + eye.shape), 2)


@pytest.mark.parametrize("kernel", KERNELS, ids=lambda k: k.name)
@settings(max_examples=40)
@given(seed=st.integers(0, 2**32 - 1))
def test_adjoint_conjugation_identity(kernel: Kernel, seed: int) -> None:
    # X·Exp(ξ)·X⁻¹ = Exp(Ad_X ξ)
    m, rng = kernel.module, np.random.default_rng(seed)
    X, xi = kernel.element(rng, (8,)), kernel.tangent(rng, (8,))
    eta = np.einsum("...ij,...j->...i", m.adjoint(X), xi)
    lhs = X @ m.exp(xi) @ kernel.inverse(X)
    s = kernel.scale(eta) * kernel.scale(xi) * np.maximum(1.0, np.abs(X).max(axis=(-1, -2)))
    assert (np.abs(lhs - m.exp(eta)).max(axis=(-1, -2)) <= ID_TOL * s).all()


# --------------------------------------------------------------------------- the group records

RECORD_CASES = [(k, lie.group(k.name)) for k in KERNELS]


def test_every_shipped_group_is_registered_once() -> None:
    assert set(lie.GROUPS) >= {k.name for k in KERNELS}  # (tests register their own too)
    for k in KERNELS:
        assert k.module.GROUP is lie.group(k.name)
        assert lie.group(lie.group(k.name)) is lie.group(k.name)


@pytest.mark.parametrize("case", RECORD_CASES, ids=lambda c: c[0].name)
def test_record_methods_are_the_module_functions(case: tuple[Kernel, lie.Group]) -> None:
    """Every kernel name exists in the module and on the record, with the same numbers."""
    kernel, g = case
    rng = np.random.default_rng(11)
    xi = kernel.tangent(rng, (5,))
    X, Y = kernel.element(rng, (5,)), kernel.element(rng, (5,))
    tau = _tau(rng, (5,))
    n = g.matrix - len(g.cols)
    x = rng.uniform(-30.0, 30.0, size=(5, n))
    args = {
        "exp": (xi,), "log": (X,), "inverse": (X,), "compose": (X, Y), "act": (X, x),
        "adjoint": (X,), "jr": (xi,), "jl": (xi,), "jr_inv": (xi,), "jl_inv": (xi,),
        "interpolate": (X, Y, tau),
    }  # fmt: skip
    assert set(args) == set(lie.KERNEL_NAMES)
    for name, a in args.items():
        np.testing.assert_allclose(
            getattr(g, name)(*a), getattr(kernel.module, name)(*a), rtol=1e-12, atol=1e-12
        )


@pytest.mark.parametrize("case", RECORD_CASES, ids=lambda c: c[0].name)
def test_record_layout_matches_the_exponential(case: tuple[Kernel, lie.Group]) -> None:
    """The record's slots say where Exp puts each block: rotation, vectors (columns), scale."""
    _, g = case
    assert g.probe is not None and g.probe.shape == (g.matrix, g.matrix)
    for sl, col in zip(g.vecs, g.cols, strict=True):
        xi = np.zeros(g.dim)
        xi[sl] = [0.1, -0.2, 0.3][: sl.stop - sl.start]
        E = g.exp(xi)
        k = g.matrix - len(g.cols)
        np.testing.assert_allclose(E[:k, col], xi[sl], atol=1e-15)  # a pure vector moves it
    if g.rot is not None:
        xi = np.zeros(g.dim)
        xi[g.rot] = 0.3
        E = g.exp(xi)
        k = g.matrix - len(g.cols)
        R = E[:k, :k]
        np.testing.assert_allclose(R @ R.T, np.eye(k), atol=1e-14)
        assert not np.allclose(R, np.eye(k))
    if g.scale is not None:
        xi = np.zeros(g.dim)
        xi[g.scale] = 0.4
        assert g.kernels.scale is not None
        np.testing.assert_allclose(g.kernels.scale(g.exp(xi)), np.exp(0.4), rtol=1e-14)


def test_record_refuses_a_second_group_under_a_shipped_name() -> None:
    with pytest.raises(ValueError, match="already registered"):
        lie.register(dataclasses.replace(lie.group("se2")), replace=True)
    with pytest.raises(ValueError, match="unknown group 'se4'"):
        lie.group("se4")


# --------------------------------------------------------------------------- lie_groups
# Group-specific checks of so2, se2, sim3, se23: expm, π, GTSAM, Pinocchio, spatialmath.
#
# Each group is described by its module, tangent dimension, where the rotation coordinates sit in
# the tangent, and an independent way to build elements (rotations from scipy, matrices assembled
# by hand), so a bug in the kernel cannot corrupt the inputs. Checks: ``exp`` against
# ``scipy.linalg.expm(hat ξ)``, fixed edge angles (0, 1e-12, near and exactly π), the Sim(3)
# coefficients against 50-digit mpmath, and the real libraries:
# GTSAM 4.3 (``Rot2``, ``Pose2``, ``Similarity3``, ``NavState``), Pinocchio's SE(2) Lie group and
# spatialmath's ``Twist2``. The properties every group shares (round trips, Jacobians against
# central differences through the group's own retraction, identities, batching, no mutation) run in
# the one harness, ``tests/test_lie_kernels.py``.
#
# Tolerances: ``GROUP_ID_TOL = 1e-11·scale`` for identities between kernel outputs and for oracles,
# ``GROUP_FD_TOL = 2e-8·scale`` for central differences with step 1e-6 (scale = max(1, ‖ξ‖, ‖t‖)).

PI = math.pi
GROUP_ID_TOL = 1e-11
GROUP_FD_TOL = 2e-8
EDGE = (0.0, 1e-12, 1e-8, 0.3, 0.5, 1.0, 3.0, PI - 1e-3, PI - 1e-9)


def _rot2_any(th: Any) -> np.ndarray:
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
            X = _rot2_any(rng.uniform(-PI, PI, n))
        elif self.name == "se2":
            X = np.zeros((n, 3, 3))
            X[:, :2, :2] = _rot2_any(rng.uniform(-PI, PI, n))
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
        np.testing.assert_allclose(
            E, scipy.linalg.expm(_hat(g, xi)), atol=GROUP_ID_TOL * _scale(xi, E)
        )
        np.testing.assert_allclose(_call(g, "log", E), xi, atol=GROUP_ID_TOL * _scale(xi))
        np.testing.assert_allclose(_call(g, "vee", _hat(g, xi)), xi, atol=0)
        X = g.element(rng)
        np.testing.assert_allclose(
            _call(g, "exp", _call(g, "log", X)), X, atol=GROUP_ID_TOL * _scale(X)
        )


@pytest.mark.parametrize("angle", EDGE)
@pytest.mark.parametrize("g", GROUPS, ids=IDS)
def test_edge_angles_round_trip(g: G, angle: float) -> None:
    rng = np.random.default_rng(2)
    xi = g.tangent(rng, angle=angle)
    E = _call(g, "exp", xi)
    np.testing.assert_allclose(E, scipy.linalg.expm(_hat(g, xi)), atol=GROUP_ID_TOL * _scale(xi, E))
    tol = GROUP_ID_TOL if angle < PI - 1e-6 else 2e-6  # log near π: the axis is ill-conditioned
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
    T[:2, :2] = _rot2_any(theta)
    T[:2, 2] = [float(x) for x in ref_t]
    np.testing.assert_allclose(se2.log(T), xi, rtol=0, atol=4e-16 * 2)
