"""KITTI per-segment errors against a line-by-line transcription of the devkit's loops, and the
statistics' definitions (population std) against numpy/statistics computed independently."""

from __future__ import annotations

import math
import statistics as pystats

import numpy as np
import pytest

from liebridge import traj
from liebridge.lie import se3


def _drive(n=1800, seed=0):
    """A car-like path, ~1 m per frame, and a drifting estimate of it."""
    rng = np.random.default_rng(seed)
    steps = np.zeros((n - 1, 6))
    steps[:, 2] = 0.02 * np.sin(np.arange(n - 1) / 40.0)  # yaw rate
    steps[:, 3] = 1.0 + 0.2 * np.sin(np.arange(n - 1) / 90.0)  # forward
    T = [np.eye(4)]
    E = [np.eye(4)]
    for k in range(n - 1):
        T.append(T[-1] @ se3.exp(steps[k]))
        noisy = steps[k] + rng.normal(scale=[1e-3, 1e-3, 2e-3, 5e-3, 5e-3, 2e-3])
        E.append(E[-1] @ se3.exp(noisy))
    return np.array(T), np.array(E)


def _devkit(gt, est, lengths=(100, 200, 300, 400, 500, 600, 700, 800), step=10):
    """``calcSequenceErrors`` of evaluate_odometry.cpp, loop for loop (in double)."""
    dist = [0.0]
    for i in range(1, len(gt)):
        d = gt[i, :3, 3] - gt[i - 1, :3, 3]
        dist.append(dist[i - 1] + math.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2))
    err = []
    for first in range(0, len(gt), step):
        for length in lengths:
            last = -1
            for i in range(first, len(dist)):
                if dist[i] > dist[first] + length:
                    last = i
                    break
            if last == -1:
                continue
            d_gt = np.linalg.inv(gt[first]) @ gt[last]
            d_est = np.linalg.inv(est[first]) @ est[last]
            pe = np.linalg.inv(d_est) @ d_gt
            a, b, c = pe[0, 0], pe[1, 1], pe[2, 2]
            r = math.acos(max(min(0.5 * (a + b + c - 1.0), 1.0), -1.0))
            t = math.sqrt(pe[0, 3] ** 2 + pe[1, 3] ** 2 + pe[2, 3] ** 2)
            err.append((length, r / length, t / length))
    return err


def test_kitti_segments_match_the_devkit_loops():
    gt, est = _drive()
    k = traj.kitti_segment_errors(gt, est)
    ref = _devkit(gt, est)
    assert k.count.sum() == len(ref)
    for L, t_pct, r_deg, cnt in zip(
        k.lengths, k.translation_percent, k.rotation_deg_per_m, k.count, strict=True
    ):
        rows = [e for e in ref if e[0] == L]
        assert cnt == len(rows)
        assert t_pct == pytest.approx(100 * np.mean([e[2] for e in rows]), rel=1e-9)
        assert r_deg == pytest.approx(np.degrees(np.mean([e[1] for e in rows])), rel=1e-7)
    assert k.translation_percent_mean == pytest.approx(100 * np.mean([e[2] for e in ref]))
    with pytest.raises(ValueError, match="no KITTI segment fits"):
        traj.kitti_segment_errors(gt[:50], est[:50])


def test_statistics_definitions():
    e = np.array([0.3, 1.2, 0.7, 2.5, 0.1, 0.9])
    s = traj.statistics(e)
    assert s.std == pytest.approx(pystats.pstdev(e.tolist()), rel=1e-12)  # population
    assert s.std != pytest.approx(pystats.stdev(e.tolist()), rel=1e-3)
    assert s.rmse == pytest.approx(math.sqrt(sum(x * x for x in e) / len(e)))
    assert s.median == pytest.approx(pystats.median(e.tolist()))
    assert (s.min, s.max, s.n) == (0.1, 2.5, 6)
    with pytest.raises(ValueError, match="non-empty"):
        traj.statistics([])


def test_ape_rpe_bad_input():
    gt, est = _drive(60)
    with pytest.raises(ValueError, match="associated poses"):
        traj.ape(gt, est[:-1])
    with pytest.raises(ValueError, match="pose_relation"):
        traj.ape(gt, est, "translation")
    with pytest.raises(ValueError, match="integer"):
        traj.rpe(gt, est, 1.5, "frames")
    with pytest.raises(ValueError, match="no pose pair"):
        traj.rpe(gt, est, 1e4, "m")
    with pytest.raises(ValueError, match="unit"):
        traj.rpe(gt, est, 1, "deg")
