"""Values glue for every group: Pose2, Rot2, Similarity3, NavState (and Pose3/Rot3) round trips."""

from __future__ import annotations

import gtsam
import numpy as np
import pytest

from liebridge.gtsam import glue
from liebridge.lie import se2, se3, se23, sim3, so2, so3

KERNELS = {"se2": (se2, 3), "so2": (so2, 1), "sim3": (sim3, 7), "se23": (se23, 9), "so3": (so3, 3)}


@pytest.mark.parametrize("group", sorted(KERNELS))
def test_values_round_trip(group: str) -> None:
    kernel, dim = KERNELS[group]
    X = kernel.exp(np.random.default_rng(1).normal(size=(6, dim)))
    keys = [gtsam.symbol("x", k) for k in range(6)]
    vals = glue.to_values(X, keys, group=group)
    assert vals.size() == 6
    back = glue.from_values(vals, keys[::-1], group=group)
    np.testing.assert_allclose(back, X[::-1], rtol=0, atol=1e-15)


def test_similarity3_translation_is_converted_not_copied() -> None:
    """liebridge's [sR t; 0 1]: p ↦ sRp + t; GTSAM's Similarity3(R, t_g, s): p ↦ s(Rp + t_g)."""
    rng = np.random.default_rng(2)
    X = sim3.exp(rng.normal(size=(4, 7)))
    for Xk, S in zip(X, glue.to_gtsam(X, "sim3"), strict=True):
        p = rng.normal(size=3)
        np.testing.assert_allclose(S.transformFrom(p), Xk[:3, :3] @ p + Xk[:3, 3], atol=1e-13)
        s = np.cbrt(np.linalg.det(Xk[:3, :3]))
        np.testing.assert_allclose(S.translation(), Xk[:3, 3] / s, atol=1e-13)  # t_g = t / s
        np.testing.assert_allclose(S.matrix()[3, 3], 1.0 / s, rtol=1e-14)
        np.testing.assert_allclose(glue.from_gtsam(S, "sim3"), Xk, atol=1e-13)


def test_navstate_matrix_is_r_p_v() -> None:
    X = se23.exp(np.random.default_rng(3).normal(size=9))
    N = glue.to_gtsam(X, "se23")
    np.testing.assert_array_equal(N.position(), X[:3, 3])
    np.testing.assert_array_equal(N.velocity(), X[:3, 4])
    np.testing.assert_allclose(N.attitude().matrix(), X[:3, :3], atol=1e-15)


def test_pose2_from_gtsam_equals_its_matrix() -> None:
    P = gtsam.Pose2(1.0, -2.0, 0.7)
    np.testing.assert_array_equal(glue.from_gtsam(P, "se2"), P.matrix())
    np.testing.assert_allclose(glue.to_gtsam(P.matrix(), "se2").matrix(), P.matrix(), atol=1e-15)


def test_default_group_is_pose3_as_before() -> None:
    T = se3.exp(np.random.default_rng(4).normal(size=(3, 6)))
    vals = glue.to_values(T, [1, 2, 3])
    assert isinstance(vals.atPose3(1), gtsam.Pose3)
    np.testing.assert_allclose(glue.from_values(vals, [1, 2, 3]), T, atol=1e-15)


def test_an_so3_matrix_given_as_se2_is_one_clear_error() -> None:
    R = so3.exp(np.array([[0.1, 0.2, 0.3], [0.3, -0.2, 0.1]]))
    with pytest.raises(ValueError, match=r"T: not a valid SE\(2\) element at batch index \(0,\)"):
        glue.to_values(R, [1, 2], group="se2")


def test_a_nonpositive_scale_is_refused() -> None:
    X = np.eye(4)
    X[:3, :3] *= -1.0  # det < 0: s would be negative
    with pytest.raises(ValueError, match="X"):
        glue.to_gtsam(X, "sim3")


def test_wrong_value_type_and_missing_key_are_named() -> None:
    vals = glue.to_values(se2.exp(np.zeros((1, 3))), [7], group="se2")
    with pytest.raises(TypeError, match=r"keys\[0\]: the value under key 7 is not a NavState"):
        glue.from_values(vals, [7], group="se23")
    with pytest.raises(ValueError, match=r"keys\[1\]: key 8 is not in values"):
        glue.from_values(vals, [7, 8], group="se2")
    with pytest.raises(ValueError, match="group: expected one of"):
        glue.to_values(np.eye(3)[None], [1], group="pose2")
    with pytest.raises(TypeError, match=r"expected gtsam\.Pose2"):
        glue.from_gtsam(gtsam.Pose3(), "se2")
