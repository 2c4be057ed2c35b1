"""Presets of whole IMU states: the (R, p, v, b_a, b_g) conventions of VIO/LIO systems.

The 15-dimensional presets (:data:`STATE_PRESETS_15`) are :class:`~liebridge.conventions.Bundle`
s of the same three blocks, so any two convert into each other (``convert_covariance``, linear
or unscented, ``convert_information``, ``convert_jacobian``, ``tangent_map``):

* ``nav``: an SE₂(3) chart of ``(R_world_body, p_world, v_world)``, the 5×5 extended pose
  (GTSAM's ``NavState`` chart or a :class:`~liebridge.conventions.navstate.NavChart`);
* ``b_a``, ``b_g``: accelerometer and gyroscope biases, additive.

An element is the 13×13 block-diagonal matrix ``Bundle.assemble(nav=X, b_a=..., b_g=...)``
(``X`` from :func:`~liebridge.conventions.navstate.nav_state`). The tangent is the system's own
order (a permutation of ``(nav tangent, δb_a, δb_g)``). The 9-dimensional states are the SE₂(3)
presets ``gtsam_navstate``, ``manif_se23`` and ``mola`` (and any ``NavChart``); a 15×15
covariance given to one of them is refused, and so is a 9×9 given to a 15-dimensional state.

``fastlio`` is FAST-LIO's 23-dimensional ``state_ikfom`` (the same three blocks, the
lidar-IMU extrinsic and the gravity on S², a :class:`~liebridge.conventions.sphere.Sphere`); it
converts to bundles of the same blocks, and its IMU part (``FASTLIO.marginal``,
``FASTLIO.sub_element``, the preset ``fastlio_imu``) to every 15-dimensional preset. ``mola`` is
MOLA's 9-dimensional preintegrated-IMU chart (MOLA propagates no bias covariance).

See ``docs/navigation-states.md`` for the table with sources.
"""

from __future__ import annotations

from .bundle import Bundle, Vector
from .chart import Chart
from .convention import Convention
from .navstate import NavChart
from .presets import GTSAM, GTSAM_NAVSTATE
from .sphere import Sphere

_BIAS_BLOCKS: list[tuple[str, Vector]] = [("b_a", Vector(3)), ("b_g", Vector(3))]
#: Tangent permutation for (nav 9, δb_g, δb_a) — the gyroscope bias first.
_GYRO_FIRST = [*range(9), 12, 13, 14, 9, 10, 11]


def _state(
    name: str, nav: Convention | NavChart, order: list[int] | None, source: str, notes: str
) -> Bundle:
    return Bundle.of(name, [("nav", nav), *_BIAS_BLOCKS], order=order, source=source, notes=notes)


GTSAM_COMBINED = _state(
    "gtsam_combined",
    GTSAM_NAVSTATE,
    None,
    source="V GTSAM 4.3.0 PyPI wheel (NavState.retract; CombinedImuFactor residual); "
    "S gtsam/navigation/CombinedImuFactor.cpp (evaluateError: 15-vector, bias part b_i − b_j), "
    "gtsam/navigation/NavState.cpp (retract), gtsam/navigation/ImuBias.h (vector() = (acc, gyro))",
    notes=(
        "d = (δθ, δp, δv, δb_a, δb_g): NavState.retract ((R·Exp(δθ), p + R·δp, v + R·δv), "
        "component-wise in the body frame) followed by additive biases; the chart of "
        "PreintegratedCombinedMeasurements' covariance and of CombinedImuFactor's residual. "
        "False: retract = X·NavState.Expmap(δ) (the coupled SE₂(3) one); false: the biases come "
        "(gyro, acc) as in OpenVINS/Basalt (ConstantBias.vector() is (acc, gyro))."
    ),
)
"""GTSAM combined IMU chart: NavState (θ, p, v) body-frame split, then (δb_a, δb_g)."""

_GTSAM_POSE_VEL = NavChart.of(
    "gtsam_pose_velocity",
    GTSAM,
    "world",
    source="V GTSAM 4.3.0 PyPI wheel (Pose3.retract, Vector3 +)",
    notes="(Pose3 (ω, v) right SE(3) exponential, world-frame velocity added).",
)

GTSAM_IMU_KEYS = _state(
    "gtsam_imu_keys",
    _GTSAM_POSE_VEL,
    None,
    source="V GTSAM 4.3.0 PyPI wheel (Pose3.retract, Marginals.jointMarginalCovariance("
    "[X(i), V(i), B(i)]).fullMatrix(): blocks in the order of the keys given, measured); "
    "S gtsam/navigation/ImuFactor.h (pose, Vector3 velocity in the navigation frame, bias keys)",
    notes=(
        "d = (ω, ρ, δv, δb_a, δb_g): the graph's Pose3 key retracted as X·Exp(ω, ρ) (coupled "
        "SE(3)), the Vector3 velocity key v + δv (world frame), the ConstantBias key b + δb with "
        "(acc, gyro). What Marginals.jointMarginalCovariance([X(i), V(i), B(i)]).fullMatrix() "
        "returns, in that key order. False: it equals the NavState chart (gtsam_combined): the "
        "pose part is coupled and the velocity increment is in the world, not the body frame."
    ),
)
"""A GTSAM graph's Pose3, world velocity and bias keys (what ``Marginals`` gives), in (X, V, B)."""

KIMERA = _state(
    "kimera",
    _GTSAM_POSE_VEL,
    None,
    source="S Kimera-VIO src/backend/VioBackend.cpp (computeStateCovariance: marginals of "
    "[pose, velocity, imu bias] symbols, reordered by UtilsOpenCV::Covariance_bvx2xvb); GTSAM "
    "Pose3/Vector3/imuBias::ConstantBias keys",
    notes=(
        "Kimera-VIO's state covariance: gtsam_imu_keys' chart and order (ω, ρ, δv, δb_a, δb_g). "
        "False: the marginals come (bias, velocity, pose) — Kimera reorders bvx → xvb itself."
    ),
)
"""Kimera-VIO: GTSAM's Pose3 / velocity / bias keys, (x, v, b) order."""

_OPENVINS_POSE = Convention(
    name="openvins_pose",
    side="right",
    order="rot_first",
    chart="so3xr3_world",
    rotation="cayley",
    quat_order="jpl",
)
OPENVINS = _state(
    "openvins",
    NavChart.of("openvins_nav", _OPENVINS_POSE, "world"),
    _GYRO_FIRST,
    source="S OpenVINS ov_core/src/types/JPLQuat.h (update: dq = quatnorm([½δθ; 1]), "
    "q ← dq ⊗ q, JPL q_GtoI stored (x, y, z, w)), ov_core/src/types/IMU.h (error state "
    "(θ, p, v, b_g, b_a); p_IinG, v_IinG, bg, ba added), ov_core/src/utils/quat_ops.h",
    notes=(
        "d = (δθ, δp, δv, δb_g, δb_a). The JPL update δq ⊗ q̄ of q_GtoI is "
        "R_ItoG ← R_ItoG·Cay(δθ) (Cay(r) = (I − r^/2)⁻¹(I + r^/2), the rotation of "
        "normalize(1, r/2)): a right (body-frame) update with Cayley/Gibbs coordinates; p_IinG, "
        "v_IinG added in the global frame. The element's R is R_ItoG = "
        "quaternion.to_matrix(q_GtoI, order='jpl').T. False: reading q_GtoI as a Hamilton "
        "quaternion gives R_GtoI (it gives R_ItoG); false: δθ is a left/global rotation error "
        "(δq multiplies q_GtoI on the left, which is the body side of R_ItoG)."
    ),
)
"""OpenVINS IMU state: JPL ``q_GtoI``, (θ, p, v, b_g, b_a), Cayley right rotation, world p, v."""

VINS = _state(
    "vins",
    NavChart.of(
        "vins_nav",
        Convention(
            name="vins_pose",
            side="right",
            order="trans_first",
            chart="so3xr3_world",
            rotation="cayley",
            quat_order="xyzw",
        ),
        "world",
    ),
    None,
    source="S VINS-Mono/VINS-Fusion vins_estimator/src/factor/pose_local_parameterization.cpp "
    "(Plus: p + δp, (q ⊗ (1, ½δθ)).normalized(), Utility::deltaQ), estimator.h para_SpeedBias "
    "(v, b_a, b_g) added; parameters.h StateOrder (O_P 0, O_R 3, O_V 6, O_BA 9, O_BG 12)",
    notes=(
        "d = (δp, δθ, δv, δb_a, δb_g): p + δp (world), q ⊗ normalize(1, ½δθ) (Hamilton, Eigen "
        "xyzw storage): R·Cay(δθ), a right update whose first-order scale is 1; v, b_a, b_g "
        "added. False: Ceres's QuaternionManifold half angle (exp of δ/2·2); false: the rotation "
        "increment is exactly Exp(δθ) (it is the Cayley map, equal to second order only)."
    ),
)
"""VINS-Mono/Fusion: (p, θ, v, b_a, b_g), Cayley right rotation, world p, v."""

BASALT = _state(
    "basalt",
    NavChart.of(
        "basalt_nav",
        Convention(
            name="basalt_pose",
            side="left",
            order="trans_first",
            chart="so3xr3_world",
            rotation="exp",
            quat_order="xyzw",
        ),
        "world",
    ),
    _GYRO_FIRST,
    source="S basalt-headers include/basalt/imu/imu_types.h (PoseState::incPose: R' = Exp(ω)·R, "
    "p' = p + υ; PoseVelBiasState::applyInc: [trans, rot, vel, bias_gyro, bias_accel])",
    notes=(
        "d = (δp, δθ, δv, δb_g, δb_a): Exp(δθ)·R (left, world frame), p, v, biases added. "
        "False: Basalt's increment is Sophus's SE3 right perturbation T·Exp(ξ)."
    ),
)
"""Basalt ``PoseVelBiasState``: (p, θ, v, b_g, b_a), left rotation, world p, v."""

ORBSLAM3 = _state(
    "orbslam3",
    NavChart.of(
        "orbslam3_nav",
        Convention(
            name="orbslam3_pose",
            side="right",
            order="rot_first",
            chart="so3xr3_body",
            rotation="exp",
            quat_order="wxyz",
        ),
        "world",
    ),
    _GYRO_FIRST,
    source="S ORB-SLAM3 src/G2oTypes.cc (ImuCamPose::Update: twb += Rwb·ut, Rwb = "
    "Rwb·ExpSO3(ur), pu = (ur, ut); VertexVelocity, VertexGyroBias, VertexAccBias added), "
    "src/Optimizer.cc (15×15 H of ConstraintPoseImu: pose, velocity, gyro bias, acc bias)",
    notes=(
        "d = (δθ, δp, δv, δb_g, δb_a): R·Exp(δθ), p + R·δp (body frame), v + δv (world), "
        "biases added. False: the velocity increment is body-frame like GTSAM's NavState "
        "(ORB-SLAM3's pose update is body-frame, its velocity vertex is not)."
    ),
)
"""ORB-SLAM3 inertial vertices: (θ, p, v, b_g, b_a), right rotation, body p, world v."""

# ----------------------------------------------------------------------------- FAST-LIO
_FASTLIO_REF = "hku-mars/FAST_LIO @ 1087a72497d19c3ac19a608b89e28b5e62b00e2a"
#: FAST-LIO's gravity: MTK ``S2<double, 98090, 10000, 1>``, length den/num = 9.809, S2_typ 1.
FASTLIO_GRAVITY = Sphere(length=98090 / 10000, basis="mtk_x", name="fastlio_gravity")
_FASTLIO_NAV = NavChart.of(
    "fastlio_nav",
    Convention(
        name="fastlio_pose",
        side="right",
        order="trans_first",
        chart="so3xr3_world",
        rotation="exp",
        quat_order="xyzw",
    ),
    "world",
)
_FASTLIO_EXTRINSIC = Convention(
    name="fastlio_extrinsic",
    side="right",
    order="rot_first",
    chart="so3xr3_world",
    rotation="exp",
    quat_order="xyzw",
)
#: Block concatenation: nav (δp 0-2, δθ 3-5, δv 6-8), b_a 9-11, b_g 12-14, T_imu_lidar
#: (δθ_LI 15-17, δt_LI 18-20), gravity 21-22; FAST-LIO's order (p, R, R_LI, t_LI, v, bg, ba, g):
_FASTLIO_ORDER = [*range(6), *range(15, 21), 6, 7, 8, 12, 13, 14, 9, 10, 11, 21, 22]
_FASTLIO_SOURCE = (
    f"S {_FASTLIO_REF}: include/use-ikfom.hpp (MTK_BUILD_MANIFOLD(state_ikfom, pos, rot, "
    "offset_R_L_I, offset_T_L_I, vel, bg, ba, grav); typedef MTK::S2<double, 98090, 10000, 1> "
    "S2; df_dx's blocks (12, 3) ∂vel/∂rot, (12, 18) ∂vel/∂ba, (12, 21) ∂vel/∂grav, (3, 15) "
    "∂rot/∂bg confirm the offsets 0, 3, 6, 9, 12, 15, 18, 21), "
    "include/IKFoM_toolkit/mtk/types/SOn.hpp (SO3::boxplus: *this = *this * exp(vec); "
    "boxminus: log(other.conjugate() * *this)), include/IKFoM_toolkit/mtk/types/S2.hpp "
    "(S2::boxplus: vec = Exp(S2_Bx δ)·vec; boxminus; S2_Bx), "
    "include/IKFoM_toolkit/mtk/src/mtkmath.hpp (MTK::exp with scale ½: the unit quaternion of "
    "the rotation vector), include/IKFoM_toolkit/mtk/types/vect.hpp (vect: added), "
    "src/laserMapping.cpp (pointBodyToWorld: rot·(offset_R_L_I·p + offset_T_L_I) + pos, so "
    "rot = R_world_imu and (offset_R_L_I, offset_T_L_I) = T_imu_lidar)"
)
FASTLIO = Bundle.of(
    "fastlio",
    [
        ("nav", _FASTLIO_NAV),
        *_BIAS_BLOCKS,
        ("T_imu_lidar", _FASTLIO_EXTRINSIC),
        ("gravity", FASTLIO_GRAVITY),
    ],
    order=_FASTLIO_ORDER,
    source=_FASTLIO_SOURCE,
    notes=(
        "FAST-LIO's 23-dimensional error state of state_ikfom, "
        "d = (δp, δθ, δθ_LI, δt_LI, δv, δb_g, δb_a, δg): pos + δp (world), rot·Exp(δθ) "
        "(right, rot = R_world_imu), offset_R_L_I·Exp(δθ_LI) and offset_T_L_I + δt_LI (the "
        "lidar in the IMU frame, T_imu_lidar), vel + δv (world), biases added, and the gravity "
        "g (world frame, ‖g‖ = 9.809) moved as Exp(S2_Bx(g)·δg)·g with MTK's S2_typ-1 basis. "
        "False: FAST-LIO's error state is 24-dimensional with a 3-vector gravity (it is 23: "
        "gravity is on S², 2 entries; the 24 rows of get_f/df_dx are the process model's); "
        "false: the pose chart is SE(3)'s T·Exp(ξ) (rotation and position are perturbed "
        "separately, position in the world frame); false: δg is the direction of motion of g "
        "(it is the rotation axis S2_Bx·δg, perpendicular to it)."
    ),
)
"""FAST-LIO(2) ``state_ikfom``: 23-dim (p, θ, θ_LI, t_LI, v, b_g, b_a, g ∈ S²)."""

FASTLIO_IMU = FASTLIO.sub(
    ["nav", "b_a", "b_g"],
    name="fastlio_imu",
    source=_FASTLIO_SOURCE,
    notes=(
        "The IMU part of fastlio: d = (δp, δθ, δv, δb_g, δb_a), FAST-LIO's charts and relative "
        "order (pos + δp world, rot·Exp(δθ), vel + δv world, biases added). Its covariance is "
        "FASTLIO.marginal(P, ['nav', 'b_a', 'b_g']) (the rows/columns 0-5, 12-20 of FAST-LIO's "
        "P; exact, each block is retracted by its own entries), its element "
        "FASTLIO.sub_element(X, [...]); it converts to every 15-dimensional preset. False: "
        "FAST-LIO's (p, R, v, bg, ba) block reordered is GTSAM's covariance (GTSAM's δp, δv "
        "are body-frame: convert it). Into OpenVINS (right rotation, world p and v) the "
        "first-order map is the reordering (Cayley and exp agree to second order)."
    ),
)
"""FAST-LIO's IMU sub-state (p, θ, v, b_g, b_a): 15-dim, converts to the other 15-dim presets."""

# ----------------------------------------------------------------------------- MOLA
_MOLA_REF = "MOLAorg/mola_imu_preintegration @ 467fc53c1bcb7a22983b5c95f41d66de7a5209ba"
MOLA = NavChart.of(
    "mola",
    Convention(
        name="mola_pose",
        side="right",
        order="rot_first",
        chart="so3xr3_world",
        rotation="exp",
        quat_order="wxyz",
    ),
    "world",
    order=[0, 1, 2, 6, 7, 8, 3, 4, 5],
    source=(
        f"S {_MOLA_REF}: include/mola_imu_preintegration/ImuPreintegrator.h "
        "(PreintegrationCovariance 9×9 'ordered as [theta(3), v(3), p(3)]'; 'Only the noise of "
        "the raw readings is propagated here; bias uncertainty is handled by the estimator via "
        "the Jacobians'), src/ImuPreintegrator.cpp (integrate_measurement: A = [[ΔR_incᵀ, 0, "
        "0], [−ΔR a^ dt, I, 0], [−½ΔR a^ dt², I dt, I]], Bg = [Jr dt; 0; 0], Ba = [0; ΔR dt; "
        "½ΔR dt²]; bias_corrected: deltaRij·Exp(dR_dbg δb_g), deltaVij + ..., deltaPij + ...)"
    ),
    notes=(
        "MOLA's preintegrated IMU measurement (ΔR_ij, Δv_ij, Δp_ij) (element nav_state(ΔR_ij, "
        "Δp_ij, Δv_ij), in the body frame of i) and its covariance: d = (δθ, δv, δp), "
        "ΔR·Exp(δθ) (right), Δv + δv, Δp + δp (additive). 9-dimensional: MOLA propagates no "
        "bias covariance (there is no 15-dim MOLA state to convert). False: the order is "
        "GTSAM's (θ, p, v) (it is (θ, v, p)); false: δp, δv are rotated by ΔR as in GTSAM's "
        "NavState.retract (they are added)."
    ),
)
"""MOLA's preintegrated-IMU covariance chart: 9-dim (θ, v, p), right rotation, additive v, p."""

#: The 15-dimensional whole-state presets (every pair converts), in registry order.
STATE_PRESETS_15: tuple[Bundle, ...] = (
    GTSAM_COMBINED,
    GTSAM_IMU_KEYS,
    OPENVINS,
    VINS,
    BASALT,
    ORBSLAM3,
    KIMERA,
    FASTLIO_IMU,
)
#: Every whole-state preset in the registry: the 15-dimensional ones, MOLA's 9-dimensional
#: chart (an SE₂(3) convention: it converts to ``gtsam_navstate``, ``manif_se23``, every
#: ``NavChart``) and FAST-LIO's 23-dimensional state.
STATE_PRESETS: tuple[Chart, ...] = (*STATE_PRESETS_15, MOLA, FASTLIO)
