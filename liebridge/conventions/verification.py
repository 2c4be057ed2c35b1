"""Every preset measured against the installed version of its library: :func:`verify`.

For each preset whose library is installed, :func:`verify` runs the library's **own** update and
difference (``retract``/``oplus``/``integrate``/``Retr``/``rplus`` and ``local``/``difference``/
``rminus``/``Log``; for Ceres, whose manifolds have no ``Plus`` in Python, one Gauss–Newton step
of known size through its solver; for libraries without an update, their exponential, logarithm
and composition on the preset's side) at random elements and at rotation angles near 0 and π,
and compares each result with the preset's ``retract``/``local``. It reports the worst relative
error, the preset :func:`~liebridge.conventions.detect_convention` names for the library's update,
and a verdict: ``agrees``, ``DIFFERS: <which field>``, ``not installed (pip install …)`` or
``not runnable here: <why>``.

Libraries are found with :func:`importlib.util.find_spec` before anything is imported: a library
that is not installed is never imported. Everything runs in float64 (JAX's ``jax_enable_x64`` is
switched on around each jaxlie call and restored after it).

Increments are generated in each preset's own tangent: its order, and its rotation coordinates
(rotation vector, half angle, quaternion vector part, Cayley), so that "θ near π" means a
rotation by an angle near π in every chart.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import importlib.util
import math
import warnings
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from .._validate import FloatArray
from ..lie import group as lie_group
from ..lie import se3
from .convention import Convention
from .detect import ConventionNotDetected, detect_convention, matches_so3
from .presets import ALL_PRESETS
from .registry import get, single_group

__all__ = ["CHECKS", "NOT_RUNNABLE", "Check", "Ops", "VerifyRow", "measure", "verify"]

Fn = Callable[..., Any]

#: Verdict threshold on the worst relative error (fields that differ give errors ≥ 1e-3 at the
#: finite increments used; libraries lose up to ~3e-8 near π, see docs/verify.md).
TOL = 1e-6


@dataclass(frozen=True)
class Ops:
    """A library's operations, in a preset's tangent and liebridge's matrices.

    Attributes
    ----------
    retract : callable
        ``retract(X, d) -> matrix``: the library's own update of the element ``X`` by ``d``.
    local : callable, optional
        ``local(X, Y) -> d``: the library's own difference (``retract(X, local(X, Y)) = Y``).
    """

    retract: Fn
    local: Fn | None = None


@dataclass(frozen=True)
class Check:
    """One preset measured against one library call.

    Attributes
    ----------
    preset : str
        The preset that claims to describe the call.
    library : str
        The library's name as users know it.
    module : str
        The module imported (found with ``find_spec`` first).
    dist : str
        The distribution (``pip install`` name) whose version is reported.
    what : str
        The library calls that are run.
    make : callable
        ``make(module) -> Ops``.
    on : str
        ``"so3"`` when an SE(3) preset is measured on rotations only (else its own group).
    variants : tuple of (str, str)
        ``(detected preset, verdict text)`` for known builds of another variant (e.g.
        ``gtsam_cayley`` on an exponential-chart wheel).
    install : str
        How to install the library, where it is not ``pip install <dist>``.
    """

    preset: str
    library: str
    module: str
    dist: str
    what: str
    make: Callable[[Any], Ops]
    on: str = ""
    variants: tuple[tuple[str, str], ...] = ()
    install: str = ""


@dataclass(frozen=True)
class VerifyRow:
    """One preset's result (``verdict`` says ``agrees``, ``DIFFERS: …`` or why not run)."""

    preset: str
    library: str
    version: str | None
    worst_error: float | None
    detected: str | None
    verdict: str
    what: str = ""

    def as_dict(self) -> dict[str, Any]:
        """Return the row as a JSON-ready dict."""
        return asdict(self)


# --------------------------------------------------------------------------------- helpers


def _np(y: Any) -> FloatArray:
    """Return a library's result as a float64 array (torch tensors, JAX arrays, lists)."""
    if hasattr(y, "detach"):
        y = y.detach().cpu().numpy()
    return np.asarray(y, dtype=np.float64)


def _rot_mat(w: FloatArray) -> FloatArray:
    """Rodrigues (independent of liebridge's kernels, for the Ceres step's Jacobian only)."""
    th = float(np.linalg.norm(w))
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    if th < 1e-8:
        return np.eye(3) + K + K @ K / 2
    return np.eye(3) + math.sin(th) / th * K + (1 - math.cos(th)) / th**2 * K @ K


def _angle2(M: FloatArray) -> float:
    return math.atan2(M[1, 0], M[0, 0])


def _mat2(x: float, y: float, th: float) -> FloatArray:
    c, s = math.cos(th), math.sin(th)
    return np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])


def _quat_wxyz(R: FloatArray) -> FloatArray:
    """Return the unit quaternion (w ≥ 0) of a rotation matrix (Shepperd's method)."""
    m = R
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    cands = [tr, m[0, 0], m[1, 1], m[2, 2]]
    k = int(np.argmax(cands))
    if k == 0:
        s = 2.0 * math.sqrt(1.0 + tr)
        q = [s / 4, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif k == 1:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [(m[2, 1] - m[1, 2]) / s, s / 4, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif k == 2:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, s / 4, (m[1, 2] + m[2, 1]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, s / 4]
    out = np.array(q)
    return out if out[0] >= 0 else -out


def _quat_mat(q: FloatArray) -> FloatArray:
    w, x, y, z = np.asarray(q, dtype=np.float64) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _pose(R: FloatArray, t: Any) -> FloatArray:
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = np.asarray(t, dtype=np.float64).reshape(3)
    return T


def _sim3_parts(S: FloatArray) -> tuple[FloatArray, FloatArray, float]:
    """``[sR t; 0 1]`` → ``(R, t, s)``."""
    s = float(np.cbrt(np.linalg.det(S[:3, :3])))
    return S[:3, :3] / s, S[:3, 3].copy(), s


def _sim3(R: FloatArray, t: Any, s: float) -> FloatArray:
    S = np.eye(4)
    S[:3, :3] = s * R
    S[:3, 3] = np.asarray(t, dtype=np.float64).reshape(3)
    return S


def _se3_ops(exp: Fn, log: Fn, side: str) -> Ops:
    """Ops of a library without an update: its exp/log composed on the preset's ``side``."""
    if side == "right":
        return Ops(lambda X, d: X @ exp(d), lambda X, Y: log(np.linalg.solve(X, Y)))
    return Ops(lambda X, d: exp(d) @ X, lambda X, Y: log(Y @ np.linalg.inv(X)))


# --------------------------------------------------------------------------------- gtsam


def _gtsam_pose3(gtsam: Any) -> Ops:
    return Ops(
        lambda X, d: np.asarray(gtsam.Pose3(X).retract(d).matrix()),
        lambda X, Y: np.asarray(gtsam.Pose3(X).localCoordinates(gtsam.Pose3(Y))),
    )


def _gtsam_rot3(gtsam: Any) -> Ops:
    return Ops(
        lambda R, d: np.asarray(gtsam.Rot3(R).retract(d).matrix()),
        lambda R, S: np.asarray(gtsam.Rot3(R).localCoordinates(gtsam.Rot3(S))),
    )


def _gtsam_rot2(gtsam: Any) -> Ops:
    def rot(M: FloatArray) -> Any:
        return gtsam.Rot2.fromAngle(_angle2(M))

    return Ops(
        lambda R, d: np.asarray(rot(R).retract(np.asarray(d)).matrix()),
        lambda R, S: np.atleast_1d(np.asarray(rot(R).localCoordinates(rot(S)))),
    )


def _gtsam_pose2(gtsam: Any) -> Ops:
    def pose(M: FloatArray) -> Any:
        return gtsam.Pose2(M[0, 2], M[1, 2], _angle2(M))

    return Ops(
        lambda X, d: np.asarray(pose(X).retract(d).matrix()),
        lambda X, Y: np.asarray(pose(X).localCoordinates(pose(Y))),
    )


def _gtsam_sim3(gtsam: Any) -> Ops:
    def sim(S: FloatArray) -> Any:
        R, t, s = _sim3_parts(S)
        return gtsam.Similarity3(gtsam.Rot3(R), t / s, s)  # matrix [R t_g; 0 1/s], t = s·t_g

    def mat(x: Any) -> FloatArray:
        M = np.asarray(x.matrix())
        return M / M[3, 3]

    return Ops(
        lambda X, d: mat(sim(X).retract(d)),
        lambda X, Y: np.asarray(sim(X).localCoordinates(sim(Y))),
    )


def _gtsam_navstate(gtsam: Any) -> Ops:
    def nav(M: FloatArray) -> Any:
        return gtsam.NavState(gtsam.Rot3(M[:3, :3]), M[:3, 3].copy(), M[:3, 4].copy())

    return Ops(
        lambda X, d: np.asarray(nav(X).retract(d).matrix()),
        lambda X, Y: np.asarray(nav(X).localCoordinates(nav(Y))),
    )


# --------------------------------------------------------------------------------- pinocchio


def _pin_q(pin: Any, T: FloatArray) -> FloatArray:
    return np.asarray(pin.SE3ToXYZQUAT(pin.SE3(np.array(T, dtype=np.float64))))


def _pin_T(pin: Any, q: Any) -> FloatArray:
    return np.asarray(pin.XYZQUATToSE3(np.asarray(q, dtype=np.float64)).homogeneous)


def _pin_free_flyer(pin: Any) -> Ops:
    model = pin.Model()
    model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "free_flyer")
    return Ops(
        lambda X, d: _pin_T(pin, pin.integrate(model, _pin_q(pin, X), np.asarray(d))),
        lambda X, Y: np.asarray(pin.difference(model, _pin_q(pin, X), _pin_q(pin, Y))),
    )


def _pin_r3xso3(pin: Any) -> Ops:
    g = pin.liegroups.R3() * pin.liegroups.SO3()
    return Ops(
        lambda X, d: _pin_T(pin, g.integrate(_pin_q(pin, X), np.asarray(d))),
        lambda X, Y: np.asarray(g.difference(_pin_q(pin, X), _pin_q(pin, Y))),
    )


# --------------------------------------------------------------------------------- symforce


def _sym_pose3(sym: Any) -> Ops:
    def P(X: FloatArray) -> Any:
        return sym.Pose3(R=sym.Rot3.from_rotation_matrix(X[:3, :3].copy()), t=X[:3, 3].copy())

    return Ops(
        lambda X, d: np.asarray(P(X).retract(np.asarray(d)).to_homogenous_matrix()),
        lambda X, Y: np.asarray(P(X).local_coordinates(P(Y))),
    )


def _sym_rot3(sym: Any) -> Ops:
    def R3(R: FloatArray) -> Any:
        return sym.Rot3.from_rotation_matrix(R.copy())

    return Ops(
        lambda R, d: np.asarray(R3(R).retract(np.asarray(d)).to_rotation_matrix()),
        lambda R, S: np.asarray(R3(R).local_coordinates(R3(S))),
    )


def _sym_pose2(sym: Any) -> Ops:
    def P(X: FloatArray) -> Any:
        return sym.Pose2(R=sym.Rot2.from_angle(_angle2(X)), t=X[:2, 2].copy())

    return Ops(
        lambda X, d: np.asarray(P(X).retract(np.asarray(d)).to_homogenous_matrix()),
        lambda X, Y: np.asarray(P(X).local_coordinates(P(Y))),
    )


# --------------------------------------------------------------------------------- exp-only libs


def _pt(side: str) -> Callable[[Any], Ops]:
    def make(pt: Any) -> Ops:
        return _se3_ops(
            lambda d: np.asarray(pt.transform_from_exponential_coordinates(np.asarray(d))),
            lambda T: np.asarray(pt.exponential_coordinates_from_transform(T, check=False)),
            side,
        )

    return make


def _mr(side: str) -> Callable[[Any], Ops]:
    def make(mr: Any) -> Ops:
        return _se3_ops(
            lambda V: np.asarray(mr.MatrixExp6(mr.VecTose3(np.asarray(V))), dtype=np.float64),
            lambda T: np.asarray(mr.se3ToVec(mr.MatrixLog6(T)), dtype=np.float64),
            side,
        )

    return make


def _kornia_se3(liegroup: Any) -> Ops:
    import torch  # kornia's own dependency, installed with it

    def exp(d: FloatArray) -> FloatArray:
        v = torch.tensor(np.asarray(d)[None], dtype=torch.float64)
        return _np(liegroup.Se3.exp(v).matrix())[0]

    def log(T: FloatArray) -> FloatArray:
        return _np(liegroup.Se3.from_matrix(torch.tensor(T[None], dtype=torch.float64)).log())[0]

    return _se3_ops(exp, log, "right")


def _aria_se3(sophus: Any) -> Ops:
    def exp(d: FloatArray) -> FloatArray:
        return np.asarray(sophus.SE3.exp(d[:3], d[3:]).to_matrix())

    def log(T: FloatArray) -> FloatArray:
        return np.asarray(sophus.SE3.from_matrix(T).log()).reshape(6)

    return _se3_ops(exp, log, "right")


def _aria_so3(sophus: Any) -> Ops:
    def exp(w: FloatArray) -> FloatArray:
        return np.asarray(sophus.SO3.exp(np.asarray(w)).to_matrix()).reshape(3, 3)

    def log(R: FloatArray) -> FloatArray:
        return np.asarray(sophus.SO3.from_matrix(R).log()).reshape(3)

    return _se3_ops(exp, log, "right")


def _sophuspy(kind: str) -> Callable[[Any], Ops]:
    def make(sp: Any) -> Ops:
        cls = {"se2": sp.SE2, "se3": sp.SE3, "so3": sp.SO3}[kind]

        def exp(d: FloatArray) -> FloatArray:
            return np.asarray(cls.exp(np.asarray(d, dtype=np.float64)).matrix())

        def log(T: FloatArray) -> FloatArray:
            return np.asarray(cls(T).log()).reshape(-1)

        return _se3_ops(exp, log, "right")

    return make


# --------------------------------------------------------------------------------- jaxlie


@contextmanager
def _x64(jax: Any) -> Iterator[None]:
    old = bool(jax.config.read("jax_enable_x64"))
    jax.config.update("jax_enable_x64", True)
    try:
        yield
    finally:
        jax.config.update("jax_enable_x64", old)


def _jaxlie(kind: str) -> Callable[[Any], Ops]:
    def make(jaxlie: Any) -> Ops:
        import jax  # jaxlie's own dependency
        import jax.numpy as jnp

        cls = jaxlie.SE3 if _is(kind, se3) else jaxlie.SE2

        def G(X: FloatArray) -> Any:
            return cls.from_matrix(jnp.asarray(X))

        def retract(X: FloatArray, d: FloatArray) -> FloatArray:
            with _x64(jax):
                return _np(jaxlie.manifold.rplus(G(X), jnp.asarray(d)).as_matrix())

        def local(X: FloatArray, Y: FloatArray) -> FloatArray:
            with _x64(jax):
                return _np(jaxlie.manifold.rminus(G(X), G(Y)))

        return Ops(retract, local)

    return make


# --------------------------------------------------------------------------------- g2o


def _g2o_se3(g2o: Any) -> Ops:
    def oplus(X: FloatArray, d: FloatArray) -> FloatArray:
        v = g2o.VertexSE3()
        v.set_estimate(g2o.Isometry3d(X))
        v.oplus(np.asarray(d, dtype=np.float64))
        return np.asarray(v.estimate().matrix())

    def error(X: FloatArray, Y: FloatArray) -> FloatArray:
        # EdgeSE3's error toVectorMQT(Z⁻¹·Xi⁻¹·Xj) with Xi = I, Z = X, Xj = Y: local(X, Y)
        vi, vj = g2o.VertexSE3(), g2o.VertexSE3()
        vi.set_id(0)
        vj.set_id(1)
        vi.set_estimate(g2o.Isometry3d(np.eye(4)))
        vj.set_estimate(g2o.Isometry3d(Y))
        e = g2o.EdgeSE3()
        e.set_vertex(0, vi)
        e.set_vertex(1, vj)
        e.set_measurement(g2o.Isometry3d(X))
        e.compute_error()
        return np.asarray(e.error, dtype=np.float64)

    return Ops(oplus, error)


def _g2o_expmap(g2o: Any) -> Ops:
    def quat(T: FloatArray) -> Any:
        return g2o.SE3Quat(T[:3, :3].copy(), T[:3, 3].copy())

    def oplus(X: FloatArray, d: FloatArray) -> FloatArray:
        v = g2o.VertexSE3Expmap()
        v.set_estimate(quat(X))
        v.oplus(np.asarray(d, dtype=np.float64))
        return np.asarray(v.estimate().matrix())

    return Ops(oplus, lambda X, Y: np.asarray((quat(Y) * quat(X).inverse()).log()))


def _g2o_se2(g2o: Any) -> Ops:
    def oplus(X: FloatArray, d: FloatArray) -> FloatArray:
        v = g2o.VertexSE2()
        v.set_estimate(g2o.SE2(X[0, 2], X[1, 2], _angle2(X)))
        v.oplus(np.asarray(d, dtype=np.float64))
        return _mat2(*v.estimate().to_vector())

    return Ops(oplus)


def _g2o_se2_edge(g2o: Any) -> Ops:
    def se2(M: FloatArray) -> Any:
        return g2o.SE2(M[0, 2], M[1, 2], _angle2(M))

    def error(X: FloatArray, Y: FloatArray) -> FloatArray:
        vi, vj = g2o.VertexSE2(), g2o.VertexSE2()
        vi.set_id(0)
        vj.set_id(1)
        vj.set_estimate(se2(Y))
        e = g2o.EdgeSE2()
        e.set_vertex(0, vi)
        e.set_vertex(1, vj)
        e.set_measurement(se2(X))
        e.compute_error()
        return np.asarray(e.error, dtype=np.float64)

    return Ops(lambda X, d: _mat2(*(se2(X) * g2o.SE2(*d)).to_vector()), error)


def _g2o_sim3(g2o: Any) -> Ops:
    def sim(S: FloatArray) -> Any:
        R, t, s = _sim3_parts(S)
        return g2o.Sim3(np.asfortranarray(R), t, s)

    def mat(x: Any) -> FloatArray:
        return _sim3(np.asarray(x.rotation().matrix()), np.asarray(x.translation()), x.scale())

    def oplus(X: FloatArray, d: FloatArray) -> FloatArray:
        v = g2o.VertexSim3Expmap()
        v.set_estimate(sim(X))
        v.oplus(np.asarray(d, dtype=np.float64))
        return mat(v.estimate())

    return Ops(oplus, lambda X, Y: np.asarray((sim(Y) * sim(X).inverse()).log()))


# --------------------------------------------------------------------------------- torch libs


def _pypose(kind: str) -> Callable[[Any], Ops]:
    def make(pp: Any) -> Ops:
        import torch  # pypose's own dependency

        def G(X: FloatArray) -> Any:
            M = torch.tensor(X, dtype=torch.float64)
            return pp.mat2SE3(M, check=False) if _is(kind, se3) else pp.mat2Sim3(M, check=False)

        tangent = pp.se3 if _is(kind, se3) else pp.sim3

        def retract(X: FloatArray, d: FloatArray) -> FloatArray:
            return _np(G(X).Retr(tangent(torch.tensor(d, dtype=torch.float64))).matrix())

        def local(X: FloatArray, Y: FloatArray) -> FloatArray:
            return _np((G(Y) * G(X).Inv()).Log())

        return Ops(retract, local)

    return make


def _inverted(ops: Ops) -> Ops:
    """Apply a library's ops to the stored inverse ``X⁻¹`` (world→camera poses, DPVO)."""
    inv = np.linalg.inv

    def retract(X: FloatArray, d: FloatArray) -> FloatArray:
        return inv(ops.retract(inv(X), d))

    local = ops.local
    if local is None:
        return Ops(retract)
    return Ops(retract, lambda X, Y: local(inv(X), inv(Y)))


def _pypose_stored_inverse(pp: Any) -> Ops:
    """PyPose's ``Retr``/``Log`` on ``T_cam_world``: DPVO's update (lietorch has PyPose's)."""
    return _inverted(_pypose("se3")(pp))


def _lietorch(stores: str) -> Callable[[Any], Ops]:
    def make(lt: Any) -> Ops:
        import torch  # lietorch's own dependency

        def G(X: FloatArray) -> Any:
            q = _quat_wxyz(X[:3, :3])
            v = np.concatenate([X[:3, 3], q[1:], q[:1]])  # [t, qx, qy, qz, qw]
            return lt.SE3(torch.tensor(v[None], dtype=torch.float64))

        def retract(X: FloatArray, d: FloatArray) -> FloatArray:
            a = torch.tensor(np.asarray(d)[None], dtype=torch.float64)
            return _np(G(X).retr(a).matrix())[0]

        def local(X: FloatArray, Y: FloatArray) -> FloatArray:
            return _np((G(Y) * G(X).inv()).log())[0]

        ops = Ops(retract, local)
        return _inverted(ops) if stores == "inverse" else ops

    return make


def _theseus(kind: str) -> Callable[[Any], Ops]:
    def make(th: Any) -> Ops:
        import torch  # theseus's own dependency

        def G(X: FloatArray) -> Any:
            if _is(kind, se3):
                return th.SE3(tensor=torch.tensor(X[None, :3, :], dtype=torch.float64))
            v = np.array([X[0, 2], X[1, 2], X[0, 0], X[1, 0]])
            return th.SE2(tensor=torch.tensor(v[None], dtype=torch.float64))

        def mat(g: Any) -> FloatArray:
            M = _np(g.to_matrix())[0]
            return M

        def retract(X: FloatArray, d: FloatArray) -> FloatArray:
            return mat(G(X).retract(torch.tensor(d[None], dtype=torch.float64)))

        def local(X: FloatArray, Y: FloatArray) -> FloatArray:
            return _np(G(X).local(G(Y)))[0]

        return Ops(retract, local)

    return make


# --------------------------------------------------------------------------------- Ceres


def _five_point(f: Fn, n: int, h: float = 1e-3) -> FloatArray:
    """Return ∂f(δ)/∂δ at 0 by the five-point stencil (error O(h⁴) ≈ 1e-12 here)."""
    cols = []
    for e in np.eye(n):
        cols.append((-f(2 * h * e) + 8 * f(h * e) - 8 * f(-h * e) + f(-2 * h * e)) / (12 * h))
    return np.stack(cols, axis=1)


def _ceres_step(
    pyceres: Any, blocks: list[tuple[FloatArray, Any]], model: Fn, c: FloatArray
) -> list:
    """One Gauss–Newton step of size ``c`` (in the tangent ``model`` claims) through Ceres.

    ``model(δ)`` is the claimed ``Plus`` of the stacked parameter blocks. The cost's Jacobian is
    the pseudo-inverse of the claimed ``PlusJacobian`` (in ambient coordinates) and its residual
    at the start is ``-c``: if Ceres's manifold is the claimed one, the step it solves for is
    ``δ = c`` exactly, and the parameters it ends at are its own ``Plus(x, c)``. Everywhere
    else the residual is 0, so the step is always accepted.
    """
    x0 = np.concatenate([b[0] for b in blocks])
    B = np.linalg.pinv(_five_point(model, c.size))
    sizes = [b[0].size for b in blocks]

    class Step(pyceres.CostFunction):
        def __init__(self) -> None:
            super().__init__()
            self.set_num_residuals(c.size)
            self.set_parameter_block_sizes(sizes)

        def Evaluate(self, parameters: Any, residuals: Any, jacobians: Any) -> bool:
            x = np.concatenate([np.asarray(p) for p in parameters])
            residuals[:] = -c if np.array_equal(x, x0) else 0.0
            if jacobians is not None:
                k = 0
                for i, s in enumerate(sizes):
                    if jacobians[i] is not None:
                        jacobians[i][:] = B[:, k : k + s].ravel()
                    k += s
            return True

    params = [np.array(b[0], dtype=np.float64) for b in blocks]
    problem = pyceres.Problem()
    problem.add_residual_block(Step(), None, params)
    for p, (_, manifold) in zip(params, blocks, strict=True):
        if manifold is not None:
            problem.set_manifold(p, manifold)
    opts = pyceres.SolverOptions()
    opts.max_num_iterations = 1
    opts.initial_trust_region_radius = 1e16
    opts.max_trust_region_radius = 1e16
    opts.linear_solver_type = pyceres.LinearSolverType.DENSE_QR
    opts.minimizer_progress_to_stdout = False
    opts.logging_type = pyceres.LoggingType.SILENT
    pyceres.solve(opts, problem, pyceres.SolverSummary())
    return params


def _ceres_quaternion(order: str) -> Callable[[Any], Ops]:
    def make(pyceres: Any) -> Ops:
        conv = get("ceres_quaternion" if order == "wxyz" else "ceres_eigen_quaternion")

        def store(R: FloatArray) -> FloatArray:
            q = _quat_wxyz(R)
            return q if order == "wxyz" else q[[1, 2, 3, 0]]

        def load(q: FloatArray) -> FloatArray:
            return _quat_mat(q if order == "wxyz" else q[[3, 0, 1, 2]])

        def retract(R: FloatArray, d: FloatArray) -> FloatArray:
            q0 = store(R)
            manifold = (
                pyceres.QuaternionManifold()
                if order == "wxyz"
                else pyceres.EigenQuaternionManifold()
            )
            sign = 1.0

            def model(e: FloatArray) -> FloatArray:  # the claimed Plus, as stored numbers
                q = store(conv.retract(R, e))
                return sign * q if q @ q0 >= 0 else -sign * q

            (q,) = _ceres_step(pyceres, [(q0, manifold)], model, np.asarray(d, dtype=float))
            return load(q)

        return Ops(retract)

    return make


def _ceres_pose(pyceres: Any) -> Ops:
    conv = get("ceres_pose")

    def retract(X: FloatArray, d: FloatArray) -> FloatArray:
        q0 = _quat_wxyz(X[:3, :3])

        def model(e: FloatArray) -> FloatArray:
            Y = conv.retract(X, e)
            q = _quat_wxyz(Y[:3, :3])
            return np.r_[q if q @ q0 >= 0 else -q, Y[:3, 3]]

        q, t = _ceres_step(
            pyceres,
            [(q0, pyceres.QuaternionManifold()), (X[:3, 3].copy(), None)],
            model,
            np.asarray(d, dtype=float),
        )
        return _pose(_quat_mat(q), t)

    return Ops(retract)


# --------------------------------------------------------------------------------- the table

_EXP = "exp/log and composition on the preset's side (the library has no update)"

#: Every measurable (preset, library call), in registry order of the presets.
#: lietorch is built from its sources with a CUDA toolkit (no wheel on PyPI): read, not run, here.
_LIETORCH_INSTALL = (
    "pip install git+https://github.com/princeton-vl/lietorch.git, CUDA toolkit needed; "
    "its convention was read in the source and is PyPose's, run in the pypose rows"
)

CHECKS: tuple[Check, ...] = (
    Check("gtsam", "gtsam", "gtsam", "gtsam", "Pose3.retract/localCoordinates", _gtsam_pose3),
    Check("gtsam", "gtsam", "gtsam", "gtsam", "Rot3.retract/localCoordinates", _gtsam_rot3, "so3"),
    Check(
        "gtsam_cayley",
        "gtsam",
        "gtsam",
        "gtsam",
        "Pose3.retract/localCoordinates",
        _gtsam_pose3,
        variants=(("gtsam", "this build uses the exponential (preset gtsam)"),),
    ),
    Check(
        "sophus",
        "projectaria-tools",
        "projectaria_tools.core.sophus",
        "projectaria-tools",
        "sophus.SE3.exp/log/operator* (" + _EXP + ")",
        _aria_se3,
    ),
    Check(
        "sophus",
        "projectaria-tools",
        "projectaria_tools.core.sophus",
        "projectaria-tools",
        "sophus.SO3.exp/log/operator* (" + _EXP + ")",
        _aria_so3,
        "so3",
    ),
    Check(
        "sophus",
        "sophuspy",
        "sophuspy",
        "sophuspy",
        "SE3.exp/log/operator* (" + _EXP + ")",
        _sophuspy("se3"),
    ),
    Check(
        "sophus",
        "sophuspy",
        "sophuspy",
        "sophuspy",
        "SO3.exp/log/operator* (" + _EXP + ")",
        _sophuspy("so3"),
        "so3",
    ),
    Check(
        "pinocchio",
        "pin",
        "pinocchio",
        "pin",
        "integrate/difference on a free-flyer joint",
        _pin_free_flyer,
    ),
    Check(
        "pinocchio_r3xso3",
        "pin",
        "pinocchio",
        "pin",
        "liegroups (R3 × SO3).integrate/difference",
        _pin_r3xso3,
    ),
    Check("jaxlie", "jaxlie", "jaxlie", "jaxlie", "manifold.rplus/rminus on SE3", _jaxlie("se3")),
    Check("theseus", "theseus-ai", "theseus", "theseus-ai", "SE3.retract/local", _theseus("se3")),
    Check("pypose", "pypose", "pypose", "pypose", "SE3 Retr / (Y·X⁻¹).Log", _pypose("se3")),
    Check(
        "lietorch",
        "lietorch",
        "lietorch",
        "lietorch",
        "SE3.retr / (Y·X⁻¹).log",
        _lietorch("pose"),
        install=_LIETORCH_INSTALL,
    ),
    Check(
        "dpvo",
        "lietorch",
        "lietorch",
        "lietorch",
        "SE3.retr / log on the stored T_cam_world (DPVO's and DROID-SLAM's update)",
        _lietorch("inverse"),
        install=_LIETORCH_INSTALL,
    ),
    Check(
        "dpvo",
        "pypose",
        "pypose",
        "pypose",
        "SE3 Retr / Log on the stored T_cam_world (DPVO's lietorch update; PyPose has lietorch's "
        "convention)",
        _pypose_stored_inverse,
    ),
    Check(
        "pytransform3d_global",
        "pytransform3d",
        "pytransform3d.transformations",
        "pytransform3d",
        "transform_from_exponential_coordinates/concat (" + _EXP + ")",
        _pt("left"),
    ),
    Check(
        "pytransform3d_local",
        "pytransform3d",
        "pytransform3d.transformations",
        "pytransform3d",
        "transform_from_exponential_coordinates/concat (" + _EXP + ")",
        _pt("right"),
    ),
    Check(
        "symforce",
        "symforce-sym",
        "sym",
        "symforce-sym",
        "Pose3.retract/local_coordinates",
        _sym_pose3,
    ),
    Check(
        "symforce",
        "symforce-sym",
        "sym",
        "symforce-sym",
        "Rot3.retract/local_coordinates",
        _sym_rot3,
        "so3",
    ),
    Check(
        "ceres_quaternion",
        "pyceres",
        "pyceres",
        "pyceres",
        "QuaternionManifold through one Gauss–Newton step of the solver",
        _ceres_quaternion("wxyz"),
        "so3",
    ),
    Check(
        "ceres_eigen_quaternion",
        "pyceres",
        "pyceres",
        "pyceres",
        "EigenQuaternionManifold through one Gauss–Newton step of the solver",
        _ceres_quaternion("xyzw"),
        "so3",
    ),
    Check(
        "ceres_pose",
        "pyceres",
        "pyceres",
        "pyceres",
        "QuaternionManifold + Euclidean translation block through one Gauss–Newton step",
        _ceres_pose,
    ),
    Check("g2o", "g2opy", "g2opy", "g2opy", "VertexSE3.oplus / EdgeSE3 error", _g2o_se3),
    Check(
        "g2o_expmap", "g2opy", "g2opy", "g2opy", "VertexSE3Expmap.oplus / SE3Quat.log", _g2o_expmap
    ),
    Check(
        "mr_body",
        "modern-robotics",
        "modern_robotics",
        "modern_robotics",
        "MatrixExp6/MatrixLog6 (" + _EXP + ")",
        _mr("right"),
    ),
    Check(
        "mr_space",
        "modern-robotics",
        "modern_robotics",
        "modern_robotics",
        "MatrixExp6/MatrixLog6 (" + _EXP + ")",
        _mr("left"),
    ),
    Check(
        "kornia",
        "kornia",
        "kornia.geometry.liegroup",
        "kornia",
        "Se3.exp/log/composition (" + _EXP + ")",
        _kornia_se3,
    ),
    Check("gtsam_rot2", "gtsam", "gtsam", "gtsam", "Rot2.retract/localCoordinates", _gtsam_rot2),
    Check("gtsam_pose2", "gtsam", "gtsam", "gtsam", "Pose2.retract/localCoordinates", _gtsam_pose2),
    Check(
        "sophus_se2",
        "sophuspy",
        "sophuspy",
        "sophuspy",
        "SE2.exp/log/operator* (" + _EXP + ")",
        _sophuspy("se2"),
    ),
    Check(
        "jaxlie_se2", "jaxlie", "jaxlie", "jaxlie", "manifold.rplus/rminus on SE2", _jaxlie("se2")
    ),
    Check(
        "symforce_pose2",
        "symforce-sym",
        "sym",
        "symforce-sym",
        "Pose2.retract/local_coordinates",
        _sym_pose2,
    ),
    Check(
        "theseus_se2", "theseus-ai", "theseus", "theseus-ai", "SE2.retract/local", _theseus("se2")
    ),
    Check("g2o_se2", "g2opy", "g2opy", "g2opy", "VertexSE2.oplus", _g2o_se2),
    Check("g2o_se2_edge", "g2opy", "g2opy", "g2opy", "SE2 product / EdgeSE2 error", _g2o_se2_edge),
    Check(
        "gtsam_similarity3",
        "gtsam",
        "gtsam",
        "gtsam",
        "Similarity3.retract/localCoordinates",
        _gtsam_sim3,
    ),
    Check("g2o_sim3", "g2opy", "g2opy", "g2opy", "VertexSim3Expmap.oplus / Sim3.log", _g2o_sim3),
    Check("pypose_sim3", "pypose", "pypose", "pypose", "Sim3 Retr / (Y·X⁻¹).Log", _pypose("sim3")),
    Check(
        "gtsam_navstate",
        "gtsam",
        "gtsam",
        "gtsam",
        "NavState.retract/localCoordinates",
        _gtsam_navstate,
    ),
)

#: Presets no installable library runs, and why (the table's evidence stays S or D).
NOT_RUNNABLE: dict[str, tuple[str, str]] = {
    "manif": ("manif", "no manifpy wheel on PyPI (conda-forge only)"),
    "manif_se2": ("manif", "no manifpy wheel on PyPI (conda-forge only)"),
    "manif_se23": ("manif", "no manifpy wheel on PyPI (conda-forge only)"),
    "barfoot": (
        "liegroups (utiasSTARS)",
        "not on PyPI (PyPI's liegroups is another package)",
    ),
    "sophus_sim3": ("sophuspy", "sophuspy binds SO2, SE2, SO3 and SE3 only (no Sim3)"),
    "ros": ("ROS", "a message, no update to run"),
    "ros_pose2": ("ROS", "a message, no update to run"),
}


# --------------------------------------------------------------------------------- sampling

_PI = math.pi


def _rot_coords(conv: Convention, axis: FloatArray, theta: float) -> FloatArray:
    """Return a rotation by ``theta`` about ``axis`` in ``conv``'s rotation coordinates."""
    r = conv.rotation
    if r == "half_exp":
        return axis * theta / 2
    if r == "quat_vec":
        return axis * math.sin(theta / 2)
    if r == "cayley":
        return axis * 2 * math.tan(theta / 2)
    return axis * theta


def _tangent(conv: Convention, group: str, theta: float, rng: np.random.Generator) -> FloatArray:
    """Return an increment in ``conv``'s own tangent whose rotation angle is ``theta``."""
    g = lie_group(group)
    if g.rot_dim == 1:
        rot = np.array([theta * rng.choice([-1.0, 1.0])])
    else:
        axis = rng.normal(size=3)
        rot = _rot_coords(conv, axis / np.linalg.norm(axis), theta)
    k = sum(sl.stop - sl.start for sl in g.vecs)  # the vector coordinates
    vec = rng.normal(size=k) * 2.0
    d = np.r_[rot, vec] if conv.order == "rot_first" else np.r_[vec, rot]
    if g.scale is not None:
        d = np.r_[d, rng.normal() * 0.3]
    if conv.embed is not None:
        d = np.zeros(conv.embed.size)
        d[list(conv.embed.index)] = np.r_[vec, rot]
    return d


def _is(group: str, module: Any) -> bool:
    """Whether ``group`` names the group of ``module`` (``lie.se3``, ...): its record."""
    return lie_group(group) is module.GROUP


def _element(group: str, theta: float, rng: np.random.Generator) -> FloatArray:
    """Return an element whose rotation angle is ``theta`` (Exp of a tangent at the identity)."""
    g = lie_group(group)
    hub = Convention(  # the group's own exponential, on the right, in its canonical order
        "hub", "right", g.canonical_order, g.coupled_chart, "exp", "wxyz", group=g.name
    )
    xi = _tangent(hub, group, theta, rng)
    return hub.retract(g.identity(), xi)


#: Rotation angles of the elements and of the increments: 0, tiny, generic, near π.
ELEMENT_ANGLES = (0.0, 1e-9, 0.7, 2.4, _PI - 1e-6)
RETRACT_ANGLES = (0.0, 1e-9, 1e-5, 0.4, 1.7, _PI - 1e-6)
#: The difference is measured short of π: at π − ε the input's own rounding moves the answer by
#: ~1e-16/ε (an ill-conditioned log, whoever computes it).
LOCAL_ANGLES = (0.0, 1e-9, 1e-5, 0.4, 1.7, 3.0, _PI - 1e-4)


def samples(
    conv: Convention, group: str, rng: np.random.Generator, angles: Iterable[float]
) -> list[tuple[FloatArray, FloatArray, float, float]]:
    """``(X, d, element angle, increment angle)`` over every pair of angles (cayley: < 3)."""
    out = []
    for a in ELEMENT_ANGLES:
        for b in angles:
            if conv.rotation == "cayley" and b > 3.0:
                b = 3.0
            out.append((_element(group, a, rng), _tangent(conv, group, b, rng), a, b))
    return out


def _rel(got: Any, want: FloatArray) -> float:
    g = np.asarray(got, dtype=np.float64)
    if g.shape != want.shape:
        return math.inf
    return float(np.abs(g - want).max() / max(1.0, float(np.abs(want).max())))


def _group_of(check: Check, conv: Convention) -> str:
    return check.on or conv.group


def _edge(a: float, b: float) -> bool:
    """Whether a sample is at an edge: an angle within 1e-4 of 0 (but not 0) or beyond 3."""
    return any(0.0 < x < 1e-4 or x > 3.0 for x in (a, b))


def measure(check: Check, ops: Ops, seed: int = 0) -> tuple[float, str, float, str]:
    """Worst relative error of ``ops`` against the preset, away from and at the edges.

    Returns ``(generic worst, where, edge worst, where)``; edges are angles near 0 (not 0) and
    near π, where libraries lose accuracy in their own series and branches.
    """
    conv = single_group(get(check.preset))
    group = _group_of(check, conv)
    rng = np.random.default_rng(seed)
    worst = {False: (0.0, ""), True: (0.0, "")}

    def record(e: float, a: float, b: float, op: str) -> None:
        k = _edge(a, b)
        if e > worst[k][0] or math.isnan(e):
            worst[k] = (e, f"{op}, element angle {a:.6g}, increment angle {b:.6g}")

    for X, d, a, b in samples(conv, group, rng, RETRACT_ANGLES):
        record(_rel(ops.retract(X.copy(), d.copy()), conv.retract(X, d)), a, b, "update")
    if ops.local is not None:
        for X, d, a, b in samples(conv, group, rng, LOCAL_ANGLES):
            Y = conv.retract(X, d)
            got = np.asarray(ops.local(X.copy(), Y.copy())).reshape(-1)
            record(_rel(got, d), a, b, "difference")
    return (*worst[False], *worst[True])


def _detect(check: Check, ops: Ops) -> Convention | None:
    conv = single_group(get(check.preset))
    group = _group_of(check, conv)
    try:
        return detect_convention(ops.retract, group=group, prefer=check.preset)
    except ConventionNotDetected:
        return None


def _same(check: Check, conv: Convention, found: Convention) -> list[str]:
    """Fields of ``conv`` the detected convention differs in (rotations: side and rotation)."""
    rotation_only = bool(check.on) and not lie_group(check.on).cols
    names = ("side", "rotation") if rotation_only else ("side", "order", "chart", "rotation")
    return [
        f"{n} (measured {getattr(found, n)}, preset {getattr(conv, n)})"
        for n in names
        if getattr(found, n) != getattr(conv, n)
    ]


def _verdict(
    check: Check,
    generic: tuple[float, str],
    edge: tuple[float, str],
    found: Convention | None,
    tol: float,
) -> str:
    conv = single_group(get(check.preset))
    if found is None:
        return "DIFFERS: no convention of the model reproduces the library's update"
    variants = dict(check.variants)
    if found.name in variants and found.name != conv.name:
        return "DIFFERS: " + variants[found.name]
    diff = _same(check, conv, found)
    if diff:
        return "DIFFERS: " + "; ".join(diff)
    if not generic[0] <= tol:
        return f"DIFFERS: accuracy (worst relative error {generic[0]:.2g} at {generic[1]})"
    if not edge[0] <= tol:
        return f"agrees (the library loses accuracy at an edge: {edge[0]:.2g} at {edge[1]})"
    return "agrees"


def _detected_name(check: Check, found: Convention | None) -> str | None:
    if found is None:
        return None
    if check.on and not lie_group(check.on).cols:  # a rotation: side and rotation coordinates
        same = [c.name for c in matches_so3(found)]
        return check.preset if check.preset in same else found.name
    return found.name


def _version(dist: str) -> str | None:
    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return None


def _installed(module: str) -> bool:
    try:
        return importlib.util.find_spec(module.split(".")[0]) is not None
    except (ImportError, ValueError):
        return False


def run_check(check: Check, tol: float = TOL, seed: int = 0) -> VerifyRow:
    """Run one check (its library must be installed); never raises for a library's failure."""
    version = _version(check.dist)
    try:
        with warnings.catch_warnings():  # a library's import-time notices are not our verdict
            warnings.simplefilter("ignore")
            module = importlib.import_module(check.module)
        ceres = getattr(module, "__ceres_version__", None)  # pyceres: the Ceres it wraps
        if ceres and version:
            version = f"{version} (Ceres {ceres})"
        ops = check.make(module)
        g, gw, e, ew = measure(check, ops, seed)
        found = _detect(check, ops)
    except Exception as exc:  # a broken installation or an API this check does not know
        msg = f"{type(exc).__name__}: {exc}".splitlines()[0][:160]
        return VerifyRow(
            check.preset, check.library, version, None, None, f"could not run: {msg}", check.what
        )
    verdict = _verdict(check, (g, gw), (e, ew), found, tol)
    worst = max(g, e) if not (math.isnan(g) or math.isnan(e)) else math.nan
    return VerifyRow(
        check.preset,
        check.library,
        version,
        worst,
        _detected_name(check, found),
        verdict,
        check.what,
    )


def verify(
    libraries: Iterable[str] | None = None,
    *,
    tol: float = TOL,
    seed: int = 0,
    progress: Callable[[str], None] | None = None,
) -> list[VerifyRow]:
    """Measure every preset against the installed version of its library.

    Parameters
    ----------
    libraries : str or iterable of str, optional
        Only these libraries (names as in the rows' ``library``, e.g. ``"gtsam"``, ``"g2opy"``);
        default: all.
    tol : float
        Worst relative error (``|library − preset|∞ / max(1, |preset|∞)``) still called
        ``agrees`` when the detected fields are the preset's.
    seed : int
        Seed of the random elements and increments.
    progress : callable, optional
        Called with ``"<preset> (<library>)"`` before each measurement.

    Returns
    -------
    list of VerifyRow
        One row per (preset, library call), in registry order, then one per preset no library
        here can run. Fields ``preset``, ``library``, ``version`` (``None``: not installed),
        ``worst_error`` (``None``: not measured), ``detected`` (the preset
        :func:`detect_convention` names for the library's update, or ``None``), ``verdict``
        (``agrees``, ``DIFFERS: <which field>``, ``not installed (pip install …)``,
        ``not runnable here: <why>``, ``could not run: <error>``) and ``what`` (the calls).

    Raises
    ------
    ValueError
        For a library name no row has (the message lists the known ones).

    Notes
    -----
    A library that is not installed is never imported (:func:`importlib.util.find_spec`).
    """
    wanted = None
    if libraries is not None:
        if isinstance(libraries, str):
            libraries = [libraries]
        known = {c.library.lower() for c in CHECKS} | {v[0].lower() for v in NOT_RUNNABLE.values()}
        wanted = {str(w).strip().lower() for w in libraries}
        unknown = sorted(wanted - known)
        if unknown:
            raise ValueError(
                f"libraries: unknown {', '.join(map(repr, unknown))} "
                f"(known: {', '.join(sorted(known))})"
            )
    rows: list[VerifyRow] = []
    order = {c.name: i for i, c in enumerate(ALL_PRESETS)}
    for check in sorted(CHECKS, key=lambda c: order.get(c.preset, len(order))):
        if wanted is not None and check.library.lower() not in wanted:
            continue
        if not _installed(check.module):
            rows.append(
                VerifyRow(
                    check.preset,
                    check.library,
                    None,
                    None,
                    None,
                    f"not installed ({check.install or 'pip install ' + check.dist})",
                    check.what,
                )
            )
            continue
        if progress is not None:
            progress(f"{check.preset} ({check.library})")
        rows.append(run_check(check, tol, seed))
    for name, (lib, why) in NOT_RUNNABLE.items():
        if wanted is None or lib.lower() in wanted:
            rows.append(VerifyRow(name, lib, None, None, None, f"not runnable here: {why}"))
    return rows
