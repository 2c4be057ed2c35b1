"""Presets for what point-cloud registration libraries return (their Hessians and information).

A registration library linearises its cost in one tangent of ``T_target_source`` (the pose that
maps a source-cloud point into the target frame, ``q ≈ T·p``); the information matrix it returns,
or that a user builds from it, lives in that tangent. These presets name those tangents; they are
ordinary SE(3) :class:`~liebridge.conventions.Convention` records, found by
:func:`liebridge.conventions.get` (``"open3d"``, ``"small_gicp"``, ``"kiss_icp"``,
``"hdl_graph_slam"``), so every conversion of liebridge accepts them. What each library's matrix
*scales* to (unit noise, metric point covariances, a heuristic) is said in ``notes`` and handled by
:mod:`liebridge.registration`.

Evidence codes as in :mod:`liebridge.conventions.presets`: **V** checked by running the library
(``tests/test_registration_libs.py``), **S** read in its source (repository@commit path:line).
"""

from __future__ import annotations

from .convention import Convention

OPEN3D = Convention(
    name="open3d",
    side="left",
    order="rot_first",
    chart="se3",
    rotation="exp",
    quat_order="wxyz",
    source=(
        "V open3d 0.20 get_information_matrix_from_point_clouds (tests/test_registration_libs.py); "
        "S isl-org/Open3D@22a6a307b cpp/open3d/pipelines/registration/Registration.cpp:425-474, "
        "GlobalOptimization.cpp:177-180, 251, utility/Eigen.cpp:79-89"
    ),
    notes=(
        "get_information_matrix_from_point_clouds = Σ GᵀG, G = [−[q]ₓ | I] at the *target* "
        "points q: a left perturbation Exp(δ)·T_target_source, δ = (ω, t), rotation first, "
        "unit noise (Λ[5, 5] is the number of correspondences; divide by σ²). On an exactly "
        "aligned pair it is the Gauss–Newton Hessian of Σ‖T·p − q‖²; elsewhere it differs by "
        "the residuals (q instead of T·p). Open3D's own update is "
        "TransformVector6dToMatrix4d(δ)·T (ZYX Euler angles, translation added as is), equal to "
        "Exp(δ)·T to first order, so the information is the same; this preset's retract is the "
        "SE(3) exponential. False: 'I comes first' (the code comment at Registration.cpp:425), "
        "and the g2o form [I | p×] of GlobalOptimization.cpp:180: [I | p×](t, ω) = "
        "[−p× | I](−ω, t), order and rotation sign both differ. "
        "Quaternions: get_rotation_matrix_from_quaternion takes (w, x, y, z)."
    ),
)
"""Open3D registration information: left, ``(ω, t)``, unit noise, evaluated at target points."""

SMALL_GICP = Convention(
    name="small_gicp",
    side="right",
    order="rot_first",
    chart="se3",
    rotation="exp",
    quat_order="xyzw",
    source=(
        "V small_gicp 1.0.1 align/ICPFactor.linearize (tests/test_registration_libs.py); "
        "S koide3/small_gicp@aea1313 include/small_gicp/registration/optimizer.hpp:42-56, 112, "
        "util/lie.hpp:77-96, factors/icp_factor.hpp:43-51, gicp_factor.hpp:62-70"
    ),
    notes=(
        "RegistrationResult.H = Σ JᵀMJ with J = [R·[p]ₓ, −R] on r = q − T·p: the update is "
        "T·Exp(δ) (right), δ = (ω, ρ), full SE(3) exponential — GTSAM's Pose3 chart, so H is "
        "information for BetweenFactor<Pose3>(target, source, T_target_source) as it is. "
        "M = I for ICP (unit noise: divide by σ²); M = (C_t + R·C_s·Rᵀ)⁻¹ for GICP, an "
        "information only when the point covariances are in m² — small_gicp's own "
        "estimate_covariances normalises them (eigenvalues 1e-3, 1, 1), so calibrate. "
        "H is the linearisation *before* the last update. PLANE_ICP's error is n∘(q − T·p), "
        "component-wise. False: H is over (ρ, ω) or a left perturbation (Sophus/KISS-ICP "
        "habits). The Python bindings take no quaternion; Eigen stores them (x, y, z, w)."
    ),
)
"""small_gicp ``RegistrationResult.H``: right, ``(ω, ρ)``, SE(3) exp (GTSAM's chart)."""

KISS_ICP = Convention(
    name="kiss_icp",
    side="left",
    order="trans_first",
    chart="se3",
    rotation="exp",
    quat_order="xyzw",
    source=(
        "V kiss-icp 1.3.0 (tests/test_registration_libs.py); S PRBonn/kiss-icp@4bd9a10 "
        "cpp/kiss_icp/core/Registration.cpp:80-98, 150-166; ros/src/OdometryServer.cpp:204-216"
    ),
    notes=(
        "Internally r = T·p − q, J = [I, −[T·p]ₓ], δ = (ρ, ω) (Sophus order), update "
        "T ← Exp(δ)·T (left), Geman–McClure weights k²/(k + r²)². KISS-ICP publishes no "
        "covariance: its ROS node writes a fixed diagonal (entries 0, 7, 14 position, "
        "21, 28, 35 orientation, default 0.1). False: the increment is applied on the right "
        "(Sophus' own ceres manifold habit) or ordered (ω, ρ)."
    ),
)
"""KISS-ICP's internal tangent: left, ``(ρ, ω)``, SE(3) exp (Sophus)."""

HDL_GRAPH_SLAM = Convention(
    name="hdl_graph_slam",
    side="right",
    order="trans_first",
    chart="so3xr3_body",
    rotation="quat_vec",
    quat_order="xyzw",
    source=(
        "S koide3/hdl_graph_slam src/hdl_graph_slam/information_matrix_calculator.cpp "
        "(calc_information_matrix); g2o EdgeSE3 error chart (preset 'g2o')"
    ),
    notes=(
        "information = diag(1/w_x·I₃, 1/w_q·I₃), translation block first, on g2o's EdgeSE3 "
        "error (t, q_vec) of Z⁻¹·Xi⁻¹·Xj: right, body-frame translation, quaternion vector "
        "part (≈ θ/2, so the rotation weight is 4× that over angles). w from a fitness-score "
        "heuristic (in the constant mode it divides by σ, not σ²): not a registration "
        "Hessian. False: the weights are over (ω, v) or over rotation angles."
    ),
)
"""hdl_graph_slam-style information: g2o's EdgeSE3 chart, ``(t, q_vec)``, translation first."""

#: The registration presets, in registry order.
REGISTRATION_PRESETS: tuple[Convention, ...] = (OPEN3D, SMALL_GICP, KISS_ICP, HDL_GRAPH_SLAM)

__all__ = ["HDL_GRAPH_SLAM", "KISS_ICP", "OPEN3D", "REGISTRATION_PRESETS", "SMALL_GICP"]
