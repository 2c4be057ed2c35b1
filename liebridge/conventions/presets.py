"""Named presets for real libraries, each with its evidence.

Notation: right = ``X·Exp(d)``, left = ``Exp(d)·X``; ``(ω, v)`` = rotation first. Evidence codes as
in ``docs/library-facts.md``: **V** checked by running the library, with the version measured
(re-measured by ``tests/test_presets_run.py`` and by ``liebridge conventions verify`` against the
installed version), **S** read in its source, **D** docs, **N** why no library runs it here.
Every preset lists the defining identity of its ``retract`` and, where one tempts, a false one.
A library without quaternions still gets a ``quat_order`` (it never enters a retraction); that is
said in its notes.
"""

from __future__ import annotations

from dataclasses import dataclass

from .convention import Convention, Embed

GTSAM = Convention(
    name="gtsam",
    side="right",
    order="rot_first",
    chart="se3",
    rotation="exp",
    quat_order="wxyz",
    source="V GTSAM 4.3.0 PyPI wheel (Pose3.retract, localCoordinates); S gtsam/base/Lie.h",
    notes=(
        "Pose3.retract(ξ) = X·Exp(ξ), ξ = (ω, v), true SE(3) exp (wheel built with "
        "GTSAM_POSE3_EXPMAP=ON). False: retract(ξ) = Exp(ξ)·X (a common error, "
        "docs/common-formula-errors.md E1). "
        "Quaternions: the constructor Rot3.Quaternion(w, x, y, z) takes wxyz; "
        "toQuaternion().coeffs() is Eigen's xyzw."
    ),
)
"""GTSAM ``Pose3``/``Rot3`` (PyPI wheel): right, (ω, v), SE(3) exp, rotation vector, wxyz."""

GTSAM_CAYLEY = Convention(
    name="gtsam_cayley",
    side="right",
    order="rot_first",
    chart="so3xr3_body",
    rotation="cayley",
    quat_order="wxyz",
    source="S gtsam/geometry/Pose3.cpp ChartAtOrigin, Rot3M.cpp CayleyChart "
    "(GTSAM_POSE3_EXPMAP=OFF); N the wheel is an exp build (verify: DIFFERS)",
    notes=(
        "retract(ξ) = (R·Cay(ω), t + R·v), Cay(ω) = (I − hat(ω)/2)⁻¹(I + hat(ω)/2). "
        "False: retract(ξ) = X·Exp(ξ) (agrees only to first order)."
    ),
)
"""GTSAM built with ``GTSAM_POSE3_EXPMAP=OFF`` (default before mid-2020): decoupled Cayley chart."""

SOPHUS = Convention(
    name="sophus",
    side="right",
    order="trans_first",
    chart="se3",
    rotation="exp",
    quat_order="xyzw",
    source="V projectaria-tools 2.3.0 sophus.SE3 (C++ Sophus exp, log, product), sophuspy "
    "1.2.0 SE3/SO3; S Sophus sophus/se3.hpp (SE3::exp, tangent (υ, ω)), sophus/ceres_manifold.hpp "
    "(T·exp(δ): the side)",
    notes=(
        "retract(d) = X·exp(d), d = (υ, ω). SE3::params() = [qx, qy, qz, qw, tx, ty, tz]. "
        "False: d = (ω, υ) as in GTSAM."
    ),
)
"""Sophus (C++): right, (v, ω), SE(3) exp; params storage xyzw then translation."""

MANIF = Convention(
    name="manif",
    side="right",
    order="trans_first",
    chart="se3",
    rotation="exp",
    quat_order="xyzw",
    source="S manif include/manif/impl/lie_group_base.h (plus = rplus), impl/se3/SE3Tangent.h; "
    "N no manifpy wheel on PyPI",
    notes=(
        "X.plus(d) = X.rplus(d) = X·Exp(d), d = (ρ, θ); X.minus(Y) = Log(Y⁻¹X). "
        "coeffs = [x, y, z, qx, qy, qz, qw]. False: X.minus(Y) = Log(X⁻¹Y) (argument order)."
    ),
)
"""manif: right (``plus`` = ``rplus``), (v, ω), SE(3) exp; coeffs xyz then xyzw."""

PINOCCHIO = Convention(
    name="pinocchio",
    side="right",
    order="trans_first",
    chart="se3",
    rotation="exp",
    quat_order="xyzw",
    source="V pin 4.1.0 (integrate/difference on the free-flyer, exp6/log6); "
    "tests/test_presets_libs.py",
    notes=(
        "integrate(q, v) = X·exp6(v), v = (linear, angular); q = [x, y, z, qx, qy, qz, qw]. "
        "False: the free-flyer integrates rotation and translation separately "
        "(that is the R3×SO3 Lie group, preset pinocchio_r3xso3)."
    ),
)
"""Pinocchio free-flyer / ``exp6``: right, (v, ω), SE(3) exp; XYZQUAT storage (xyzw)."""

PINOCCHIO_R3XSO3 = Convention(
    name="pinocchio_r3xso3",
    side="right",
    order="trans_first",
    chart="so3xr3_world",
    rotation="exp",
    quat_order="xyzw",
    source="V pin 4.1.0 liegroups R3×SO3 (integrate/difference); tests/test_presets_libs.py",
    notes=(
        "integrate(q, d) = (t + u, R·Exp(ω)), d = (u, ω): translation added in the world frame. "
        "False: integrate = X·exp6(d)."
    ),
)
"""Pinocchio ``R3 × SO3`` Lie group: right rotation, world-frame translation, (v, ω)."""

JAXLIE = Convention(
    name="jaxlie",
    side="right",
    order="trans_first",
    chart="se3",
    rotation="exp",
    quat_order="wxyz",
    source="V jaxlie 1.5.0 (manifold.rplus/rminus on SE3); S jaxlie/_se3.py",
    notes="rplus(X, d) = X·exp(d), d = (v, ω); SE3.wxyz_xyz = [qw, qx, qy, qz, x, y, z].",
)
"""jaxlie: right (``rplus``), (v, ω), SE(3) exp; storage ``wxyz_xyz``."""

THESEUS = Convention(
    name="theseus",
    side="right",
    order="trans_first",
    chart="se3",
    rotation="exp",
    quat_order="wxyz",
    source="V theseus-ai 0.2.3 (SE3.retract/local); S theseus/geometry/se3.py (retract = "
    "compose(exp_map)), quaternion helpers wxyz",
    notes="retract(X, d) = X·exp(d), d = (v, ω).",
)
"""Theseus: right, (v, ω), SE(3) exp; quaternions wxyz."""

PYPOSE = Convention(
    name="pypose",
    side="left",
    order="trans_first",
    chart="se3",
    rotation="exp",
    quat_order="xyzw",
    source="V pypose 0.9.5 (SE3 Retr, Log); S pypose/lietensor/lietensor.py (Retr = Exp(d)·X), "
    "storage [tx, ty, tz, qx, qy, qz, qw]",
    notes="X.Retr(d) = Exp(d)·X (left), d = (τ, φ). False: X·Exp(d).",
)
"""PyPose: left, (v, ω), SE(3) exp; storage translation then xyzw."""

BARFOOT = Convention(
    name="barfoot",
    side="left",
    order="trans_first",
    chart="se3",
    rotation="exp",
    quat_order="wxyz",
    source="V utiasSTARS liegroups (source package) SE3.perturb; D Barfoot, State Estimation for "
    "Robotics, 2nd ed., §7.1.7 (ξ = (ρ, φ)); N not on the package index",
    notes=(
        "perturb: T ← Exp(ξ)·T, ξ = (ρ, φ) (left, translation first). False: the utiasSTARS "
        "package is `pip install liegroups` — that name on PyPI is an unrelated package."
    ),
)
"""Barfoot / utiasSTARS ``liegroups``: left, (ρ, φ) = (v, ω), SE(3) exp."""

PYTRANSFORM3D_GLOBAL = Convention(
    name="pytransform3d_global",
    side="left",
    order="rot_first",
    chart="se3",
    rotation="exp",
    quat_order="wxyz",
    source="V pytransform3d 3.17.0 concat_globally_uncertain_transforms (Monte Carlo); "
    "tests/test_presets_libs.py",
    notes=(
        "Global uncertainty: T = Exp(ξ)·T̄, ξ = (ω, v) (exponential coordinates, rotation first). "
        "pq = [x, y, z, qw, qx, qy, qz]."
    ),
)
"""pytransform3d "global" uncertainty: left, (ω, v), SE(3) exp; ``pq`` stores wxyz."""

PYTRANSFORM3D_LOCAL = Convention(
    name="pytransform3d_local",
    side="right",
    order="rot_first",
    chart="se3",
    rotation="exp",
    quat_order="wxyz",
    source="V pytransform3d 3.17.0 concat_locally_uncertain_transforms; tests/test_presets_libs.py",
    notes="Local uncertainty: T = T̄·Exp(ξ), ξ = (ω, v) — identical to GTSAM's tangent.",
)
"""pytransform3d "local" uncertainty: right, (ω, v), SE(3) exp (same fields as GTSAM)."""

SYMFORCE = Convention(
    name="symforce",
    side="right",
    order="rot_first",
    chart="so3xr3_world",
    rotation="exp",
    quat_order="xyzw",
    source="V symforce-sym 0.12.0 (Pose3/Rot3 retract, local_coordinates); S "
    "symforce/geo/pose3.py docstring (retract is not a group op)",
    notes=(
        "Pose3.retract(a, v) = (R·Exp(ω), t + v), v = (ω, t). Stated by symforce itself: "
        "retract(a, v) != compose(a, from_tangent(v)). Storage [qx, qy, qz, qw, x, y, z]."
    ),
)
"""symforce ``Pose3``: right rotation, **world**-frame translation, (ω, t); storage xyzw."""

CERES_QUATERNION = Convention(
    name="ceres_quaternion",
    side="left",
    order="rot_first",
    chart="so3xr3_world",
    rotation="half_exp",
    quat_order="wxyz",
    source="V pyceres 2.6 (Ceres 2.2.0) QuaternionManifold, one Gauss–Newton step; "
    "S include/ceres/manifold.h",
    notes=(
        "SO(3) manifold: Plus(q, δ) = q(δ) ⊗ q, q(δ) = [cos‖δ‖, sin‖δ‖·δ/‖δ‖]: the rotation angle "
        "is 2‖δ‖ (half-angle tangent, left). Storage [w, x, y, z]. False: Plus = q ⊗ exp(δ) "
        "(right, full angle; Ceres master used the full angle Jun 2025–Jul 2026, no release did). "
        "On a pose, as a product with a Euclidean translation block: see ceres_pose."
    ),
)
"""Ceres ``QuaternionManifold`` (2.2): left, half angle, wxyz (SO(3); on poses ``ceres_pose``)."""

CERES_EIGEN_QUATERNION = Convention(
    name="ceres_eigen_quaternion",
    side="left",
    order="rot_first",
    chart="so3xr3_world",
    rotation="half_exp",
    quat_order="xyzw",
    source="V pyceres 2.6 (Ceres 2.2.0) EigenQuaternionManifold, one Gauss–Newton step; "
    "S ceres/manifold.h",
    notes="As ceres_quaternion, with Eigen's storage [x, y, z, w].",
)
"""Ceres ``EigenQuaternionManifold`` (2.2): left, half angle, xyzw."""

CERES_POSE = Convention(
    name="ceres_pose",
    side="left",
    order="rot_first",
    chart="so3xr3_world",
    rotation="half_exp",
    quat_order="wxyz",
    source="V pyceres 2.6 (Ceres 2.2.0) QuaternionManifold × Euclidean<3>, one Gauss–Newton "
    "step; S include/ceres/product_manifold.h (ProductManifold<QuaternionManifold, "
    "EuclideanManifold<3>> over a [qw, qx, qy, qz, x, y, z] block)",
    notes=(
        "Plus((q, t), (δ, u)) = (q(δ) ⊗ q, t + u): left half-angle rotation, world translation, "
        "rotation block first (the product's order; reverse it for a [t, q] block)."
    ),
)
"""Ceres pose as ``ProductManifold(QuaternionManifold, Euclidean<3>)``: left half angle, world t."""

G2O = Convention(
    name="g2o",
    side="right",
    order="trans_first",
    chart="so3xr3_body",
    rotation="quat_vec",
    quat_order="xyzw",
    source="V g2opy 2.3.0 (VertexSE3.oplus, EdgeSE3 error); S g2o types/slam3d/vertex_se3.h "
    "(oplusImpl: _estimate * increment), "
    "edge_se3.cpp, isometry3d_mappings.cpp (toVectorMQT/fromVectorMQT)",
    notes=(
        "VertexSE3 oplus: X ← X·[R(q(r)), u], q(r) = (sqrt(1 − ‖r‖²), r): d = (u, r), r the "
        "quaternion vector part (≈ θ/2). EDGE_SE3:QUAT error = toVectorMQT(Z⁻¹·Xi⁻¹·Xj) = "
        "local(Z, Xi⁻¹Xj); its information is over (x, y, z, qx, qy, qz). False: that information "
        "is over the rotation angle (gtsam.readG2o reads it so: 4× the rotation weight)."
    ),
)
"""g2o ``VertexSE3`` / ``EDGE_SE3:QUAT``: right, (t, qvec), decoupled body chart, quat vector."""

G2O_EXPMAP = Convention(
    name="g2o_expmap",
    side="left",
    order="rot_first",
    chart="se3",
    rotation="exp",
    quat_order="xyzw",
    source="V g2opy 2.3.0 VertexSE3Expmap; S g2o types/sba/vertex_se3_expmap.cpp "
    "(setEstimate(SE3Quat::exp(update) * estimate()))",
    notes="VertexSE3Expmap (ORB-SLAM style) oplus: X ← Exp(ξ)·X, ξ = (ω, v).",
)
"""g2o ``VertexSE3Expmap`` (ORB-SLAM): left, (ω, v), SE(3) exp."""

ROS = Convention(
    name="ros",
    side="left",
    order="trans_first",
    chart="so3xr3_world",
    rotation="exp",
    quat_order="xyzw",
    source="S geometry_msgs/PoseWithCovariance.msg (noetic, ROS 2): covariance over "
    "(x, y, z, rotX, rotY, rotZ), rotations about the parent frame's fixed axes; N a message, "
    "no update to run",
    notes=(
        "ROS defines no retraction; this preset's retract (t + u, Exp(ω)·R) is the one whose "
        "first-order map reproduces the message semantics: from GTSAM's tangent, "
        "[[0, R], [R, 0]]. False: the covariance is P·Ad_X (left SE(3)), which couples "
        "translation with rotation."
    ),
)
"""ROS ``PoseWithCovariance``: parent-frame position, fixed-axis rotation, (x, y, z, rx, ry, rz)."""

MR_BODY = Convention(
    name="mr_body",
    side="right",
    order="rot_first",
    chart="se3",
    rotation="exp",
    quat_order="wxyz",
    source="V modern-robotics 1.1.1 (MatrixExp6/MatrixLog6, body twist); D Lynch & Park, Modern "
    "Robotics §3.3",
    notes="Body twist V_b = (ω_b, v_b): T·e^[V_b]. No quaternions (quat_order unused).",
)
"""Modern Robotics body twist: right, (ω, v), SE(3) exp."""

MR_SPACE = Convention(
    name="mr_space",
    side="left",
    order="rot_first",
    chart="se3",
    rotation="exp",
    quat_order="wxyz",
    source="V modern-robotics 1.1.1 (MatrixExp6/MatrixLog6, space twist); D Lynch & Park, Modern "
    "Robotics §3.3",
    notes="Space twist V_s = (ω_s, v_s): e^[V_s]·T; V_s = Ad_T V_b. No quaternions.",
)
"""Modern Robotics space twist: left, (ω, v), SE(3) exp."""

LIETORCH = Convention(
    name="lietorch",
    side="left",
    order="trans_first",
    chart="se3",
    rotation="exp",
    quat_order="xyzw",
    source="S princeton-vl/lietorch@e7df865 lietorch/groups.py:153-156 (retr: 'Exp(a) * X'), "
    ":44-45 (LieGroupParameter.add_ = exp(update)·group), :265-272 (SE3 storage [t, q_xyzw]); "
    "include/se3.h:34-43, 89-97 (exp with the left Jacobian V, tangent (tau, phi)); "
    "src/lietorch_gpu.cu:41-42 (gradients w.r.t. a left perturbation). N read, not run: "
    "lietorch builds only with CUDA; its convention is PyPose's, measured through pypose",
    notes=(
        "X.retr(a) = Exp(a)·X (left), a = (τ, φ) translation first, the true SE(3) exp; storage "
        "SE3.data = [tx, ty, tz, qx, qy, qz, qw]; gradients are taken w.r.t. a left "
        "perturbation. Same convention as PyPose (which ships Jr, lietorch Jinv). False: "
        "X·Exp(a), and data = [qw, qx, qy, qz, ...] (the wxyz swap of lietorch#14)."
    ),
)
"""lietorch ``SE3``: left, (τ, φ), SE(3) exp; storage ``[tx, ty, tz, qx, qy, qz, qw]``.

Storage order ``[t, q_xyzw]``; tangent order (translation, rotation); side left,
``retr(a) = Exp(a)·X``. Defining identity: ``X.retr(a).matrix() = expm(hat(a))·X.matrix()`` with
``hat`` of ``(τ, φ)``. Tempting and false: ``X·Exp(a)`` (Theseus's side), or a quaternion stored
``wxyz``. Read in the source (CUDA only, not run here); PyPose's identical convention is run.
"""

DPVO = Convention(
    name="dpvo",
    side="left",
    order="trans_first",
    chart="se3",
    rotation="exp",
    quat_order="xyzw",
    stores="inverse",
    source="S lietorch on the stored inverse T_cam_world: princeton-vl/DPVO dpvo/dpvo.py "
    "(terminate: poses.inv(), 'internal representation is world-to-camera'), dpvo/ba.py "
    "(poses updated with lietorch retr); princeton-vl/"
    "DROID-SLAM droid_slam/droid.py (terminate returns camera_trajectory.inv()); DPVO#27, "
    "DROID-SLAM#77; lietorch as the 'lietorch' preset. N not run: lietorch needs CUDA; the "
    "same update is run with PyPose's identical convention on the stored inverse",
    notes=(
        "DPVO and DROID-SLAM keep T_cam_world (world→camera) in lietorch and update it "
        "Exp(a)·T_cam_world. On liebridge's element T_world_cam that is "
        "T_world_cam·Exp(−P·a), P = (τ, φ) → (ω, v): a right update with the sign flipped. "
        "False: the stored 7-vector is the camera pose in the world (it is its inverse), and "
        "T_world_cam·Exp(P·a) (the sign)."
    ),
)
"""DPVO / DROID-SLAM (alias ``droid_slam``): lietorch on world→camera poses.

Storage ``[tx, ty, tz, qx, qy, qz, qw]`` of ``T_cam_world`` (the inverse of liebridge's
``T_world_cam``); tangent order (τ, φ); side left on the stored world→camera pose, so on
``T_world_cam``: ``retract(T, a) = T·Exp(−P·a)``. Defining identity: ``retract(T, a) =
inv(Exp(a)·inv(T))``. Tempting and false: treating the stored vector as ``T_world_cam``, or
dropping the minus sign (``T·Exp(P·a)``).
"""

KORNIA = Convention(
    name="kornia",
    side="right",
    order="trans_first",
    chart="se3",
    rotation="exp",
    quat_order="wxyz",
    source="V kornia 0.9.0 (Se3.exp/log, composition, Se3.r.q storage); "
    "S kornia/geometry/liegroup/se3.py",
    notes=(
        "Se3.exp(v), v = (υ, ω) (translation part first); Se3.r is a Quaternion stored "
        "(w, x, y, z); a * b is the matrix product. kornia has no update of its own: the side is "
        "the user's choice; this preset uses X·exp(v) (replace(KORNIA, side='left') for "
        "exp(v)·X). False: v = (ω, υ) as in GTSAM, and a quaternion stored (x, y, z, w)."
    ),
)
"""kornia ``Se3``: (υ, ω), SE(3) exp, quaternion ``(w, x, y, z)``; the side is the user's choice.

Storage: ``Se3.r`` a ``Quaternion`` with ``.data = [w, x, y, z]``, ``Se3.t`` the translation;
tangent order (υ, ω) for ``Se3.exp``/``log``; ``a * b`` is the matrix product. kornia has no
update (no ``retract``/``plus``), so the side is the user's: this preset takes ``X·Exp(v)``
(right, as Sophus, which kornia's ``Se3`` follows); ``dataclasses.replace(KORNIA, name=...,
side="left")`` gives the other. Defining identity: ``Se3.exp(v).matrix() = expm(hat(v))`` with
``hat`` of ``(υ, ω)``. Tempting and false: ``v = (ω, υ)`` (GTSAM's order), a quaternion read
``xyzw``.
"""

#: All presets, in registry order (ties in :func:`detect_convention` resolve to the first).
PRESETS: tuple[Convention, ...] = (
    GTSAM,
    GTSAM_CAYLEY,
    SOPHUS,
    MANIF,
    PINOCCHIO,
    PINOCCHIO_R3XSO3,
    JAXLIE,
    THESEUS,
    PYPOSE,
    LIETORCH,
    DPVO,
    BARFOOT,
    PYTRANSFORM3D_GLOBAL,
    PYTRANSFORM3D_LOCAL,
    SYMFORCE,
    CERES_QUATERNION,
    CERES_EIGEN_QUATERNION,
    CERES_POSE,
    G2O,
    G2O_EXPMAP,
    ROS,
    MR_BODY,
    MR_SPACE,
    KORNIA,
)


# ============================================================================ other groups
# Each group's canonical tangent is GTSAM's (see docs/design-groups.md): SE(2) (vx, vy, ω),
# Sim(3) (ω, u, λ), SE₂(3) (ω, ρ_p, ρ_v). ``order`` names where the rotation block sits; the
# Sim(3) log-scale is last in every library found.

GTSAM_ROT2 = Convention(
    name="gtsam_rot2",
    side="right",
    order="rot_first",
    chart="so2",
    rotation="exp",
    quat_order="wxyz",
    group="so2",
    source="V GTSAM 4.3.0 PyPI wheel (Rot2.retract, Rot2.Expmap); tests/test_conventions.py",
    notes="Rot2.retract(θ) = R·Exp(θ) = Exp(θ)·R (SO(2) is commutative). No quaternions.",
)
"""GTSAM ``Rot2``: the angle."""

GTSAM_POSE2 = Convention(
    name="gtsam_pose2",
    side="right",
    order="trans_first",
    chart="se2",
    rotation="exp",
    quat_order="wxyz",
    group="se2",
    source="V GTSAM 4.3.0 PyPI wheel (Pose2.retract, localCoordinates, Expmap); "
    "S gtsam/geometry/Pose2.cpp",
    notes=(
        "Pose2.retract(d) = X·Exp(d), d = (vx, vy, ω), true SE(2) exponential. False: "
        "d = (θ, x, y) (the order of the Pose2(x, y, θ) constructor is not the issue: the rotation "
        "is last) and retract(d) = (x + vx, y + vy, θ + ω). No quaternions."
    ),
)
"""GTSAM ``Pose2``: right, (vx, vy, ω), SE(2) exp."""

GTSAM_SIMILARITY3 = Convention(
    name="gtsam_similarity3",
    side="right",
    order="rot_first",
    chart="sim3",
    rotation="exp",
    quat_order="wxyz",
    group="sim3",
    source="V GTSAM 4.3.0 PyPI wheel (Similarity3.retract, Expmap, AdjointMap, matrix); "
    "S gtsam/geometry/Similarity3.cpp",
    notes=(
        "Similarity3.retract(d) = X·Exp(d), d = (ω, u, λ), Expmap = expm([[hat ω, u], [0, −λ]]). "
        "Trap: Similarity3(R, t_g, s).matrix() = [R t_g; 0 1/s] and transformFrom(p) = s(Rp + t_g),"
        " so liebridge's matrix [sR t; 0 1] has t = s·t_g: pass M / M[3, 3]. False: t_g is the "
        "translation of the map."
    ),
)
"""GTSAM ``Similarity3``: right, (ω, u, λ), Sim(3) exp; matrix [R t_g; 0 1/s] (t = s·t_g)."""

GTSAM_NAVSTATE = Convention(
    name="gtsam_navstate",
    side="right",
    order="rot_first",
    chart="split_body",
    rotation="exp",
    quat_order="wxyz",
    group="se23",
    source="V GTSAM 4.3.0 PyPI wheel (NavState.retract, localCoordinates, Expmap, matrix); "
    "S gtsam/navigation/NavState.cpp (retract)",
    notes=(
        "NavState.retract(d) = (R·Exp(δθ), p + R·δp, v + R·δv), d = (δθ, δp, δv): component-wise "
        "in the body frame. False: retract(d) = X·NavState.Expmap(d) (Expmap and AdjointMap are "
        "the coupled SE₂(3) ones; they differ from retract at second order)."
    ),
)
"""GTSAM ``NavState``: right rotation, body-frame position and velocity increments (split)."""

SOPHUS_SE2 = Convention(
    name="sophus_se2",
    side="right",
    order="trans_first",
    chart="se2",
    rotation="exp",
    quat_order="xyzw",
    group="se2",
    source="V sophuspy 1.2.0 (SE2.exp/log, product, numpy < 2); S Sophus sophus/se2.hpp "
    "(SE2::exp, tangent (υ, θ)), sophus/ceres_manifold.hpp (T·exp(δ): the side)",
    notes="retract(d) = X·exp(d), d = (υ1, υ2, θ); SE2::params() = [Re(z), Im(z), x, y].",
)
"""Sophus ``SE2``: right, (υ, θ), SE(2) exp."""

SOPHUS_SIM3 = Convention(
    name="sophus_sim3",
    side="right",
    order="trans_first",
    chart="sim3",
    rotation="exp",
    quat_order="xyzw",
    group="sim3",
    source="S Sophus sophus/sim3.hpp (Sim3::exp, tangent (υ, ω, σ)), sophus/ceres_manifold.hpp; "
    "N sophuspy binds no Sim3",
    notes=(
        "retract(d) = X·exp(d), d = (υ, ω, σ); Sim3::matrix() = [sR t; 0 1] (liebridge's). "
        "False: d = (σ, ...) scale first; the scale is stored in the quaternion's norm (s = |q|²)."
    ),
)
"""Sophus ``Sim3``: right, (υ, ω, σ), Sim(3) exp."""

MANIF_SE2 = Convention(
    name="manif_se2",
    side="right",
    order="trans_first",
    chart="se2",
    rotation="exp",
    quat_order="xyzw",
    group="se2",
    source="S manif include/manif/impl/se2/SE2Tangent_base.h (x, y, angle), "
    "impl/lie_group_base.h (plus = rplus); N no manifpy wheel on PyPI",
    notes="X.plus(d) = X·Exp(d), d = (ρx, ρy, θ); coeffs = [x, y, cos θ, sin θ]. "
    "False: X.minus(Y) = Log(X⁻¹Y) (it is Log(Y⁻¹X)).",
)
"""manif ``SE2``: right, (ρ, θ), SE(2) exp."""

MANIF_SE23 = Convention(
    name="manif_se23",
    side="right",
    order="trans_first",
    chart="se23",
    rotation="exp",
    quat_order="xyzw",
    group="se23",
    source="S manif include/manif/impl/se_2_3/SE_2_3Tangent_base.h (ρ, ν, θ), "
    "impl/lie_group_base.h (plus = rplus); N no manifpy wheel on PyPI",
    notes=(
        "X.plus(d) = X·Exp(d), d = (ρ, ν, θ) = (position, velocity, rotation) parts, coupled "
        "SE₂(3) exponential. False: manif's plus equals GTSAM's NavState.retract (that one is "
        "component-wise)."
    ),
)
"""manif ``SE_2_3``: right, (ρ, ν, θ), coupled SE₂(3) exp."""

JAXLIE_SE2 = Convention(
    name="jaxlie_se2",
    side="right",
    order="trans_first",
    chart="se2",
    rotation="exp",
    quat_order="wxyz",
    group="se2",
    source="V jaxlie 1.5.0 (manifold.rplus/rminus on SE2); S jaxlie/_se2.py (tangent (vx, vy, "
    "omega)), jaxlie/manifold/_manifold_helpers.py (rplus = X @ exp(d))",
    notes="rplus(X, d) = X·exp(d), d = (vx, vy, ω); SE2.unit_complex_xy = [cos, sin, x, y].",
)
"""jaxlie ``SE2``: right, (vx, vy, ω), SE(2) exp."""

SYMFORCE_POSE2 = Convention(
    name="symforce_pose2",
    side="right",
    order="rot_first",
    chart="split_world",
    rotation="exp",
    quat_order="xyzw",
    group="se2",
    source="V symforce-sym 0.12.0 (sym.Pose2.retract); S sym/ops/pose2/lie_group_ops.py",
    notes=(
        "Pose2.retract(d) = (R·Exp(θ), t + (x, y)), d = (θ, x, y): rotation first, translation "
        "added in the world frame. False: retract(d) = X·Exp(d). Storage [cos, sin, x, y]."
    ),
)
"""symforce ``Pose2``: (θ, x, y), world-frame translation increment (split)."""

THESEUS_SE2 = Convention(
    name="theseus_se2",
    side="right",
    order="trans_first",
    chart="se2",
    rotation="exp",
    quat_order="wxyz",
    group="se2",
    source="V theseus-ai 0.2.3 (SE2.retract/local); S theseus/geometry/se2.py (exp_map of "
    "(ux, uy, θ), retract = compose with exp_map)",
    notes="retract(X, d) = X·exp(d), d = (ux, uy, θ); storage [x, y, cos, sin].",
)
"""Theseus ``SE2``: right, (u, θ), SE(2) exp."""

G2O_SE2 = Convention(
    name="g2o_se2",
    side="right",
    order="trans_first",
    chart="split_world",
    rotation="exp",
    quat_order="xyzw",
    group="se2",
    source="V g2opy 2.3.0 (VertexSE2.oplus); S g2o/types/slam2d/vertex_se2.h (oplusImpl: "
    "t += update.head<2>(), angle = normalize_theta(angle + update[2]))",
    notes=(
        "The vertex chart, the one g2o's marginals and solver increments live in: "
        "oplus(d) = (t + (dx, dy), θ + dθ), d = (dx, dy, dθ): translation added in the world "
        "frame, angle added. False: oplus(d) = X·SE2(dx, dy, dθ) (body frame) — that is the "
        "chart of g2o's EDGE_SE2 error toVector(Z⁻¹·Xi⁻¹·Xj), preset g2o_se2_edge. g2o's SE(2) "
        "vertex chart and its edge-error chart differ: the vertex adds coordinates, the edge "
        "measures the relative pose in the first pose's frame. Convert g2o vertex covariances "
        "(marginals) with g2o_se2; write factors whose residual is g2o's edge error with "
        "g2o_se2_edge. No quaternions."
    ),
)
"""g2o ``VertexSE2`` update: (dx, dy, dθ), world-frame translation increment, angle added."""

G2O_SE2_EDGE = Convention(
    name="g2o_se2_edge",
    side="right",
    order="trans_first",
    chart="split_body",
    rotation="exp",
    quat_order="xyzw",
    group="se2",
    source="V g2opy 2.3.0 (EdgeSE2.compute_error); S g2o/types/slam2d/edge_se2.h (computeError: "
    "toVector(Z⁻¹·Xi⁻¹·Xj)), types/slam2d/se2.h (operator*, toVector)",
    notes=(
        "The chart of g2o's EDGE_SE2 error: e = local(Z, Xi⁻¹·Xj) = toVector(Z⁻¹·Xi⁻¹·Xj), "
        "retract(X, d) = X·SE2(dx, dy, dθ) = (R·Rot(dθ), t + R·(dx, dy)): an SE2 built from "
        "(x, y, θ) directly (body frame), not the exponential. The 2-D file reader and "
        "factors with g2o's residual use it. False: it is the chart of VertexSE2.oplus (that "
        "adds the translation in the world frame: preset g2o_se2); X·Exp(d) (equal to first "
        "order only). No quaternions."
    ),
)
"""g2o ``EDGE_SE2`` error chart: (dx, dy, dθ) of ``Z⁻¹·Xi⁻¹·Xj``, body-frame translation (split)."""

G2O_SIM3 = Convention(
    name="g2o_sim3",
    side="left",
    order="rot_first",
    chart="sim3",
    rotation="exp",
    quat_order="xyzw",
    group="sim3",
    source="V g2opy 2.3.0 (VertexSim3Expmap.oplus, Sim3.log); S "
    "g2o/types/sim3/types_seven_dof_expmap.h (VertexSim3Expmap::oplusImpl: "
    "Sim3(update)·estimate), types/sim3/sim3.h (Sim3(const Vector7&): ω, υ, σ)",
    notes=(
        "oplus(d) = Exp(d)·X (left), d = (ω, υ, σ). False: X·Exp(d) (g2o's SE3Expmap vertex is "
        "also left; ORB-SLAM's Sim3 graph uses this vertex)."
    ),
)
"""g2o ``VertexSim3Expmap``: left, (ω, υ, σ), Sim(3) exp."""

PYPOSE_SIM3 = Convention(
    name="pypose_sim3",
    side="left",
    order="trans_first",
    chart="sim3",
    rotation="exp",
    quat_order="xyzw",
    group="sim3",
    source="V pypose 0.9.5 (Sim3 Retr, Log); S pypose/lietensor/lietensor.py (Retr = Exp(d)·X), "
    "storage [tx, ty, tz, qx, qy, qz, qw, s]",
    notes="X.Retr(d) = Exp(d)·X (left), d = (τ, φ, σ). False: X·Exp(d).",
)
"""PyPose ``Sim3``: left, (τ, φ, σ), Sim(3) exp."""

ROS_POSE2 = Convention(
    name="ros_pose2",
    side="left",
    order="trans_first",
    chart="split_world",
    rotation="exp",
    quat_order="xyzw",
    group="se2",
    embed=Embed(index=(0, 1, 5), size=6),
    source="D REP 103/105, geometry_msgs/PoseWithCovariance.msg (6×6 row-major, (x, y, z, "
    "rot X, rot Y, rot Z), parent frame); N a message, no update to run",
    notes=(
        "A planar pose inside the 6×6 PoseWithCovariance: (x, y, yaw) at rows/columns (0, 1, 5), "
        "x, y in the parent frame, yaw variance at flat index 35; z, roll, pitch rows/columns are "
        "0 (the planar model does not move them; set a large variance there yourself if your "
        "consumer wants 'unknown'). False: yaw at index 2 (the 3×3 (x, y, θ) layout pasted into "
        "the 6×6 puts yaw on z)."
    ),
)
"""ROS planar pose in ``PoseWithCovariance``: (x, y, yaw) at entries (0, 1, 5) of the 6-vector."""

#: The presets of the groups other than SE(3)/SO(3), in registry order, per group.
GROUP_PRESETS: tuple[Convention, ...] = (
    GTSAM_ROT2,
    GTSAM_POSE2,
    SOPHUS_SE2,
    MANIF_SE2,
    JAXLIE_SE2,
    SYMFORCE_POSE2,
    THESEUS_SE2,
    G2O_SE2,
    G2O_SE2_EDGE,
    ROS_POSE2,
    GTSAM_SIMILARITY3,
    SOPHUS_SIM3,
    G2O_SIM3,
    PYPOSE_SIM3,
    GTSAM_NAVSTATE,
    MANIF_SE23,
)

#: Every preset of every group (``PRESETS`` keeps the SE(3)/SO(3) ones, as before groups).
ALL_PRESETS: tuple[Convention, ...] = PRESETS + GROUP_PRESETS

#: Second names of presets (``get(alias)`` returns the preset itself): DROID-SLAM stores its
#: poses as DPVO does (both are lietorch on world→camera poses, by the same authors).
ALIASES: dict[str, str] = {"droid_slam": "dpvo"}


@dataclass(frozen=True)
class StorageLayout:
    """A storage layout without a retraction (not a convention: nothing is perturbed).

    ``fields`` names the stored numbers in order; ``to_matrix`` says how they make liebridge's
    matrix.
    """

    name: str
    group: str
    fields: tuple[str, ...]
    to_matrix: str
    source: str
    notes: str = ""


COLMAP_SIM3 = StorageLayout(
    name="colmap_sim3",
    group="sim3",
    fields=("scale", "qx", "qy", "qz", "qw", "tx", "ty", "tz"),
    to_matrix="[s·R(q) t; 0 1], p ↦ s·R(q)·p + t (liebridge's Sim(3) matrix as it is)",
    source="S colmap src/colmap/geometry/sim3.h (struct Sim3d: scale, Eigen::Quaterniond "
    "rotation, Vector3d translation; ToMatrix = [scale·R t])",
    notes="COLMAP optimises Sim3d through Ceres with its own parameterisation; it is a layout.",
)
"""COLMAP ``Sim3d``: a storage layout (scale, quaternion xyzw in Eigen's coeffs, translation)."""

LAYOUTS: dict[str, StorageLayout] = {COLMAP_SIM3.name: COLMAP_SIM3}
