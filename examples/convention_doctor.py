"""The convention doctor on one planted bug per row of the failure table.

Each block writes the wrong code a user writes (a Jacobian copied with the other perturbation
side, the old skew sign, ``Jr⁻¹`` left out, an inverted relative-pose residual, a covariance
without its adjoint, a w-first quaternion file, a SLERP without the hemisphere check), asks the
doctor, and prints its verdict and explanation. Run from anywhere::

    python examples/convention_doctor.py [--out DIR] [--no-show]

With ``--out`` it also writes ``convention_doctor.png``: ``‖Log(R_refᵀR)‖`` along a 360° turn
and the rotation step of a SLERP'd sequence with and without the hemisphere check (needs
matplotlib).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from liebridge.doctor import (
    Diagnosis,
    diagnose_covariance,
    diagnose_jacobian,
    diagnose_residual,
    scan_trajectory,
)
from liebridge.lie import quaternion, se3, so3

inv = np.linalg.inv
X = se3.exp(np.array([0.3, -0.2, 0.1, 1.0, 2.0, 3.0]))
P = np.array([0.5, -1.0, 2.0])


def show(title: str, d: Diagnosis) -> None:
    print(f"== {title}\n{d}\n")


def act(T: np.ndarray) -> np.ndarray:
    return T[:3, :3] @ P + T[:3, 3]


def naive_slerp(q0: np.ndarray, q1: np.ndarray, tau: float) -> np.ndarray:
    """SLERP without the hemisphere check (the bug): wxyz, unit quaternions."""
    th = np.arccos(np.clip(q0 @ q1, -1.0, 1.0))
    if th < 1e-9:
        return q0
    return (np.sin((1 - tau) * th) * q0 + np.sin(tau * th) * q1) / np.sin(th)


def checked_slerp(q0: np.ndarray, q1: np.ndarray, tau: float) -> np.ndarray:
    """SLERP with the check: negate q1 when dot(q0, q1) < 0."""
    return naive_slerp(q0, q1 if q0 @ q1 >= 0 else -q1, tau)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=None, help="write convention_doctor.png here")
    ap.add_argument("--no-show", action="store_true", help="do not open a window")
    args = ap.parse_args()

    # 1. a left-perturbation Jacobian handed to GTSAM (right): side mismatch and its fix
    J_left = lambda T: np.hstack([-so3.hat(act(T)), np.eye(3)])  # noqa: E731
    show(
        "left Jacobian, GTSAM solver", diagnose_jacobian(act, J_left, X, solver_convention="gtsam")
    )

    # 2. the old skew sign
    J_old = lambda T: np.hstack([T[:3, :3] @ so3.hat(P), T[:3, :3]])  # noqa: E731
    show("old skew sign", diagnose_jacobian(act, J_old, X, solver_convention="gtsam"))

    # 3. a between residual without Jr⁻¹(r)
    Z = se3.exp(np.array([0.1, 0.2, -0.1, 1.0, 0.0, 0.0]))
    Tj = se3.exp(np.array([0.5, 0.1, 0.2, 2.0, 1.0, 3.0]))

    def r(Ti: np.ndarray, Tj: np.ndarray) -> np.ndarray:
        return se3.log(inv(Z) @ inv(Ti) @ Tj)

    J_no_jr = lambda Ti, Tj: np.hstack([-se3.adjoint(inv(Tj) @ Ti), np.eye(6)])  # noqa: E731
    show(
        "between residual without Jr⁻¹",
        diagnose_jacobian(r, J_no_jr, (X, Tj), solver_convention="gtsam"),
    )

    # 4. a small-angle Jr⁻¹ ≈ I + hat(r)/2 (U-turns fail)
    J_small = lambda R: np.eye(3) + 0.5 * so3.hat(so3.log(R))  # noqa: E731
    show(
        "small-angle Jacobian",
        diagnose_jacobian(so3.log, J_small, X[:3, :3], solver_convention="gtsam"),
    )

    # 5. an inverted relative-pose residual: the loop closure pulls the wrong way
    show("inverted residual", diagnose_residual(lambda Ti, Tj, Z: se3.log(Z @ inv(Ti) @ Tj)))

    # 6. a GTSAM marginal moved to Barfoot's left tangent without the adjoint
    cov = np.diag([1e-3, 2e-3, 3e-3, 1e-2, 2e-2, 3e-2])
    show("missing adjoint", diagnose_covariance(lambda c, T: c, X, cov, src="gtsam", dst="barfoot"))

    # 7. a w-first TUM file (a vehicle on a circle)
    n = 300
    yaw = np.linspace(0.0, 1.6 * np.pi, n)
    t = np.stack([5 * np.sin(yaw), 5 * (1 - np.cos(yaw)), 0 * yaw], axis=1)
    R = so3.exp(yaw[:, None] * np.array([0.0, 0.0, 1.0]))
    q_wxyz = quaternion.from_matrix(R, order="wxyz")
    q_wxyz *= np.where(q_wxyz[:, :1] < 0, -1.0, 1.0)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "w_first.tum"
        rows = np.hstack([np.arange(n)[:, None] * 0.1, t, q_wxyz])
        np.savetxt(path, rows, header="timestamp tx ty tz qx qy qz qw")
        data = np.loadtxt(path)
    show("w-first TUM file", scan_trajectory(data[:, 0], data[:, 1:], quat_order="xyzw"))

    # 8. SLERP between keyframes, one stored with the other sign
    keys = quaternion.from_matrix(
        so3.exp(np.linspace(0, 1.2, 6)[:, None] * [0.0, 0.0, 1.0]), order="wxyz"
    )
    keys[3] *= -1.0
    taus = np.linspace(0, 1, 10, endpoint=False)
    dense_bad = np.array([naive_slerp(keys[k], keys[k + 1], s) for k in range(5) for s in taus])
    dense_ok = np.array([checked_slerp(keys[k], keys[k + 1], s) for k in range(5) for s in taus])
    stamps = np.arange(len(dense_bad)) * 0.01
    show(
        "SLERP without the hemisphere check", scan_trajectory(stamps, dense_bad, quat_order="wxyz")
    )
    show("SLERP with the check", scan_trajectory(stamps, dense_ok, quat_order="wxyz"))

    if args.out is not None:
        import matplotlib

        if args.no_show:
            matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        turn = so3.exp(np.linspace(0, 2 * np.pi, 361)[:, None] * np.array([0.0, 0.0, 1.0]))
        w = so3.log(turn)

        def step(q: np.ndarray) -> np.ndarray:
            Rs = quaternion.to_matrix(q, order="wxyz")
            rel = np.einsum("nji,njk->nik", Rs[:-1], Rs[1:])
            return np.degrees(np.linalg.norm(so3.log(rel), axis=-1))

        fig, ax = plt.subplots(1, 2, figsize=(10, 3.6))
        ax[0].plot(np.arange(361), np.linalg.norm(w, axis=-1), label="‖Log(R_refᵀR)‖")
        ax[0].plot(np.arange(361), w[:, 2], label="its z component")
        ax[0].axhline(np.pi, ls="--", c="gray")
        ax[0].set(xlabel="yaw (deg)", ylabel="rad", title="the log's branch cut at π")
        ax[0].legend()
        ax[1].plot(step(dense_bad), label="no hemisphere check")
        ax[1].plot(step(dense_ok), label="with the check")
        ax[1].set(xlabel="sample", ylabel="rotation step (deg)", title="SLERP spin")
        ax[1].legend()
        fig.tight_layout()
        args.out.mkdir(parents=True, exist_ok=True)
        fig.savefig(args.out / "convention_doctor.png", dpi=110)
        if not args.no_show:
            plt.show()


if __name__ == "__main__":
    main()
