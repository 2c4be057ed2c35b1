"""Pose3 / Values batch conversion.

Also here (folded in from its twin file): Values glue for every group: Pose2, Rot2, Similarity3,
NavState (and Pose3/Rot3) round trips.
"""

from __future__ import annotations

import gtsam
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from liebridge.gtsam import glue
from liebridge.lie import se2, se3, se23, sim3, so2, so3


def random_poses(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3] = Rotation.random(n, random_state=rng).as_matrix()
    T[:, :3, 3] = rng.normal(scale=10.0, size=(n, 3))
    return T


def test_to_pose3_single_and_batch() -> None:
    T = random_poses(5, 0)
    p = glue.to_pose3(T[0])
    assert isinstance(p, gtsam.Pose3)
    assert np.array_equal(p.rotation().matrix(), T[0, :3, :3])
    assert np.array_equal(p.translation(), T[0, :3, 3])
    ps = glue.to_pose3(T)
    assert isinstance(ps, list) and len(ps) == 5
    assert all(np.array_equal(pi.matrix(), Ti) for pi, Ti in zip(ps, T, strict=True))


def test_from_pose3_single_and_sequence() -> None:
    ps = [
        gtsam.Pose3(gtsam.Rot3.Ypr(0.1 * k, -0.2, 0.3), np.array([k, 2.0, 3.0])) for k in range(4)
    ]
    one = glue.from_pose3(ps[2])
    assert one.shape == (4, 4) and np.array_equal(one, ps[2].matrix())
    many = glue.from_pose3(ps)
    assert many.shape == (4, 4, 4)
    assert np.array_equal(many, np.stack([p.matrix() for p in ps]))
    assert glue.from_pose3(iter(ps)).shape == (4, 4, 4)
    with pytest.raises(TypeError, match=r"p\[1\]: expected gtsam.Pose3"):
        glue.from_pose3([ps[0], gtsam.Rot3()])
    with pytest.raises(TypeError):
        glue.from_pose3(3.0)


def test_round_trip_is_bit_exact() -> None:
    T = random_poses(100, 1)
    assert np.array_equal(glue.from_pose3(glue.to_pose3(T)), T)
    keys = [gtsam.symbol("x", k) for k in range(100)]
    vals = glue.to_values(T, keys)
    assert vals.size() == 100
    assert np.array_equal(glue.from_values(vals, keys), T)


def test_non_rotation_rejected_where_gtsam_accepts_it() -> None:
    T = random_poses(3, 2)
    T[2, :3, :3] *= 1.001
    # GTSAM builds it without complaint ...
    gtsam.Pose3(T[2])
    # ... liebridge does not, and says where
    with pytest.raises(ValueError, match=r"T: not a rotation at batch index \(2,\)"):
        glue.to_pose3(T)
    with pytest.raises(ValueError, match=r"batch index \(2,\)"):
        glue.to_values(T, [0, 1, 2])
    R = np.diag([1.0, 1.0, -1.0])  # orthonormal but a reflection
    M = np.eye(4)
    M[:3, :3] = R
    with pytest.raises(ValueError, match="reflection"):
        glue.to_pose3(M)


def test_to_values_does_not_mutate_and_checks_keys() -> None:
    T = random_poses(3, 3)
    base = gtsam.Values()
    base.insert(100, gtsam.Point3(1.0, 2.0, 3.0))
    out = glue.to_values(T, [0, 1, 2], base)
    assert base.size() == 1  # the input Values is untouched
    assert out.size() == 4 and out.exists(100)
    assert isinstance(out.atPose3(1), gtsam.Pose3)
    with pytest.raises(ValueError, match="key 100 already exists"):
        glue.to_values(T, [0, 100, 2], base)
    with pytest.raises(ValueError, match="appears twice"):
        glue.to_values(T, [0, 1, 0])
    with pytest.raises(ValueError, match="expected 3 keys"):
        glue.to_values(T, [0, 1])
    with pytest.raises(TypeError, match=r"keys\[1\]"):
        glue.to_values(T, [0, 1.5, 2])
    with pytest.raises(ValueError, match=r"shape \(N, 4, 4\)"):
        glue.to_values(T[0], [0])
    with pytest.raises(TypeError, match=r"gtsam\.Values"):
        glue.to_values(T, [0, 1, 2], values={})


def test_from_values_order_repeats_and_errors() -> None:
    T = random_poses(6, 4)
    keys = [50, 7, 9, 1, 30, 2]  # not sorted: extractPose3 sorts, from_values must not
    vals = glue.to_values(T, keys)
    vals.insert(999, gtsam.Point3(0.0, 0.0, 0.0))
    want = [9, 50, 9, 2]
    got = glue.from_values(vals, want)
    ref = np.stack([vals.atPose3(k).matrix() for k in want])  # the per-key loop
    assert np.array_equal(got, ref)
    assert glue.from_values(vals, []).shape == (0, 4, 4)
    with pytest.raises(ValueError, match=r"keys\[1\]: key 8 is not in values"):
        glue.from_values(vals, [7, 8])
    with pytest.raises(TypeError, match=r"keys\[2\]: the value under key 999 is not a Pose3"):
        glue.from_values(vals, [7, 9, 999])
    with pytest.raises(TypeError, match=r"gtsam\.Values"):
        glue.from_values({}, [1])
    with pytest.raises(ValueError, match="uint64"):
        glue.from_values(vals, [-1])


def test_from_values_subset_of_large_pose_only_values() -> None:
    T = random_poses(40, 5)
    vals = glue.to_values(T, range(100, 140))
    for want in ([139, 100, 120], list(range(139, 99, -1)), [105] * 50):
        got = glue.from_values(vals, want)
        assert np.array_equal(got, T[np.array(want) - 100])
    with pytest.raises(ValueError, match=r"keys\[40\]: key 99 is not in values"):
        glue.from_values(vals, [*range(100, 140), 99])


def test_batch_path_layout_assumption() -> None:
    # extractPose3 rows: R row-major then t, in increasing key order (the batch path relies on it)
    vals = gtsam.Values()
    p5 = gtsam.Pose3(gtsam.Rot3.Ypr(0.3, 0.2, 0.1), np.array([1.0, 2.0, 3.0]))
    vals.insert(5, p5)
    vals.insert(2, gtsam.Pose3())
    rows = gtsam.utilities.extractPose3(vals)
    assert np.array_equal(rows[1, :9].reshape(3, 3), p5.rotation().matrix())
    assert np.array_equal(rows[1, 9:], [1.0, 2.0, 3.0])
    assert np.array_equal(rows[0, :9], np.eye(3).ravel())


# --------------------------------------------------------------------------- gtsam_glue_groups
# Values glue for every group: Pose2, Rot2, Similarity3, NavState (and Pose3/Rot3) round trips.

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
