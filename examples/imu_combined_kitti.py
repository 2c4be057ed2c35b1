"""GPS-aided inertial navigation on KITTI with the combined IMU factor (bias random walk inside).

Problem
    GTSAM's KITTI sample data (``KittiEquivBiasedImu.txt``, 100 Hz IMU with a bias;
    ``KittiGps_converted.txt``, 1 Hz positions). One keyframe per GPS fix with a position-only
    prior; between keyframes the IMU samples are preintegrated and tied by one *combined* IMU
    factor on (pose, velocity, bias) at both keyframes: the bias random walk lives inside the
    factor (15-dimensional residual), there is no separate bias between-factor. The same graph is
    built twice:

    * liebridge: :func:`liebridge.imu.preintegrate_combined` (GTSAM's tangent preintegration,
      15×15 covariance) and :func:`liebridge.imu.combined_imu` (a ``gtsam.CustomFactor``),
      optimized with :func:`liebridge.gtsam.optimize`;
    * GTSAM: ``PreintegratedCombinedMeasurements`` and ``gtsam.CombinedImuFactor``, optimized with
      GTSAM's Levenberg-Marquardt.

Conventions
    Residual order (θ, p, v, b_a, b_g), ``ImuFactorErrorMode.ComponentWise`` for both, bias part
    ``b_i − b_j``, noise model GTSAM's ``residualCovariance()``. Poses are ``T_world_body``
    (``Pose3``, right perturbation (ω, v)); velocities world-frame ``Vector3``; biases (acc, gyro).

What to look at
    The two optimized trajectories agree to far below the GPS noise (the "max position difference"
    line); ``--quick`` uses the first 1,500 IMU samples (the test suite runs it).
"""

from __future__ import annotations

import argparse
import time

import gtsam
import numpy as np
from gtsam.symbol_shorthand import B, V, X

import liebridge as lb

GRAVITY = 9.8
GPS_SIGMA = 0.25  # m


def load(samples: int | None) -> tuple[np.ndarray, np.ndarray, dict[str, float]]:
    """IMU rows (time, dt, acc, gyro), GPS rows (time, x, y, z) and the IMU metadata."""
    imu = np.loadtxt(gtsam.findExampleDataFile("KittiEquivBiasedImu.txt"), skiprows=1)[2:]
    if samples is not None:
        imu = imu[:samples]
    gps = np.loadtxt(gtsam.findExampleDataFile("KittiGps_converted.txt"), skiprows=1, delimiter=",")
    with open(gtsam.findExampleDataFile("KittiEquivBiasedImu_metadata.txt")) as f:
        names = f.readline().split()
        meta = dict(zip(names, map(float, f.readline().split()), strict=True))
    return imu, gps, meta


def combined_params(meta: dict[str, float]) -> gtsam.PreintegrationCombinedParams:
    p = gtsam.PreintegrationCombinedParams.MakeSharedU(GRAVITY)
    p.setAccelerometerCovariance(meta["AccelerometerSigma"] ** 2 * np.eye(3))
    p.setGyroscopeCovariance(meta["GyroscopeSigma"] ** 2 * np.eye(3))
    p.setIntegrationCovariance(max(meta["IntegrationSigma"], 1e-4) ** 2 * np.eye(3))
    p.setBiasAccCovariance(meta["AccelerometerBiasSigma"] ** 2 * np.eye(3))
    p.setBiasOmegaCovariance(meta["GyroscopeBiasSigma"] ** 2 * np.eye(3))
    p.setImuFactorErrorMode(gtsam.ImuFactorErrorMode.ComponentWise)
    return p


def segments(imu: np.ndarray, gps: np.ndarray) -> list[tuple[int, np.ndarray]]:
    """(GPS index, IMU rows) per keyframe interval, as GTSAM's IMUKittiExampleGPS.py splits them."""
    out = []
    j = 0
    for i in range(2, len(gps)):
        t_prev, t = gps[i - 1, 0], gps[i, 0]
        if t > imu[-1, 0]:
            break
        start = j
        while j < len(imu) and imu[j, 0] <= t:
            j += 1
        rows = imu[start:j]
        out.append((i, rows[rows[:, 0] >= t_prev]))
    return out


def build(imu: np.ndarray, gps: np.ndarray, meta: dict[str, float]):
    params = combined_params(meta)
    zero_bias = gtsam.imuBias.ConstantBias()
    graphs = {"liebridge": gtsam.NonlinearFactorGraph(), "gtsam": gtsam.NonlinearFactorGraph()}
    initial = gtsam.Values()
    gps_prior = gtsam.noiseModel.Diagonal.Precisions(np.array([0, 0, 0] + [GPS_SIGMA**-2] * 3))

    def add_keyframe(k: int, R: np.ndarray, position: np.ndarray, velocity: np.ndarray) -> None:
        initial.insert(X(k), gtsam.Pose3(gtsam.Rot3(R), position))
        initial.insert(V(k), velocity)
        initial.insert(B(k), zero_bias)
        for g in graphs.values():
            g.add(gtsam.PriorFactorPose3(X(k), gtsam.Pose3(gtsam.Rot3(), position), gps_prior))

    R = np.eye(3)
    add_keyframe(0, R, gps[1, 1:], np.zeros(3))
    for g in graphs.values():
        g.add(gtsam.PriorFactorVector(V(0), np.zeros(3), gtsam.noiseModel.Isotropic.Sigma(3, 1e3)))
        g.add(
            gtsam.PriorFactorConstantBias(
                B(0), zero_bias, gtsam.noiseModel.Diagonal.Sigmas(np.array([0.1] * 3 + [5e-5] * 3))
            )
        )
    segs = segments(imu, gps)
    for k, (i, rows) in enumerate(segs, start=1):
        dt, acc, gyro = rows[:, 1], rows[:, 2:5], rows[:, 5:8]
        ours = lb.imu.preintegrate_combined(acc, gyro, dt, bias=zero_bias, params=params)
        pim = gtsam.PreintegratedCombinedMeasurements(params, zero_bias)
        for a, w, d in zip(acc, gyro, dt, strict=True):
            pim.integrateMeasurement(a, w, d)
        keys = (X(k - 1), V(k - 1), X(k), V(k), B(k - 1), B(k))
        graphs["liebridge"].add(lb.imu.combined_imu(*keys, ours))
        graphs["gtsam"].add(gtsam.CombinedImuFactor(*keys, pim))
        velocity = (gps[i, 1:] - gps[i - 1, 1:]) / (gps[i, 0] - gps[i - 1, 0])
        R = R @ ours.delta_R
        add_keyframe(k, R, gps[i, 1:], velocity)
    return graphs, initial, len(segs)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--samples", type=int, default=None, help="use the first N IMU samples")
    parser.add_argument("--quick", action="store_true", help="the first 1,500 IMU samples")
    args = parser.parse_args(argv)
    imu, gps, meta = load(1500 if args.quick else args.samples)
    graphs, initial, n_key = build(imu, gps, meta)
    print(f"keyframes: {n_key + 1}, combined IMU factors: {n_key}")
    lm = gtsam.LevenbergMarquardtParams()
    lm.setMaxIterations(100)
    lm.setRelativeErrorTol(1e-10)
    lm.setAbsoluteErrorTol(1e-10)
    results = {}
    for name in ("liebridge", "gtsam"):
        graph = graphs[name]
        t0 = time.perf_counter()
        if name == "liebridge":
            result = lb.gtsam.optimize(graph, initial, lm, progress=False).values
        else:
            result = gtsam.LevenbergMarquardtOptimizer(graph, initial, lm).optimize()
        t1 = time.perf_counter()
        results[name] = result
        print(
            f"{name} graph: error {graph.error(initial):.6g} -> {graph.error(result):.6g} "
            f"in {1e3 * (t1 - t0):.0f} ms"
        )
    a, b = results["liebridge"], results["gtsam"]
    ks = range(n_key + 1)
    dpos = max(
        float(np.linalg.norm(a.atPose3(X(k)).translation() - b.atPose3(X(k)).translation()))
        for k in ks
    )
    drot = max(
        float(
            np.linalg.norm(
                gtsam.Rot3.Logmap(a.atPose3(X(k)).rotation().between(b.atPose3(X(k)).rotation()))
            )
        )
        for k in ks
    )
    dbias = max(
        float(np.abs(a.atConstantBias(B(k)).vector() - b.atConstantBias(B(k)).vector()).max())
        for k in ks
    )
    print(f"max position difference: {dpos:.3e} m")
    print(f"max rotation difference: {drot:.3e} rad")
    print(f"max bias difference: {dbias:.3e}")
    agree = dpos < 1e-4 and drot < 1e-6
    print(f"agree: {'yes' if agree else 'NO'}")
    return 0 if agree else 1


if __name__ == "__main__":
    raise SystemExit(main())
