"""FAST-LIO's 23×23 covariance: its IMU part in GTSAM's and OpenVINS's charts, its gravity in Unit3.

FAST-LIO's ``state_ikfom`` (include/use-ikfom.hpp) is (pos, rot, offset_R_L_I, offset_T_L_I,
vel, bg, ba, grav) with the error state (δp, δθ, δθ_LI, δt_LI, δv, δb_g, δb_a, δg): 23 entries,
the gravity on a sphere of radius 9.809 with MTK's ``S2_Bx`` chart. Preset ``fastlio``.

The script draws perturbations in FAST-LIO's own 23-dimensional chart and reads

* the IMU part of each perturbed state in ``gtsam_combined``'s and ``openvins``'s charts, against
  ``convert_covariance(FASTLIO.marginal(P, ...), ..., "fastlio_imu", dst)``;
* the gravity in GTSAM's ``Unit3`` chart, against the converted 2×2 block;

and prints the maximum difference (as correlations) to the Monte Carlo, with that of the shortcut
of reordering FAST-LIO's rows and columns only.

    python examples/fastlio_state_covariance.py [--samples 200000] [--quick]
"""

from __future__ import annotations

import argparse

import numpy as np

import liebridge as lb
from liebridge import conventions as C
from liebridge.lie import so3

IMU = ["nav", "b_a", "b_g"]
#: Index of each destination entry in FAST-LIO's (p, θ, θ_LI, t_LI, v, bg, ba, g).
NAIVE = {
    "gtsam_combined": [3, 4, 5, 0, 1, 2, 12, 13, 14, 18, 19, 20, 15, 16, 17],  # (θ, p, v, ba, bg)
    "openvins": [3, 4, 5, 0, 1, 2, 12, 13, 14, 15, 16, 17, 18, 19, 20],  # (θ, p, v, bg, ba)
}
UNIT3 = C.Bundle.of("unit3_gravity", [("gravity", C.Sphere(98090 / 10000, "gtsam"))])


def fastlio_state() -> tuple[np.ndarray, np.ndarray]:
    """Return a FAST-LIO-like state (23-dim element) and a correlated covariance ``P``."""
    rng = np.random.default_rng(5)
    T_imu_lidar = np.eye(4)
    T_imu_lidar[:3, :3] = so3.exp([0.0, 0.02, -0.01])
    T_imu_lidar[:3, 3] = [0.04165, 0.02326, -0.0284]  # the Avia offset in use-ikfom.hpp
    grav = np.array([0.3, -0.2, -9.7])
    X = C.FASTLIO.assemble(
        nav=C.nav_state(so3.exp([0.1, -0.3, 2.0]), [25.0, -40.0, 3.0], [2.0, 0.5, -0.1]),
        b_a=[0.05, -0.02, 0.1],
        b_g=[1e-3, -2e-3, 5e-4],
        T_imu_lidar=T_imu_lidar,
        gravity=9.809 * grav / np.linalg.norm(grav),
    )
    sig = np.r_[[0.3, 0.6, 1.0], [0.08] * 3, [0.01] * 3, [0.02] * 3, [0.2] * 3]
    sig = np.r_[sig, [1e-3] * 3, [1e-2] * 3, [0.02, 0.08]]
    A = rng.normal(size=(23, 23)) * 0.3 + np.eye(23)
    corr = A @ A.T
    d = 1 / np.sqrt(np.diag(corr))
    return X, (d[:, None] * corr * d[None, :]) * np.outer(sig, sig)


def _err(a: np.ndarray, mc: np.ndarray) -> float:
    return float(np.abs((a - mc) / np.sqrt(np.outer(np.diag(mc), np.diag(mc)))).max())


def main(argv: list[str] | None = None) -> dict[str, tuple[float, float]]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=200_000)
    ap.add_argument("--quick", action="store_true", help="20,000 samples")
    args = ap.parse_args(argv)
    n = 20_000 if args.quick else args.samples
    X, P = fastlio_state()
    Y = C.FASTLIO.retract(X, np.random.default_rng(1).multivariate_normal(np.zeros(23), P, n))
    X15, P15 = C.FASTLIO.sub_element(X, IMU), C.FASTLIO.marginal(P, IMU)
    Y15 = C.FASTLIO.sub_element(Y, IMU)
    out = {}
    for dst in ("gtsam_combined", "openvins"):
        conv = lb.convert_covariance(P15, X15, "fastlio_imu", dst)
        mc = np.cov(C.get(dst).local(X15, Y15).T)
        out[dst] = (_err(conv, mc), _err(P[np.ix_(NAIVE[dst], NAIVE[dst])], mc))
        print(f"fastlio → {dst}: σ = {np.array2string(np.sqrt(np.diag(conv)), precision=4)}")
        print(
            f"  max |Δ|/(σ_i σ_j) to Monte Carlo ({n} samples): converted {out[dst][0]:.3f}, "
            f"reordered only {out[dst][1]:.3f}"
        )
    g_mtk = C.FASTLIO.sub(["gravity"])
    Xg, Yg = C.FASTLIO.sub_element(X, ["gravity"]), C.FASTLIO.sub_element(Y, ["gravity"])
    conv = lb.convert_covariance(C.FASTLIO.marginal(P, ["gravity"]), Xg, g_mtk, UNIT3)
    mc = np.cov(UNIT3.local(Xg, Yg).T)
    out["unit3"] = (_err(conv, mc), _err(C.FASTLIO.marginal(P, ["gravity"]), mc))
    print(f"fastlio gravity (MTK S2_Bx) → GTSAM Unit3: σ = {np.sqrt(np.diag(conv))}")
    print(
        f"  max |Δ|/(σ_i σ_j) to Monte Carlo: converted {out['unit3'][0]:.3f}, "
        f"as is {out['unit3'][1]:.3f}"
    )
    ok = all(e < 0.05 for e, _ in out.values()) and out["gtsam_combined"][1] > 0.2
    print("converted covariances within Monte Carlo noise" if ok else "MISMATCH")
    return out


if __name__ == "__main__":
    main()
