"""Navigation states, bundles and S² on numpy, torch and JAX: same values, the caller's type.

numpy is the reference (itself checked against GTSAM, MTK and FAST-LIO's sources in
``tests/test_state_presets_fastlio_mola.py`` and ``tests/test_navigation_states.py``); torch and
JAX must give the same values (float64 to 1e-12 relative to the largest entry, float32 to 2e-5),
in the caller's array type and dtype, with gradients (``torch.autograd.gradcheck``,
``jax.test_util.check_grads``) that are finite where a naive norm is not, and the same error
messages as numpy for bad input.
"""

from __future__ import annotations

import importlib.util
import itertools
import zlib
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest

import liebridge as lb
from liebridge import arrays
from liebridge import conventions as C
from liebridge.conventions.navstate import nav_state
from liebridge.lie import s2, se3, so3

HAS = {name: importlib.util.find_spec(name) is not None for name in ("torch", "jax")}
FOREIGN = [
    pytest.param("torch", marks=pytest.mark.skipif(not HAS["torch"], reason="torch extra")),
    pytest.param("jax", marks=pytest.mark.skipif(not HAS["jax"], reason="jax extra")),
]
TOL64, TOL32 = 1e-12, 2e-5
G_LEN = 98090 / 10000  # FAST-LIO's gravity: MTK::S2<double, 98090, 10000, 1>


@pytest.fixture
def x64() -> Iterator[None]:
    """JAX in float64 for the test (restored after)."""
    if not HAS["jax"]:
        yield
        return
    import jax

    old = bool(jax.config.read("jax_enable_x64"))
    jax.config.update("jax_enable_x64", True)
    yield
    jax.config.update("jax_enable_x64", old)


class Backend:
    """Make arrays of one library and read them back."""

    def __init__(self, name: str, dtype: str = "float64") -> None:
        self.name, self.dtype = name, dtype

    def __call__(self, a: Any) -> Any:
        a = np.asarray(a, dtype=np.float64)
        if self.name == "numpy":
            return a.astype(self.dtype)
        if self.name == "torch":
            import torch

            return torch.tensor(a, dtype=getattr(torch, self.dtype))
        import jax.numpy as jnp

        return jnp.asarray(a, dtype=getattr(jnp, self.dtype))

    def check(self, out: Any) -> np.ndarray:
        """``out`` is of this backend (and dtype); return it as float64 numpy."""
        if self.name == "numpy":
            assert isinstance(out, np.ndarray)
        else:
            assert arrays.backend_of(out) == self.name, type(out)
            assert str(out.dtype).endswith(self.dtype), out.dtype
        return np.asarray(arrays.to_numpy(out), dtype=np.float64)


@pytest.fixture(params=FOREIGN)
def B(request: pytest.FixtureRequest, x64: None) -> Backend:
    return Backend(request.param)


def _close(out: np.ndarray, ref: np.ndarray, tol: float) -> None:
    scale = max(1.0, float(np.abs(ref).max()) if ref.size else 1.0)
    assert out.shape == ref.shape
    np.testing.assert_allclose(out, ref, rtol=0, atol=tol * scale)


# ----------------------------------------------------------------------------- states
#: Rotation angles of the states: 0, tiny, generic, near π and exactly π.
ANGLES = [0.0, 1e-9, 0.4, 2.0, np.pi - 1e-6, np.pi]
SHAPES = [(), (4,), (2, 3)]
AXIS = np.array([0.48, -0.6, 0.64])


def _rotations(n: int, rng: np.random.Generator, angles: list[float] = ANGLES) -> np.ndarray:
    a = np.resize(np.asarray(angles), n)
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=-1, keepdims=True)
    u[0] = AXIS
    return so3.exp(a[:, None] * u)


def _element(chart: C.Chart, n: int, rng: np.random.Generator, angles: list[float] = ANGLES) -> Any:
    """``n`` elements of a navigation chart or a bundle (rotations at ``angles``)."""
    X = nav_state(_rotations(n, rng, angles), 10 * rng.normal(size=(n, 3)), rng.normal(size=(n, 3)))
    if not isinstance(chart, C.Bundle):
        return X
    parts: dict[str, np.ndarray] = {}
    for name, b in chart.blocks:
        if name == "nav":
            parts[name] = X
        elif isinstance(b, C.Vector):
            parts[name] = 0.1 * rng.normal(size=(n, b.n))
        elif isinstance(b, C.Sphere):
            g = rng.normal(size=(n, 3))
            g[0] = [-1.0, 0.0, 0.0]  # MTK's S2_typ-1 fallback direction (and GTSAM's −x pole)
            parts[name] = b.length * g / np.linalg.norm(g, axis=-1, keepdims=True)
        else:  # an SE(3) block (FAST-LIO's extrinsic)
            T = se3.exp(rng.normal(size=(n, 6)))
            if n > 1:
                T[1, :3, :3] = _rotations(1, rng, [np.pi])[0]
            parts[name] = T
    return chart.assemble(**parts)


def _batched(X: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    k = int(np.prod(shape)) if shape else 1
    return X[:k].reshape((*shape, *X.shape[-2:])) if shape else X[0]


def _cov(n: int, rng: np.random.Generator) -> np.ndarray:
    A = 0.1 * rng.normal(size=(n, n))
    return A @ A.T + 1e-4 * np.eye(n)


def _pairs() -> list[tuple[str, str]]:
    """Every ordered pair of navigation-state presets that convert (same blocks)."""
    states = [*C.STATE_PRESETS, C.get("gtsam_navstate"), C.get("manif_se23")]
    return [(a.name, b.name) for a, b in itertools.product(states, states) if a.group == b.group]


PAIRS = _pairs()


def test_the_pairs_cover_every_navigation_state_preset() -> None:
    names = {a for a, _ in PAIRS}
    assert {c.name for c in C.STATE_PRESETS} <= names
    assert len(PAIRS) == 8 * 8 + 3 * 3 + 1  # the 15-dim states, the SE₂(3) charts, FAST-LIO


@pytest.mark.parametrize(("src", "dst"), PAIRS)
def test_tangent_map_and_covariance_of_every_pair_equal_numpys(
    B: Backend, src: str, dst: str
) -> None:
    rng = np.random.default_rng(zlib.crc32(f"{src}>{dst}".encode()))
    a = C.get(src)
    X = _element(a, 6, rng)
    n = a.dim()
    for shape in SHAPES:
        Xs = _batched(X, shape)
        cov = np.broadcast_to(_cov(n, rng), (*shape, n, n))
        M = lb.tangent_map(Xs, src, dst)
        S = lb.convert_covariance(cov, Xs, src, dst)
        _close(B.check(lb.tangent_map(B(Xs), src, dst)), M, TOL64)
        _close(B.check(lb.convert_covariance(B(cov), B(Xs), src, dst)), S, TOL64)
    # float32 at generic rotations (docs/tensors.md: float32 cannot place an angle near π)
    B32 = Backend(B.name, "float32")
    X32 = _element(a, 4, rng, [0.3, 1.0, 2.0])
    cov = _cov(n, rng)
    _close(B32.check(lb.tangent_map(B32(X32), src, dst)), lb.tangent_map(X32, src, dst), TOL32)
    S32 = B32.check(lb.convert_covariance(B32(cov), B32(X32), src, dst))
    _close(S32, lb.convert_covariance(cov, X32, src, dst), TOL32)


CHARTS = ["gtsam_combined", "gtsam_imu_keys", "basalt", "orbslam3", "fastlio_imu", "mola",
          "fastlio", "gtsam_navstate"]  # fmt: skip


@pytest.mark.parametrize("name", CHARTS)
def test_retract_local_and_jacobian_equal_numpys(B: Backend, name: str) -> None:
    rng = np.random.default_rng(7)
    c = C.get(name)
    X = _element(c, 6, rng)
    # JAX compiles each operation per shape on first use: one batch shape there (the pair test
    # above runs all three)
    for shape in SHAPES if B.name == "torch" else [(2, 3)]:
        Xs = _batched(X, shape)
        d = 0.3 * rng.normal(size=(*shape, c.dim()))
        Y = c.retract(Xs, d)
        _close(B.check(c.retract(B(Xs), B(d))), Y, TOL64)
        _close(B.check(c.local(B(Xs), B(Y))), c.local(Xs, Y), TOL64)
        _close(B.check(c.local_jacobian(B(Xs), B(Y))), c.local_jacobian(Xs, Y), TOL64)
        _close(B.check(c.to_canonical(B(Xs))), c.to_canonical(Xs), TOL64)
        _close(B.check(c.from_canonical(B(Xs))), c.from_canonical(Xs), TOL64)


def test_bundle_assemble_split_marginal_sub_element(B: Backend) -> None:
    rng = np.random.default_rng(8)
    F = C.FASTLIO
    X = _element(F, 3, rng)
    parts = F.split(X)
    Xb = F.assemble(**{k: B(v) for k, v in parts.items()})
    _close(B.check(Xb), X, 0.0)
    for k, v in F.split(Xb).items():
        _close(B.check(v), parts[k], 0.0)
    P = _cov(23, rng)
    keep = ["nav", "b_a", "b_g"]
    _close(B.check(F.marginal(B(P), keep)), F.marginal(P, keep), 0.0)
    _close(B.check(F.sub_element(B(X), keep)), F.sub_element(X, keep), 0.0)
    # a numpy part next to a tensor part: the tensor's type
    mixed = dict(parts, nav=B(parts["nav"]))
    _close(B.check(F.assemble(**mixed)), X, 0.0)


def test_split_returns_new_arrays_not_views_of_the_callers() -> None:
    torch = pytest.importorskip("torch")
    rng = np.random.default_rng(9)
    X = torch.tensor(_element(C.GTSAM_COMBINED, 2, rng))
    b_a = C.GTSAM_COMBINED.split(X)["b_a"]
    before = b_a.clone()
    X[..., 5, 8] += 1.0  # the caller writes into its element (b_a's column) afterwards
    assert torch.equal(b_a, before)


@pytest.mark.parametrize("state", [C.OPENVINS, C.VINS], ids=lambda c: c.name)
def test_cayley_states_retract_and_convert_on_tensors(state: Any) -> None:
    """OpenVINS/VINS (Cayley rotation coordinates): retract, local and maps on tensors = numpy."""
    torch = pytest.importorskip("torch")
    rng = np.random.default_rng(10)
    X = _element(state, 3, rng, [0.3])
    M = lb.tangent_map(torch.tensor(X, requires_grad=True), state.name, "gtsam_combined")
    assert M.requires_grad
    d = 0.1 * rng.normal(size=(3, 15))
    Y = state.retract(X, d)
    Yt = state.retract(torch.tensor(X), torch.tensor(d))
    np.testing.assert_allclose(Yt.numpy(), Y, rtol=0, atol=1e-12)
    np.testing.assert_allclose(
        state.local(torch.tensor(X), Yt).numpy(), state.local(X, Y), rtol=0, atol=1e-12
    )


# ----------------------------------------------------------------------------- S²
def _directions() -> np.ndarray:
    """Poles of every axis (GTSAM's and MTK's special directions), diagonals, generic."""
    rng = np.random.default_rng(11)
    poles = np.concatenate([np.eye(3), -np.eye(3)])
    diag = np.array([[1.0, 1.0, 1.0], [1.0, -1.0, 0.0]])
    diag /= np.linalg.norm(diag, axis=-1, keepdims=True)
    g = rng.normal(size=(4, 3))
    return np.concatenate([poles, diag, g / np.linalg.norm(g, axis=-1, keepdims=True)])


def _tangents(n: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Tangent vectors at ``n`` of length ``scale`` (0, tiny, generic, near π)."""
    E = s2.unit3_basis(n)
    d = np.stack([np.cos(np.arange(len(n))), np.sin(np.arange(len(n)))], axis=-1)
    return scale[:, None] * np.einsum("...ij,...j->...i", E, d)


S2_LENGTHS = np.resize(np.array([0.0, 1e-9, 1e-4, 0.7, 2.5, np.pi - 1e-5]), len(_directions()))


def test_s2_functions_equal_numpys(B: Backend) -> None:
    n = _directions()
    w = _tangents(n, S2_LENGTHS)
    m = s2.exp(n, w)
    cases: list[tuple[Callable[..., Any], tuple[Any, ...]]] = [
        (s2.unit_vector, (n,)),
        (s2.exp, (n, w)),
        (s2.log, (n, m)),
        (s2.dlog, (n, m)),
        (s2.unit3_basis, (n,)),
        (lambda x: s2.mtk_basis(x, 1, G_LEN), (n,)),  # n = −x: MTK's fallback
        (lambda x: s2.mtk_basis(x, 2), (n[n[:, 1] > -0.5],)),
        (lambda x: s2.mtk_basis(x, 3), (n[n[:, 2] > -0.5],)),
    ]
    for f, args in cases:
        ref = f(*args)
        _close(B.check(f(*(B(a) for a in args))), ref, TOL64)
        for shape in [(), (2, 3)]:
            k = int(np.prod(shape)) if shape else 1
            sub = [a[:k].reshape((*shape, 3)) if shape else a[0] for a in args]
            _close(B.check(f(*(B(a) for a in sub))), f(*sub), TOL64)
    # a numpy argument next to a tensor: the tensor's type
    _close(B.check(s2.log(n, B(m))), s2.log(n, m), TOL64)
    B32 = Backend(B.name, "float32")
    gen = (np.arange(len(n)) >= 6) & (S2_LENGTHS < 3.0)  # generic directions, not near π
    _close(B32.check(s2.log(B32(n[gen]), B32(m[gen]))), s2.log(n[gen], m[gen]), TOL32)


@pytest.mark.parametrize("basis", ["gtsam", "mtk_x", "mtk_y", "mtk_z"])
def test_sphere_chart_equals_numpys(B: Backend, basis: str) -> None:
    sph = C.Sphere(G_LEN, basis)
    n = _directions()
    if basis != "mtk_x":  # the other S2_typ have no valid basis at −axis (numpy refuses too)
        n = n[n[:, "xyz".index(basis[-1]) if basis != "gtsam" else 0] > -0.5]
    g = G_LEN * n
    d = np.stack([0.3 * np.cos(np.arange(len(n))), 0.2 * np.sin(np.arange(len(n)))], -1)
    h = sph.retract(g, d)
    _close(B.check(sph.retract(B(g), B(d))), h, TOL64 * G_LEN)
    _close(B.check(sph.local(B(g), B(h))), sph.local(g, h), TOL64)
    X, Y = (np.broadcast_to(np.eye(4), (len(n), 4, 4)).copy() for _ in range(2))
    X[:, :3, 3], Y[:, :3, 3] = g, h
    for f in ("_to_canonical", "_from_canonical"):
        _close(B.check(getattr(sph, f)(sph.element(B(X)))), getattr(sph, f)(X), TOL64)
    _close(B.check(sph._local_jacobian(B(X), B(Y))), sph._local_jacobian(X, Y), TOL64)


# ----------------------------------------------------------------------------- gradients
def _nav_grad_fns() -> dict[str, Callable[[Any, Any], Any]]:
    """Functions of an increment ``d`` at a state ``X0`` (perturbed by a chart's own retract)."""
    nav = C.get("gtsam_navstate")
    F = C.FASTLIO

    def cov(X0: Any, n: int) -> Any:
        A = arrays.like(0.1 * np.arange(n * n).reshape(n, n) / (n * n), X0) + arrays.eye(n, X0)
        return A @ arrays.mT(A)

    return {
        "NavChart mola → gtsam_navstate tangent_map": lambda X0, d: lb.tangent_map(
            nav.retract(X0, d), "mola", "gtsam_navstate"
        ),
        "fastlio_imu → openvins convert_covariance": lambda X0, d: lb.convert_covariance(
            cov(X0, 15), C.FASTLIO_IMU.retract(X0, d), "fastlio_imu", "openvins"
        ),
        "fastlio local (gravity at MTK's fallback)": lambda X0, d: F.local(X0, F.retract(X0, d)),
    }


def _grad_state(name: str, angle: float) -> np.ndarray:
    rng = np.random.default_rng(12)
    chart = {"NavChart": C.MOLA, "fastlio_imu": C.FASTLIO_IMU, "fastlio": C.FASTLIO}[
        name.split(" ")[0]
    ]
    return _element(chart, 1, rng, [angle])[0]


def _dim(name: str) -> int:
    return {"NavChart": 9, "fastlio_imu": 15, "fastlio": 23}[name.split(" ")[0]]


GRAD_ANGLES = {"identity": 0.0, "generic": 1.1}


@pytest.mark.parametrize("point", list(GRAD_ANGLES))
@pytest.mark.parametrize("fn", list(_nav_grad_fns()))
def test_torch_gradcheck_navigation(fn: str, point: str) -> None:
    torch = pytest.importorskip("torch")
    X0 = torch.tensor(_grad_state(fn, GRAD_ANGLES[point]))
    f = _nav_grad_fns()[fn]
    d = torch.zeros(_dim(fn), dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda d: f(X0, d), (d,))


@pytest.mark.parametrize("point", list(GRAD_ANGLES))
@pytest.mark.parametrize("fn", list(_nav_grad_fns()))
def test_jax_check_grads_navigation(fn: str, point: str, x64: None) -> None:
    jax = pytest.importorskip("jax")
    from jax.test_util import check_grads

    X0 = jax.numpy.asarray(_grad_state(fn, GRAD_ANGLES[point]))
    f = _nav_grad_fns()[fn]
    # through jax.jit: the same trace as eager, compiled once for the many evaluations (eager JAX
    # dispatches every operation of a 23-dimensional state: 3× slower here)
    g = jax.jit(lambda d: f(X0, d))
    check_grads(g, (jax.numpy.zeros(_dim(fn)),), order=1, modes=("fwd", "rev"))


POLES = {"north pole": [0.0, 0.0, 1.0], "south pole": [0.0, 0.0, -1.0], "−x": [-1.0, 0.0, 0.0]}


def _s2_grad_fns(n0: Any) -> dict[str, Callable[[Any], Any]]:
    """Functions of a 2-vector ``d`` (tangents ``E d`` stay tangent) or a rotation ``r`` of n."""
    E = s2.unit3_basis(n0)
    m0 = s2.exp(n0, arrays.matvec(E, arrays.like(np.array([0.3, -0.2]), n0)))
    return {
        "exp": lambda d: s2.exp(n0, arrays.matvec(E, d)),
        "log at the identity": lambda d: s2.log(n0, s2.exp(n0, arrays.matvec(E, d))),
        "log in n": lambda d: s2.log(so3.exp(arrays.concat([d, d[:1]], 0)) @ n0, m0),
        "mtk_basis": lambda d: s2.mtk_basis(s2.exp(n0, arrays.matvec(E, d)), 1, G_LEN),
    }


@pytest.mark.parametrize("pole", list(POLES))
@pytest.mark.parametrize("fn", ["exp", "log at the identity", "log in n", "mtk_basis"])
def test_s2_gradients_at_poles_and_the_identity(fn: str, pole: str, x64: None) -> None:
    if fn == "mtk_basis" and pole == "−x":
        pytest.skip("MTK's S2_Bx jumps at −x (its fallback): no derivative to check there")
    if not (HAS["torch"] or HAS["jax"]):
        pytest.skip("torch or jax extra")
    if HAS["torch"]:
        import torch

        n0 = torch.tensor(POLES[pole], dtype=torch.float64)
        d = torch.zeros(2, dtype=torch.float64, requires_grad=True)
        assert torch.autograd.gradcheck(_s2_grad_fns(n0)[fn], (d,))
    if HAS["jax"]:
        import jax
        from jax.test_util import check_grads

        nj = jax.numpy.asarray(POLES[pole])
        check_grads(_s2_grad_fns(nj)[fn], (jax.numpy.zeros(2),), order=1, modes=("fwd", "rev"))


def test_s2_log_gradient_at_m_equal_n_is_finite_where_a_naive_norm_gives_nan() -> None:
    """``∂ log(n, m)/∂m`` at ``m = n`` is ``I − n nᵀ``; ``d‖n × m‖`` at 0 is NaN if not guarded."""
    torch = pytest.importorskip("torch")
    n = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64)

    def naive(m: Any) -> Any:
        c = (n * m).sum()
        s = torch.sqrt((torch.linalg.cross(n, m) ** 2).sum())
        th = torch.atan2(s, c)
        k = torch.where(th < 1e-3, 1.0 + th**2 / 6.0, th / torch.where(th < 1e-3, 1.0, s))
        return k * (m - c * n)

    Jn = torch.autograd.functional.jacobian(naive, n.clone())
    assert not torch.isfinite(Jn).all()  # the bug this guards against is real
    J = torch.autograd.functional.jacobian(lambda m: s2.log(n, m), n.clone())
    assert torch.isfinite(J).all()
    np.testing.assert_allclose(J.numpy(), np.diag([1.0, 1.0, 0.0]), atol=1e-15)
    np.testing.assert_allclose(J.numpy(), s2.dlog(n.numpy(), n.numpy()), atol=1e-15)


# ----------------------------------------------------------------------------- tracing
def test_jax_jit_of_a_bundle_conversion(x64: None) -> None:
    jax = pytest.importorskip("jax")
    rng = np.random.default_rng(13)
    X = _element(C.FASTLIO, 4, rng, [0.3, 2.0])
    P = np.broadcast_to(_cov(23, rng), (4, 23, 23))
    keep = ["nav", "b_a", "b_g"]
    X15, P15 = C.FASTLIO.sub_element(X, keep), C.FASTLIO.marginal(P, keep)
    ref = lb.convert_covariance(P15, X15, "fastlio_imu", "gtsam_combined")
    f = jax.jit(lambda P, X: lb.convert_covariance(P, X, "fastlio_imu", "gtsam_combined"))
    _close(np.asarray(f(P15, X15)), ref, TOL64)
    g = jax.jit(lambda X, d: C.FASTLIO.local(X, C.FASTLIO.retract(X, d)))
    d = 0.1 * rng.normal(size=(4, 23))
    _close(np.asarray(g(X, d)), d, 1e-12)
    v = jax.vmap(lambda X, d: C.FASTLIO.local(X, C.FASTLIO.retract(X, d)))  # one element each
    _close(np.asarray(v(X, d)), d, 1e-12)


@pytest.mark.exhaustive  # torch.compile ≈ 15 s: CI compiles in test_tensors.py and _quat
def test_torch_compile_of_a_navigation_tangent_map() -> None:
    """MOLA's NavChart (its own order, world velocity) into GTSAM's NavState chart, compiled."""
    torch = pytest.importorskip("torch")
    rng = np.random.default_rng(14)
    X = _element(C.MOLA, 3, rng, [0.3, 2.0])
    f = torch.compile(lambda X: lb.tangent_map(X, "mola", "gtsam_navstate"))
    _close(f(torch.tensor(X)).numpy(), lb.tangent_map(X, "mola", "gtsam_navstate"), TOL64)


# ----------------------------------------------------------------------------- bad input
def _message(case: Callable[[Any], Any], T: Any) -> str:
    with pytest.raises(ValueError) as info:
        case(T)
    return str(info.value)


def test_bad_input_on_tensors_gives_numpys_error(B: Backend) -> None:
    rng = np.random.default_rng(15)
    F = C.FASTLIO
    X = _element(F, 3, rng, [0.3])
    bad_rot = X.copy()
    bad_rot[1, 0, 0] += 1e-3  # the nav block's rotation at batch index 1
    off = X.copy()
    off[2, 0, 12] = 1e-3  # an entry off the diagonal blocks at batch index 2
    grav = X.copy()
    grav[1, 17:20, 20] *= 1.01  # gravity (block rows 17-20) off its sphere at batch index 1
    vec = X.copy()
    vec[2, 5, 6] = 0.5  # the b_a block (rows 5-8) is not [[I, b], [0, 1]]
    cases: list[Callable[[Callable[[Any], Any]], Any]] = [
        lambda T: lb.tangent_map(T(bad_rot), "fastlio", "fastlio"),
        lambda T: lb.convert_covariance(T(np.eye(23)), T(off), "fastlio", "fastlio"),
        lambda T: F.retract(T(grav), T(np.zeros(23))),
        lambda T: F.local(T(X), T(vec)),
        lambda T: lb.convert_covariance(T(-np.eye(23)), T(X), "fastlio", "fastlio"),
        lambda T: s2.log(T([[0, 0, 1.0], [0, 1.0, 0]]), T([[0, 0, 1.0], [0, -1.0, 0]])),
        lambda T: s2.exp(T([[0, 0, 1.0], [0, 0, 1.0]]), T([[0.1, 0, 0], [0.1, 0, 0.2]])),
        lambda T: s2.unit_vector(T([[0, 0, 1.0], [0, 0, 1.1]])),
        lambda T: s2.mtk_basis(T([[0, 1.0, 0], [0, 0, -1.0]]), 3),
        lambda T: C.Sphere(G_LEN).local(T([0, 0, -G_LEN]), T([0, 0, G_LEN])),
        lambda T: C.GTSAM_COMBINED.assemble(
            nav=T(X[:, :5, :5]), b_a=T(np.zeros((3, 3))), b_g=T(np.zeros((2, 3)))
        ),
    ]
    for case in cases:
        assert _message(case, B) == _message(case, np.asarray)
    assert "batch index (1,)" in _message(cases[0], B)
    assert "batch index (2,)" in _message(cases[1], B)


def test_under_jit_shapes_are_checked_not_values(x64: None) -> None:
    jax = pytest.importorskip("jax")
    sph = C.Sphere(G_LEN)
    with pytest.raises(ValueError, match=r"expected shape \(\.\.\., 2\)"):
        jax.jit(sph.retract)(jax.numpy.asarray([0, 0, G_LEN]), jax.numpy.zeros(3))
    out = jax.jit(s2.log)(jax.numpy.asarray([0, 0, 1.0]), jax.numpy.asarray([0, 0, 2.0]))
    assert out.shape == (3,)  # not a unit vector: nothing can be checked while tracing


def test_nav_state_assembles_tensors(B: Backend) -> None:
    rng = np.random.default_rng(16)
    R, p, v = _rotations(4, rng), rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
    _close(B.check(nav_state(B(R), p, B(v))), nav_state(R, p, v), 0.0)
    _close(B.check(nav_state(B(R), B(p[0]), B(v))), nav_state(R, p[0], v), 0.0)


def test_the_other_conversions_of_a_state_equal_numpys(B: Backend) -> None:
    rng = np.random.default_rng(17)
    X = _element(C.FASTLIO_IMU, 3, rng)
    P, d, J = _cov(15, rng), 0.1 * rng.normal(size=(3, 15)), rng.normal(size=(2, 15))
    L = np.linalg.inv(P)
    cases: list[Callable[[Any], Any]] = [
        lambda T: lb.convert_tangent(T(d), T(X), "fastlio_imu", "basalt"),
        lambda T: lb.convert_tangent(T(d), T(X), "fastlio_imu", "basalt", exact=False),
        lambda T: lb.convert_information(T(L), T(X), "fastlio_imu", "gtsam_combined"),
        lambda T: lb.convert_jacobian(T(J), T(X), "fastlio_imu", "gtsam_combined"),
    ]
    for case in cases:
        _close(B.check(case(B)), case(np.asarray), TOL64)


def test_the_docs_section_runs() -> None:
    """The python block of docs/tensors.md's navigation-state section runs."""
    pytest.importorskip("torch")
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "tensors.md").read_text("utf-8")
    start = text.index("## Navigation states, bundles and S²")
    end = text.find("\n## ", start + 1)
    blocks = re.findall(r"^```python\n(.*?)^```", text[start:end], re.M | re.S)
    assert blocks
    for n, code in enumerate(blocks):
        exec(compile(code, f"tensors.md[navigation block {n}]", "exec"), {"__name__": "nav_md"})
