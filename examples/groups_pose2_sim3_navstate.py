"""The other groups in one run: Pose2 → ROS 6×6, Sim(3) GTSAM → Sophus, NavState → manif.

A GTSAM Pose2 marginal becomes a ROS ``PoseWithCovariance`` 6×6; a Sim(3) covariance goes from
GTSAM's to Sophus's tangent; GTSAM's NavState chart is compared with manif's SE_2(3).

Prints, for each case, the converted covariance and its agreement with a Monte Carlo of the
source library's own retraction read in the destination's chart (``--samples`` draws).
"""

from __future__ import annotations

import argparse
import math

import gtsam
import numpy as np

import liebridge as lb
from liebridge.check import monte_carlo_covariance
from liebridge.lie import se23, sim3


def pose2_marginal_to_ros(samples: int) -> float:
    graph = gtsam.NonlinearFactorGraph()
    graph.add(
        gtsam.PriorFactorPose2(
            0, gtsam.Pose2(), gtsam.noiseModel.Diagonal.Sigmas(np.array([0.05, 0.05, 0.02]))
        )
    )
    odo = gtsam.noiseModel.Diagonal.Sigmas(np.array([0.2, 0.1, 0.1]))
    values = gtsam.Values()
    pose = gtsam.Pose2()
    values.insert(0, pose)
    for k in range(3):
        step = gtsam.Pose2(2.0, 0.0, math.pi / 2)
        graph.add(gtsam.BetweenFactorPose2(k, k + 1, step, odo))
        pose = pose.compose(step)
        values.insert(k + 1, pose)
    S = gtsam.Marginals(graph, values).marginalCovariance(3)  # GTSAM: body-frame (x, y, θ)
    X = values.atPose2(3).matrix()
    ros = lb.convert_covariance(S, X, "gtsam_pose2", "ros_pose2")  # 6×6, (x, y, yaw) at 0, 1, 5
    print("GTSAM Pose2 marginal (vx, vy, ω):\n", np.array2string(S, precision=5))
    print("as ROS PoseWithCovariance 6×6:\n", np.array2string(ros, precision=5))
    mc = monte_carlo_covariance(S, X, "gtsam_pose2", "ros_pose2", n=samples)
    err = float(np.abs(ros - mc).max() / np.abs(mc).max())
    print(f"max relative difference to Monte Carlo ({samples} samples): {err:.3%}")
    return err


def sim3_gtsam_to_sophus(samples: int) -> float:
    X = sim3.exp([0.3, -0.2, 0.5, 1.0, 2.0, -1.0, 0.4])  # [sR t; 0 1]
    S = np.diag([1e-3, 1e-3, 2e-3, 1e-2, 1e-2, 2e-2, 1e-3])
    out = lb.convert_covariance(S, X, "gtsam_similarity3", "sophus_sim3")
    mc = monte_carlo_covariance(S, X, "gtsam_similarity3", "sophus_sim3", n=samples)
    err = float(np.abs(out - mc).max() / np.abs(mc).max())
    print(f"Sim(3) GTSAM (ω, u, λ) -> Sophus (υ, ω, σ): relative difference to MC {err:.3%}")
    return err


def navstate_to_manif(samples: int) -> float:
    X = se23.exp([0.3, -0.2, 0.5, 10.0, 5.0, -1.0, 2.0, 0.5, 0.1])
    S = np.diag([1e-3] * 3 + [0.5] * 3 + [0.1] * 3)
    lin = lb.convert_covariance(S, X, "gtsam_navstate", "manif_se23")
    uns = lb.convert_covariance(S, X, "gtsam_navstate", "manif_se23", method="unscented")
    mc = monte_carlo_covariance(S, X, "gtsam_navstate", "manif_se23", n=samples)
    e_lin = float(np.abs(lin - mc).max() / np.abs(mc).max())
    e_uns = float(np.abs(uns - mc).max() / np.abs(mc).max())
    print(f"NavState -> manif SE_2(3): linear {e_lin:.3%}, unscented {e_uns:.3%} from MC")
    return e_uns


def main() -> None:
    """Run the three conversions."""
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--samples", type=int, default=200_000)
    args = p.parse_args()
    errs = [
        pose2_marginal_to_ros(args.samples),
        sim3_gtsam_to_sophus(args.samples),
        navstate_to_manif(args.samples),
    ]
    print("all within Monte Carlo noise" if max(errs) < 0.05 else "MISMATCH")


if __name__ == "__main__":
    main()
