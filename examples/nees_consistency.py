"""Is an estimator's covariance consistent with its error? NEES in the estimator's convention.

Problem. A VIO/SLAM system reports, with each pose, a 6×6 covariance in *its* convention (here
ROS's ``PoseWithCovariance``: ``(x, y, z, rx, ry, rz)``, position and fixed-axis rotation
perturbed in the parent (world) frame: left, translation first). The evaluation must compare
it with the error of that pose after aligning the estimate to the ground truth — with the
covariances moved by the same alignment, in the same convention. Read the covariance in the
wrong convention and the consistency verdict is wrong, however good the estimator is.

Simulation. GTSAM's shipped ``sphere2500`` poses are the estimate; each pose gets an anisotropic
covariance ``Σ_i`` (ROS convention); the truth is ``ros.retract(T_est, d_i)``, ``d_i ~ N(0, Σ_i)``,
expressed in another world frame. So the estimator is consistent by construction.

Evaluation (``liebridge.traj``): associate, Umeyama SE(3) alignment ``A`` (on positions),
``Σ'_i = A.transform_covariance(T_est, Σ_i, "ros")``, ``NEES_i = e_iᵀ Σ'_i⁻¹ e_i`` with
``e_i = ros.local(A(T_est,i), T_ref,i)``; two-sided 95 % χ² bounds per pose (6 dof) and for the
ANEES (6N dof). Three readings of the same numbers:

1. as ROS (right): ANEES inside its bounds;
2. left read as right (``ros`` with ``side="right"``: body-frame perturbation): outside;
3. ``(ω, v)`` swapped (translation block read as rotation): far outside.

What to look at. The printed ANEES and bounds (one line per reading) and the plot: NEES per pose
on a log axis against the per-pose bounds (≈ 95 % of the points between the lines when the
reading is right).

Run: ``python examples/nees_consistency.py [--poses 1500] [--out DIR] [--quick]``.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import gtsam
import numpy as np

from liebridge import conventions as C
from liebridge import traj
from liebridge.io import g2o
from liebridge.lie import se3


def simulate(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    conv = C.get("ros")
    rng = np.random.default_rng(seed)
    T_est = g2o.read(gtsam.findExampleDataFile("sphere2500.txt")).poses[:n]
    sig = np.array([0.05, 0.08, 0.12, 1e-3, 2e-3, 3e-3])  # (x, y, z, rx, ry, rz)
    Q = np.linalg.qr(rng.normal(size=(n, 3, 3)))[0]
    L = np.zeros((n, 6, 6))
    L[:, :3, :3] = Q * sig[:3]
    L[:, 3:, 3:] = np.linalg.qr(rng.normal(size=(n, 3, 3)))[0] * sig[3:]
    cov = L @ np.swapaxes(L, -1, -2)
    d = np.einsum("nij,nj->ni", L, rng.normal(size=(n, 6)))
    T_true = conv.retract(T_est, d)
    G = se3.exp([0.3, -0.1, 1.2, 5.0, -3.0, 2.0])  # the reference's world frame
    t = 0.1 * np.arange(n)
    return t, G @ T_true, T_est, cov


def swap_wv(cov: np.ndarray) -> np.ndarray:
    P = np.zeros((6, 6))
    P[:3, 3:] = np.eye(3)
    P[3:, :3] = np.eye(3)
    return np.asarray(P @ cov @ P.T)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--poses", type=int, default=1500, help="number of poses (≤ 2500)")
    p.add_argument("--out", type=Path, default=Path("."), help="directory for the PNG")
    p.add_argument("--quick", action="store_true", help="400 poses")
    p.add_argument("--no-show", action="store_true", help="accepted for symmetry; never shows")
    args = p.parse_args()
    n = 400 if args.quick else args.poses
    t, T_ref, T_est, cov = simulate(n)
    i_ref, i_est = traj.associate(t, t)
    A = traj.align(T_ref[i_ref], T_est[i_est], "se3")
    ros = C.get("ros")
    readings = {
        "ros (correct)": (cov, ros),
        "left read as right": (cov, dataclasses.replace(ros, name="ros_as_right", side="right")),
        "(ω, v) swapped": (swap_wv(cov), ros),
    }
    results = {}
    for label, (c, conv) in readings.items():
        C_al = A.transform_covariance(T_est, c, conv)
        r = traj.nees(T_ref, A.apply(T_est), C_al, conv)
        results[label] = r
        lo, hi = r.anees_bounds
        verdict = "consistent" if r.consistent else "INCONSISTENT"
        print(
            f"{label:<20} ANEES = {r.anees:10.4g}  bounds [{lo:.4g}, {hi:.4g}]  "
            f"{100 * r.fraction_inside:5.1f}% of poses inside  {verdict}"
        )

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2), sharey=True)
    for ax, (label, r) in zip(axes, results.items(), strict=True):
        ax.semilogy(t, r.nees, ".", ms=2, color="C0" if r.consistent else "C3")
        for b in r.pose_bounds:
            ax.axhline(b, color="k", ls="--", lw=1)
        ax.axhline(r.anees, color="C1", lw=1.5, label=f"ANEES {r.anees:.3g}")
        ax.set_title(f"{label}: {'consistent' if r.consistent else 'inconsistent'}", fontsize=10)
        ax.set_xlabel("time [s]")
        ax.legend(loc="upper right", fontsize=8)
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("NEES (6 dof), 95 % bounds dashed")
    fig.suptitle("Same estimator, same numbers, three readings of the covariance", fontsize=11)
    fig.tight_layout()
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "nees_consistency.png"
    fig.savefig(path, dpi=100)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
