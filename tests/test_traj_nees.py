"""NEES/ANEES: a consistent simulated estimator is inside its χ² bounds in every convention, through
an alignment; the same covariances read in the wrong convention are not.

Simulation: the estimate ``T_est`` (GTSAM's sphere2500 poses), anisotropic covariances ``Σ_i`` in
the estimator's convention, ``d_i ~ N(0, Σ_i)``, truth ``conv.retract(T_est, d_i)`` moved into
another world frame ``G`` (so ``--align se3`` is needed and the covariances must move with it).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from _traj_data import sphere_poses

from liebridge import conventions as C
from liebridge import traj
from liebridge.lie import se3

CONVENTIONS = ["gtsam", "sophus", "ros", "pypose", "symforce", "pytransform3d_global", "g2o_expmap"]


def _covariances(rng, n, conv, sig_t, sig_r):
    """Anisotropic, correlated 6×6 covariances in ``conv``'s order (rotation small)."""
    A = rng.normal(size=(n, 3, 3))
    Qr, _ = np.linalg.qr(A)
    Qt, _ = np.linalg.qr(rng.normal(size=(n, 3, 3)))
    L = np.zeros((n, 6, 6))
    rot = slice(0, 3) if conv.order == "rot_first" else slice(3, 6)
    tr = slice(3, 6) if conv.order == "rot_first" else slice(0, 3)
    L[:, rot, rot] = Qr * sig_r
    L[:, tr, tr] = Qt * sig_t
    L[:, tr, rot] = 0.3 * rng.normal(size=(n, 3, 3)) * 0.01  # some correlation
    cov = L @ np.swapaxes(L, -1, -2)
    return 0.5 * (cov + np.swapaxes(cov, -1, -2)), L


G_REF_EST = se3.exp([0.3, -0.1, 1.2, 5.0, -3.0, 2.0])
KNOWN = traj.Alignment("se3", G_REF_EST[:3, :3].copy(), G_REF_EST[:3, 3].copy())


def simulate(conv, n=800, seed=0, sig_t=(0.02, 0.08, 0.3), sig_r=(0.002, 0.006, 0.02)):
    rng = np.random.default_rng(seed)
    T_est = sphere_poses()[:n].copy()
    cov, L = _covariances(rng, n, conv, np.asarray(sig_t), np.asarray(sig_r))
    d = np.einsum("nij,nj->ni", L, rng.normal(size=(n, 6)))
    T_true = conv.retract(T_est, d)
    return G_REF_EST @ T_true, T_est, cov


def evaluate(T_ref, T_est, cov, conv, kind="se3"):
    A = KNOWN if kind == "known" else traj.align(T_ref, T_est, kind)
    return traj.nees(T_ref, A.apply(T_est), A.transform_covariance(T_est, cov, conv), conv)


@pytest.mark.parametrize("name", CONVENTIONS)
def test_consistent_estimator_inside_bounds(name):
    """Known alignment: isolates the covariance transport under it (ANEES ~ 6 ± 0.12)."""
    conv = C.get(name)
    T_ref, T_est, cov = simulate(conv)
    r = evaluate(T_ref, T_est, cov, conv, "known")
    assert r.consistent, (r.anees, r.anees_bounds)
    assert 0.92 < r.fraction_inside < 0.98


@pytest.mark.parametrize("name", ["gtsam", "sophus", "ros", "pypose"])
def test_consistent_estimator_inside_bounds_umeyama(name):
    """Alignment estimated from the same data (what the CLI does). Its own error is not in Σ, so
    the ANEES is biased up by O(σ_max²/(N σ_min²)) (a world-frame rotation error moves far poses
    by ``ω × t``); with moderate anisotropy it stays inside."""
    conv = C.get(name)
    T_ref, T_est, cov = simulate(conv, n=1500, sig_t=(0.05, 0.08, 0.12), sig_r=(1e-3, 2e-3, 3e-3))
    r = evaluate(T_ref, T_est, cov, conv, "se3")
    assert r.consistent, (r.anees, r.anees_bounds)


def test_bounds_are_chi2_quantiles():
    from scipy import stats

    lo, hi = traj.chi2_bounds(6, 100, 0.95)
    assert lo == pytest.approx(stats.chi2.ppf(0.025, 600) / 100)
    assert hi == pytest.approx(stats.chi2.ppf(0.975, 600) / 100)
    # Monte Carlo: the mean of 100 χ²(6) draws falls inside ~95 % of the time
    rng = np.random.default_rng(1)
    m = rng.chisquare(6, size=(4000, 100)).mean(axis=1)
    assert 0.93 < np.mean((m >= lo) & (m <= hi)) < 0.97


def _swap_wv(cov):
    P = np.zeros((6, 6))
    P[:3, 3:] = np.eye(3)
    P[3:, :3] = np.eye(3)
    return P @ cov @ P.T


@pytest.mark.parametrize("name", ["pypose", "ros", "g2o_expmap", "ceres_pose"])
def test_left_covariance_read_as_right_fails(name):
    conv = C.get(name)
    assert conv.side == "left"
    wrong = dataclasses.replace(conv, name=name + "_read_as_right", side="right")
    T_ref, T_est, cov = simulate(conv)
    assert evaluate(T_ref, T_est, cov, conv, "known").consistent
    bad = evaluate(T_ref, T_est, cov, wrong, "known")
    assert not bad.consistent
    assert bad.anees > 3 * bad.anees_bounds[1]
    assert not evaluate(T_ref, T_est, cov, wrong, "se3").consistent


@pytest.mark.parametrize("name", ["gtsam", "sophus", "ros"])
def test_omega_v_swapped_fails(name):
    conv = C.get(name)
    T_ref, T_est, cov = simulate(conv)
    assert evaluate(T_ref, T_est, cov, conv, "known").consistent
    bad = evaluate(T_ref, T_est, _swap_wv(cov), conv, "known")
    assert not bad.consistent
    assert bad.anees > 10 * bad.anees_bounds[1]


def test_alignment_without_moving_covariances_fails_for_left_convention():
    """Aligning the poses but not the covariances of a world-frame (left) estimator is wrong."""
    conv = C.get("pypose")
    T_ref, T_est, cov = simulate(conv)
    assert evaluate(T_ref, T_est, cov, conv, "known").consistent
    bad = traj.nees(T_ref, KNOWN.apply(T_est), cov, conv)
    assert not bad.consistent


def test_nees_invariant_under_correct_conversion():
    T_ref, T_est, cov = simulate(C.get("gtsam"), n=50)
    a = traj.nees(T_ref, T_est, cov, "gtsam")
    cov_s = C.convert_covariance(cov, T_est, "gtsam", "sophus")
    b = traj.nees(T_ref, T_est, cov_s, "sophus")
    # first order: the errors are small, so the NEES agree closely but not exactly
    np.testing.assert_allclose(b.nees, a.nees, rtol=0.05, atol=0.05)
    # for the exactly linear pair (reordering) they agree to rounding
    np.testing.assert_allclose(
        traj.nees(T_ref, T_est, _swap_wv(cov), "sophus").nees, a.nees, rtol=1e-9
    )


def test_bad_input():
    T_ref, T_est, cov = simulate(C.get("gtsam"), n=20)
    with pytest.raises(ValueError, match="19 covariances for 20 poses"):
        traj.nees(T_ref, T_est, cov[:19], "gtsam")
    c = cov.copy()
    c[7] = 0.0
    with pytest.raises(ValueError, match="pose 7"):
        traj.nees(T_ref, T_est, c, "gtsam")
    with pytest.raises(ValueError, match="shape"):
        traj.nees(T_ref, T_est, cov[:, :3, :3], "gtsam")
