"""Convention.local_jacobian (used by every custom factor) against finite differences."""

import numpy as np
import pytest

import liebridge as lb
from liebridge import conventions as C
from liebridge.check import assert_jacobian, numerical_jacobian
from liebridge.lie import se3


def pair(seed, angle_scale=2.0, d_scale=0.4):
    rng = np.random.default_rng(seed)
    X = se3.exp(np.r_[rng.uniform(-angle_scale, angle_scale, 3), rng.uniform(-30, 30, 3)])
    return X, rng.uniform(-d_scale, d_scale, 6)


@pytest.mark.parametrize("conv", C.PRESETS, ids=lambda c: c.name)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_local_jacobian_pose(conv, seed):
    X, d = pair(seed)
    Y = conv.retract(X, d)
    J = conv.local_jacobian(X, Y)
    J_fd = numerical_jacobian(
        lambda Z: conv.local(X, Z), Y, retract=conv.retract, out_local="euclidean"
    )
    assert_jacobian(J, J_fd, atol=1e-7, name=conv.name)  # FD error ≲ 1e-9 at eps = 1e-6


@pytest.mark.parametrize("conv", C.PRESETS, ids=lambda c: c.name)
def test_local_jacobian_rotation(conv):
    X, d = pair(3)
    R, Y = X[:3, :3], conv.retract(X[:3, :3], d[:3])
    J_fd = numerical_jacobian(
        lambda Z: conv.local(R, Z), Y, retract=conv.retract, out_local="euclidean"
    )
    assert_jacobian(conv.local_jacobian(R, Y), J_fd, atol=1e-7, name=conv.name)


@pytest.mark.parametrize("conv", C.PRESETS, ids=lambda c: c.name)
def test_local_jacobian_in_gtsam_columns(conv):
    """∂ local(X, Y·Exp(δ))/∂δ (GTSAM's perturbation) = local_jacobian · tangent_map(Y, ...)."""
    X, d = pair(4)
    Y = conv.retract(X, d)
    J = conv.local_jacobian(X, Y) @ lb.tangent_map(Y, "gtsam", conv)
    J_fd = numerical_jacobian(
        lambda Z: conv.local(X, Z), Y, retract=C.GTSAM.retract, out_local="euclidean"
    )
    assert_jacobian(J, J_fd, atol=1e-7, name=conv.name)


def test_local_jacobian_is_identity_only_at_zero_residual():
    """J = I is the textbook approximation: exact at Y = X only (scales cancel in the own chart)."""
    X, d = pair(5)
    for conv in C.PRESETS:
        np.testing.assert_allclose(conv.local_jacobian(X, X), np.eye(6), atol=1e-12)
        Y = conv.retract(X, d)
        assert np.abs(conv.local_jacobian(X, Y) - np.eye(6)).max() > 1e-2, conv.name


def test_local_jacobian_batched():
    rng = np.random.default_rng(6)
    X = se3.exp(rng.normal(size=(4, 6)))
    d = rng.uniform(-0.3, 0.3, (4, 6))
    for conv in (C.G2O, C.BARFOOT, C.GTSAM_CAYLEY):
        Y = conv.retract(X, d)
        J = conv.local_jacobian(X, Y)
        for i in range(4):
            np.testing.assert_allclose(J[i], conv.local_jacobian(X[i], Y[i]), atol=1e-15)
