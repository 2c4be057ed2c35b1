"""Euler-angle conventions on torch and JAX arrays (the SE(3) tensor engine's Euler branch)."""

from __future__ import annotations

import importlib.util
from collections.abc import Iterator

import numpy as np
import pytest

import liebridge as lb
from liebridge import arrays
from liebridge.conventions import Convention
from liebridge.lie import se3

HAS = {name: importlib.util.find_spec(name) is not None for name in ("torch", "jax")}
BACKENDS = [
    pytest.param("torch", marks=pytest.mark.skipif(not HAS["torch"], reason="torch extra")),
    pytest.param("jax", marks=pytest.mark.skipif(not HAS["jax"], reason="jax extra")),
]


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


def _make(backend: str, a: np.ndarray) -> object:
    if backend == "torch":
        import torch

        return torch.tensor(a)
    import jax.numpy as jnp

    return jnp.asarray(a)


EULER = [
    Convention(
        name=f"euler_{rot}_{order}_{chart}",
        side="right",
        order=order,
        chart=chart,
        rotation=rot,
        quat_order="wxyz",
    )
    for rot in ("euler_zyx", "euler_rpy")
    for order in ("rot_first", "trans_first")
    for chart in ("so3xr3_body", "so3xr3_world")
]


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("conv", EULER, ids=lambda c: c.name)
@pytest.mark.parametrize("rotation_only", [False, True])
def test_euler_conventions_same_values(
    backend: str, conv: Convention, rotation_only: bool, x64: None
) -> None:
    rng = np.random.default_rng(21)
    X = se3.exp(np.concatenate([0.5 * rng.normal(size=(6, 3)), rng.normal(size=(6, 3))], -1))
    d = 0.2 * rng.normal(size=(6, 6))
    if rotation_only:
        X, d = X[..., :3, :3], d[..., :3]
    Y = conv.retract(X, d)
    C = np.eye(d.shape[-1])
    B = lambda a: _make(backend, a)  # noqa: E731
    for out, ref in [
        (conv.retract(B(X), B(d)), Y),
        (conv.local(B(X), B(Y)), conv.local(X, Y)),
        (conv.local_jacobian(B(X), B(Y)), conv.local_jacobian(X, Y)),
        (conv.to_canonical(B(X)), conv.to_canonical(X)),
        (conv.from_canonical(B(X)), conv.from_canonical(X)),
        (lb.tangent_map(B(X), conv, "pypose"), lb.tangent_map(X, conv, "pypose")),
        (
            lb.convert_covariance(B(C), B(X), conv, "gtsam"),
            lb.convert_covariance(C, X, conv, "gtsam"),
        ),
    ]:
        assert arrays.backend_of(out) == backend
        np.testing.assert_allclose(np.asarray(arrays.to_numpy(out)), ref, rtol=0, atol=1e-12)


def test_euler_tangent_map_gradcheck_and_gimbal_lock_on_tensors(x64: None) -> None:
    torch = pytest.importorskip("torch")
    conv = EULER[0]
    xi = torch.tensor([0.3, -0.4, 0.2, 1.0, 2.0, -1.0], dtype=torch.float64)
    d = torch.zeros(6, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(
        lambda d: lb.tangent_map(se3.exp(xi) @ se3.exp(d), conv, "gtsam"), (d,)
    )
    G = torch.tensor(se3.exp(np.array([0.0, np.pi / 2, 0.0, 1.0, 2.0, 3.0])))
    with pytest.raises(ValueError, match=r"pitch = ±90°.*gimbal lock"):
        lb.tangent_map(G, conv, "gtsam")
