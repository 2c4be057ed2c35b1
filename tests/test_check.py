"""liebridge.check: numerical Jacobians through explicit charts, and the Jacobian assertion."""

from __future__ import annotations

import re
from collections.abc import Callable

import _strategies as S
import numpy as np
import pytest

from liebridge.check import assert_jacobian, numerical_jacobian
from liebridge.lie import se3, so3

pytestmark = pytest.mark.filterwarnings("error")


def _linear(A: np.ndarray, b: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    return lambda x: np.einsum("ij,...j->...i", A, x) + b


@pytest.mark.parametrize("batch", S.BATCH_SHAPES, ids=str)
def test_linear_map_is_exact_at_zero_with_power_of_two_step(batch: tuple[int, ...]) -> None:
    # f(±ε e_j) = ±ε A e_j + b; with ε a power of two and x = 0 every step of the difference is
    # exact in floating point, so the result is A to the last bit
    rng = np.random.default_rng(0)
    A, b = rng.normal(size=(4, 3)), np.zeros(4)
    J = numerical_jacobian(_linear(A, b), np.zeros((*batch, 3)), eps=2.0**-20)
    assert J.shape == (*batch, 4, 3)
    np.testing.assert_array_equal(J, np.broadcast_to(A, J.shape))


@pytest.mark.parametrize("batch", S.BATCH_SHAPES, ids=str)
def test_linear_map_at_generic_point(batch: tuple[int, ...]) -> None:
    # a linear map has no truncation error: only rounding of f(x ± ε e_j), ≈ eps_mach·|f|/ε
    # = 2e-16·|f|/1e-6; the bound 1e-9·(1 + |f|) leaves a factor ≥ 5 over that
    rng = np.random.default_rng(1)
    A, b = rng.normal(size=(5, 3)), rng.normal(size=5)
    x = rng.normal(size=(*batch, 3))
    J = numerical_jacobian(_linear(A, b), x)
    fmax = float(np.abs(_linear(A, b)(x)).max())
    np.testing.assert_allclose(J, np.broadcast_to(A, J.shape), rtol=0, atol=1e-9 * (1 + fmax))


@pytest.mark.parametrize("shape", [(3, 3), (4, 4), (2, 4, 4)], ids=str)
def test_vector_batch_shaped_like_a_matrix_is_read_as_vectors(shape: tuple[int, ...]) -> None:
    # without a retraction, a (..., 4, 4) or (..., 3, 3) array is a batch of 4- or 3-vectors, not
    # a pose or a rotation: each row gets its own Jacobian diag(2 x)
    x = np.arange(1.0, 1.0 + np.prod(shape)).reshape(shape)
    J = numerical_jacobian(lambda y: y**2, x)
    n = shape[-1]
    assert J.shape == (*shape, n)
    tol = 1e-9 * (1 + x.max() ** 2)  # rounding ≈ eps_mach·|f|/ε (the truncation error is 0)
    for idx in np.ndindex(*shape[:-1]):
        np.testing.assert_allclose(J[idx], np.diag(2 * x[idx]), rtol=0, atol=tol)


def test_group_maps_with_known_tangent_jacobians_batched() -> None:
    # On SE(3) with the right chart: f(T) = A·T has Jacobian I and f(T) = T·B has Ad(B⁻¹),
    # exactly (both are linear in tangent coordinates); batched over (2, 3) poses.
    rng = np.random.default_rng(2)
    T = S.random_poses(rng, (2, 3), max_norm=3.0)
    A, B = S.random_poses(rng, (2,), max_norm=3.0)

    def retract(X: np.ndarray, d: np.ndarray) -> np.ndarray:
        return X @ se3.exp(d)

    def local(Y0: np.ndarray, Y: np.ndarray) -> np.ndarray:
        return se3.log(se3.inverse(Y0) @ Y)

    J_left = numerical_jacobian(lambda X: A @ X, T, retract=retract, local=local)
    J_right = numerical_jacobian(lambda X: X @ B, T, retract=retract, local=local)
    assert J_left.shape == (2, 3, 6, 6)
    # only rounding: eps_mach·|T|/ε ≈ 1e-9
    assert_jacobian(J_left, np.broadcast_to(np.eye(6), J_left.shape), atol=1e-8, rtol=0)
    expected = np.broadcast_to(se3.adjoint(se3.inverse(B)), J_right.shape)
    assert_jacobian(J_right, expected, atol=1e-8, rtol=0)


def test_rotation_input_dimension_is_inferred() -> None:
    R = S.random_rotations(np.random.default_rng(3), (4,))
    J = numerical_jacobian(
        lambda X: X,
        R,
        retract=lambda X, d: X @ so3.exp(d),
        local=lambda Y0, Y: so3.log(np.swapaxes(Y0, -1, -2) @ Y),
    )
    assert J.shape == (4, 3, 3)
    assert_jacobian(J, np.broadcast_to(np.eye(3), J.shape), atol=1e-9, rtol=0)


def test_bad_out_local_string() -> None:
    with pytest.raises(ValueError, match="out_local"):
        numerical_jacobian(lambda x: x, np.zeros(3), out_local="manifold")


def test_mismatched_dim_for_vector_input() -> None:
    with pytest.raises(ValueError, match="dim"):
        numerical_jacobian(lambda x: x, np.zeros(3), dim=4)


def test_input_not_mutated() -> None:
    x = np.arange(3.0)
    x.setflags(write=False)
    numerical_jacobian(lambda y: y * 2, x)
    np.testing.assert_array_equal(x, np.arange(3.0))


# --------------------------------------------------------------------------- assert_jacobian


def _values_in(msg: str) -> tuple[float, float]:
    m = re.search(r"got (\S+), expected (\S+) ", msg)
    assert m, msg
    return float(m.group(1)), float(m.group(2))


def test_assert_jacobian_passes_within_tolerance() -> None:
    e = np.random.default_rng(4).normal(size=(6, 6))
    assert_jacobian(e + 5e-8, e, atol=1e-7, rtol=0)
    assert_jacobian(e * (1 + 5e-7), e, atol=0, rtol=1e-6)


def test_assert_jacobian_names_worst_entry() -> None:
    e = np.random.default_rng(5).normal(size=(6, 6))
    a = e.copy()
    a[0, 0] += 2e-6  # violates too, but less
    a[1, 2] += 1e-3
    with pytest.raises(AssertionError) as info:
        assert_jacobian(a, e, atol=1e-7, rtol=0, name="H1")
    msg = str(info.value)
    assert msg.startswith("H1: worst entry (1, 2):"), msg
    got, expected = _values_in(msg)
    assert got == pytest.approx(a[1, 2], rel=1e-11)
    assert expected == pytest.approx(e[1, 2], rel=1e-11)
    assert "|diff| = 0.001" in msg


def test_assert_jacobian_names_worst_entry_batched() -> None:
    e = np.random.default_rng(6).normal(size=(2, 3, 6, 6))
    a = e.copy()
    a[1, 0, 4, 5] += 0.5
    a[0, 2, 1, 1] += 0.1
    with pytest.raises(AssertionError, match=re.escape("worst entry (1, 0, 4, 5)")) as info:
        assert_jacobian(a, e)
    got, expected = _values_in(str(info.value))
    assert got == pytest.approx(a[1, 0, 4, 5], rel=1e-11)
    assert expected == pytest.approx(e[1, 0, 4, 5], rel=1e-11)


def test_assert_jacobian_uses_relative_tolerance() -> None:
    # the worst entry is the one with the largest excess over atol + rtol·|e|, not the largest
    # absolute difference
    e = np.array([[1000.0, 1.0]])
    a = np.array([[1000.0 + 5e-4, 1.0 + 1e-4]])
    with pytest.raises(AssertionError, match=re.escape("worst entry (0, 1)")):
        assert_jacobian(a, e, atol=0, rtol=1e-6)


@pytest.mark.parametrize("side", ["actual", "expected"])
def test_assert_jacobian_rejects_nan(side: str) -> None:
    e = np.eye(3)
    a = np.eye(3)
    (a if side == "actual" else e)[2, 1] = np.nan
    with pytest.raises(AssertionError, match=re.escape("worst entry (2, 1)")):
        assert_jacobian(a, e)


def test_assert_jacobian_shape_mismatch() -> None:
    with pytest.raises(AssertionError, match="shape"):
        assert_jacobian(np.eye(3), np.eye(6))
