"""Bag → GTSAM → bag: odometry with ROS covariances into a pose graph, marginals back to ROS.

Problem. A robot's odometry node publishes ``nav_msgs/Odometry`` whose pose covariance grows as
it dead-reckons. ROS defines that covariance over ``(x, y, z, rotX, rotY, rotZ)``: position error
in the ``odom`` frame, rotation error about ``odom``'s fixed axes. GTSAM's ``BetweenFactorPose3``
wants the covariance of the *increment* over its own body-frame tangent ``(ω, v)``. Copying the
message's matrix into GTSAM is wrong twice (order and frame), and a pose covariance is not an
increment covariance.

Data. The trajectory is the first poses of GTSAM's shipped ``sphere2500.txt``
(``gtsam.findExampleDataFile``), taken as ground truth. Odometry increments are simulated with a
known noise ``Σ_Z`` (GTSAM tangent) and dead-reckoned with first-order covariance propagation;
the poses and covariances are written as ``/odom`` (``nav_msgs/Odometry``, ROS 2 mcap) with
``liebridge.ros.from_poses(..., convention="gtsam")``, which converts to the ROS convention.
Loop closures are the dataset's non-consecutive edges among those poses, measured from the
truth with noise.

Pipeline. ``liebridge.ros.read_messages`` → ``liebridge.ros.odometry_factors`` (the increment
covariance recovered in GTSAM's tangent after converting each message's covariance with
``convert_covariance``) + loop closures → Levenberg–Marquardt → ``liebridge.ros.
messages_from_gtsam`` (marginals converted to ROS) → ``/optimized`` in a new ROS 1 bag.

What to look at. The printed increment-covariance check (recovered ``Σ_Z`` vs the simulated one:
converted, ~1e-12; copied without conversion: wrong by O(1)), the errors against ground truth
before and after, and the NEES of the optimized poses under their ROS marginals (≈ 6 when the
covariances mean what they say). The plot: truth, odometry and optimized trajectories (x–y) with
3σ position ellipses read straight from the messages' covariance (its position block is in the
parent frame, which is why it can be drawn there).

Run: ``python examples/bag_to_gtsam.py [--quick] [--poses 300] [--out DIR]``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import gtsam
import numpy as np

from liebridge import ros
from liebridge.io import g2o
from liebridge.lie import se3

SIGMA_ROT, SIGMA_TRANS = 0.01, 0.05  # odometry noise per step: rad, m (GTSAM tangent (ω, v))
SIGMA_LOOP = (0.005, 0.02)


def simulate(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray, list]:
    """Truth from sphere2500, dead-reckoned odometry with covariance, loop closures."""
    data = g2o.read(gtsam.findExampleDataFile("sphere2500.txt"))
    truth = np.asarray(data.poses[:n])
    Q = np.diag([SIGMA_ROT**2] * 3 + [SIGMA_TRANS**2] * 3)
    L = np.linalg.cholesky(Q)
    T_odo = [truth[0]]
    C = [np.diag([1e-8] * 6)]
    for k in range(n - 1):
        Z = se3.inverse(truth[k]) @ truth[k + 1] @ se3.exp(L @ rng.normal(size=6))
        A = se3.adjoint(se3.inverse(Z))
        T_odo.append(T_odo[-1] @ Z)
        C.append(A @ C[-1] @ A.T + Q)
    loops = []
    Ql = np.diag([SIGMA_LOOP[0] ** 2] * 3 + [SIGMA_LOOP[1] ** 2] * 3)
    for i, j in data.edges.tolist():
        if j < n and i < n and abs(i - j) > 1:
            Z = (
                se3.inverse(truth[i])
                @ truth[j]
                @ se3.exp(np.linalg.cholesky(Ql) @ rng.normal(size=6))
            )
            loops.append((i, j, Z, Ql))
    return truth, np.array(T_odo), np.array(C), loops


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--poses", type=int, default=300)
    ap.add_argument("--quick", action="store_true", help="60 poses (the test runs this)")
    ap.add_argument("--out", default=".", help="directory for the bags and the plot")
    args = ap.parse_args(argv)
    n = 60 if args.quick else args.poses
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(42)
    truth, T_odo, C_gtsam, loops = simulate(n, rng)
    stamps = 1_700_000_000.0 + 0.1 * np.arange(n)

    # 1. the odometry node's bag (ROS 2, mcap): covariance converted to the message convention
    odom = ros.from_poses(
        T_odo,
        C_gtsam,
        convention="gtsam",
        stamps=stamps,
        frame_id="odom",
        child_frame_id="base_link",
        msgtype="nav_msgs/Odometry",
    )
    bag_in = ros.write_messages(out / "odometry.mcap", "/odom", odom)

    # 2. bag → GTSAM
    msgs = ros.read_messages(bag_in, "/odom")
    graph = gtsam.NonlinearFactorGraph()
    for f in ros.odometry_factors(msgs):
        graph.add(f)
    _, cz = ros.increment_covariances(msgs)
    Q = np.diag([SIGMA_ROT**2] * 3 + [SIGMA_TRANS**2] * 3)
    err_conv = np.abs(cz - Q).max() / Q.max()
    assert msgs.cov is not None
    copied = msgs.cov[1:] - msgs.cov[:-1]  # what "copy the message covariance" would give
    err_copy = np.abs(copied - Q).max() / Q.max()
    print(
        f"increment covariance vs simulated: converted rel. error {err_conv:.2e}; "
        f"copied (no conversion) {err_copy:.2e}"
    )
    for i, j, Z, Ql in loops:
        graph.add(
            gtsam.BetweenFactorPose3(i, j, gtsam.Pose3(Z), gtsam.noiseModel.Gaussian.Covariance(Ql))
        )
    initial = gtsam.Values()
    for k in range(n):
        initial.insert(k, gtsam.Pose3(msgs.T[k]))
    result = gtsam.LevenbergMarquardtOptimizer(graph, initial).optimize()
    print(
        f"{n} poses, {len(loops)} loop closures; error {graph.error(initial):.4g} -> "
        f"{graph.error(result):.4g}"
    )

    # 3. GTSAM → bag: poses + marginals as PoseWithCovarianceStamped (ROS 1)
    opt = ros.messages_from_gtsam(graph, result, range(n), stamps=msgs.stamps, frame_id="odom")
    bag_out = ros.write_messages(out / "optimized.bag", "/optimized", opt)
    back = ros.read_messages(bag_out, "/optimized")
    assert back.cov is not None

    def ate(T: np.ndarray) -> float:
        return float(np.sqrt(np.mean(np.sum((T[:, :3, 3] - truth[:, :3, 3]) ** 2, axis=-1))))

    # NEES under the ROS covariance: the error (t_true - t, Log(R_true Rᵀ)) in the ROS tangent
    e = np.c_[
        truth[:, :3, 3] - back.T[:, :3, 3],
        np.array(
            [
                se3.log(np.block([[a @ b.T, np.zeros((3, 1))], [np.zeros((1, 3)), 1]]))[:3]
                for a, b in zip(truth[:, :3, :3], back.T[:, :3, :3], strict=True)
            ]
        ),
    ]
    nees = np.einsum("ni,nij,nj->n", e[1:], np.linalg.inv(back.cov[1:]), e[1:])
    print(f"position RMSE vs truth: odometry {ate(T_odo):.4f} m, optimized {ate(back.T):.4f} m")
    print(
        f"NEES of the optimized poses under their ROS marginals: mean {nees.mean():.2f} "
        f"(6 expected)"
    )
    print(f"wrote {bag_in} (/odom) and {bag_out} (/optimized)")

    try:
        import matplotlib
    except ImportError:
        print("matplotlib not installed: no plot")
        return 0
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 6))
    ax.plot(truth[:, 0, 3], truth[:, 1, 3], "k-", lw=1, label="truth (sphere2500)")
    ax.plot(T_odo[:, 0, 3], T_odo[:, 1, 3], "r--", lw=1, label="odometry (/odom)")
    ax.plot(back.T[:, 0, 3], back.T[:, 1, 3], "b-", lw=1.5, label="optimized (/optimized)")
    th = np.linspace(0, 2 * np.pi, 60)
    for k in range(0, n, max(1, n // 15)):
        lam, U = np.linalg.eigh(back.cov[k][:2, :2])
        pts = U @ (3 * np.sqrt(np.maximum(lam, 0))[:, None] * np.array([np.cos(th), np.sin(th)]))
        ax.plot(back.T[k, 0, 3] + pts[0], back.T[k, 1, 3] + pts[1], "b-", lw=0.6, alpha=0.6)
    ax.set_xlabel("x [m] (odom)")
    ax.set_ylabel("y [m] (odom)")
    ax.set_title("bag → GTSAM → bag: 3σ position ellipses from the ROS covariance")
    ax.axis("equal")
    ax.legend()
    png = out / "bag_to_gtsam.png"
    fig.savefig(png, dpi=100)
    print(f"wrote {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
