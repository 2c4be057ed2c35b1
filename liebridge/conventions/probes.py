"""Which call of which installed library each preset describes, as measurable probes.

Each probe wraps one of a library's own operations as ``retract(X, d) -> (4, 4)`` (a pose ``X``
as a matrix, an increment ``d`` in the library's own tangent); :func:`run_probe` hands it to
:func:`liebridge.conventions.detect_convention`, which compares it with every convention of the
model at finite increments, and measures the quaternion storage order by reading a known
rotation back out of the library. Nothing about the library is assumed: a result says what was
measured and the preset that claims to describe it.

Where a library has no retraction of its own (scipy, spatialmath, Modern Robotics), the probe
composes the library's exponential on one side, so the side is the probe's choice and only the
tangent order and chart are the library's; the probe's ``note`` says so.

Libraries are imported only when probed (:func:`import_library`); ``liebridge detect`` prints the
results and ``examples/detect_conventions.py`` runs them. Users can add their own
:class:`Library` entries.
"""

from __future__ import annotations

import difflib
import importlib
import importlib.metadata
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validate import FloatArray
from ..lie import group as lie_group
from ..lie import quaternion as quat
from ..lie import so3
from .convention import Convention
from .detect import ConventionNotDetected, detect_convention, matches_so3
from .registry import get, matching_presets, single_group

__all__ = [
    "LIBRARIES",
    "R_PROBE",
    "Library",
    "LibraryError",
    "Probe",
    "ProbeResult",
    "format_result",
    "import_library",
    "resolve",
    "run_probe",
]


class LibraryError(LookupError):
    """A library is unknown, not installed or cannot be imported (the message says which)."""


Retract = Callable[[FloatArray, FloatArray], Any]
#: A known, generic rotation (no symmetric quaternion components) read back from each library.
R_PROBE = so3.exp(np.array([0.3, -0.5, 0.7]))


def _rotation_only(group: str) -> bool:
    """Whether a probe's group is a rotation group (only side and rotation coordinates act)."""
    g = lie_group(group)
    return not g.cols


@dataclass(frozen=True)
class Probe:
    """One measurable operation of a library.

    Attributes
    ----------
    what : str
        The library call being measured.
    group : {"se3", "so3"}
        What the operation acts on.
    preset : str or None
        The preset that claims to describe it (``None``: the library has no preset).
    make : callable
        ``make(module) -> retract(X, d)``; called with the imported library module.
    note : str
        Said with the result (e.g. which part of the convention is the probe's own choice).
    """

    what: str
    group: str
    preset: str | None
    make: Callable[[Any], Retract]
    note: str = ""


@dataclass(frozen=True)
class Library:
    """An installable library and its probes."""

    name: str
    module: str
    pip: str
    probes: tuple[Probe, ...]
    quaternion: Callable[[Any, FloatArray], list[tuple[str, FloatArray]]] | None = None
    aliases: tuple[str, ...] = ()


@dataclass(frozen=True)
class ProbeResult:
    """What :func:`run_probe` measured."""

    library: str
    version: str
    probe: Probe
    measured: Convention | None
    preset: Convention | None
    quaternion: list[tuple[str, str]]  # (measured order, via which call)
    error: str = ""

    @property
    def agrees(self) -> bool | None:
        """Whether the measured fields equal the preset's (``None`` without a preset)."""
        if self.measured is None:
            return False
        if self.preset is None:
            return None
        if _rotation_only(self.probe.group):
            same = (self.measured.side, self.measured.rotation) == (
                self.preset.side,
                self.preset.rotation,
            )
        else:
            same = self.measured.fields == self.preset.fields
        if self.quaternion:
            same = same and self.quaternion[0][0] == self.preset.quat_order
        return same


# --------------------------------------------------------------------------- quaternion storage


def _storage_order(stored: FloatArray) -> str:
    """``"wxyz"`` or ``"xyzw"`` for a stored quaternion of :data:`R_PROBE` (up to sign)."""
    q = quat.from_matrix(R_PROBE, order="wxyz")
    s = np.asarray(stored, dtype=np.float64).reshape(-1)
    for order, ref in (("wxyz", q), ("xyzw", np.r_[q[1:], q[0]])):
        if min(np.abs(s - ref).max(), np.abs(s + ref).max()) < 1e-9:
            return order
    return "unknown (" + np.array2string(s, precision=4) + ")"


def _gtsam_quaternions(gtsam: Any, R: FloatArray) -> list[tuple[str, FloatArray]]:
    q = quat.from_matrix(R, order="wxyz")
    q_in = np.full(4, np.nan)  # the argument order of Rot3.Quaternion that rebuilds R
    for cand in (q, q[[1, 2, 3, 0]]):
        if np.allclose(gtsam.Rot3.Quaternion(*cand).matrix(), R, atol=1e-12):
            q_in = cand
            break
    return [
        ("Rot3.Quaternion(a, b, c, d) (input)", q_in),
        (
            "Rot3.toQuaternion().coeffs() (output)",
            np.asarray(gtsam.Rot3(R).toQuaternion().coeffs()),
        ),
    ]


def _pin_xyzquat(pin: Any, T: FloatArray) -> FloatArray:
    return np.asarray(pin.SE3ToXYZQUAT(pin.SE3(np.array(T, dtype=np.float64))))


def _pin_from_xyzquat(pin: Any, q: FloatArray) -> FloatArray:
    return np.asarray(pin.XYZQUATToSE3(np.asarray(q, dtype=np.float64)).homogeneous)


def _pose(R: FloatArray) -> FloatArray:
    T = np.eye(4)
    T[:3, :3] = R
    return T


# --------------------------------------------------------------------------- probes per library


def _gtsam_pose3(gtsam: Any) -> Retract:
    return lambda X, d: np.asarray(gtsam.Pose3(X).retract(d).matrix())


def _gtsam_rot3(gtsam: Any) -> Retract:
    return lambda R, d: np.asarray(gtsam.Rot3(R).retract(d).matrix())


def _pin_free_flyer(pin: Any) -> Retract:
    model = pin.Model()
    model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "free_flyer")
    return lambda X, d: _pin_from_xyzquat(pin, pin.integrate(model, _pin_xyzquat(pin, X), d))


def _pin_r3xso3(pin: Any) -> Retract:
    group = pin.liegroups.R3() * pin.liegroups.SO3()
    return lambda X, d: _pin_from_xyzquat(pin, group.integrate(_pin_xyzquat(pin, X), d))


def _pt_global(pt: Any) -> Retract:
    # concat(A2B, B2C) = B2C·A2B, so concat(X, Exp(d)) = Exp(d)·X
    return lambda X, d: np.asarray(
        pt.concat(X, pt.transform_from_exponential_coordinates(d), check=False)
    )


def _pt_local(pt: Any) -> Retract:
    return lambda X, d: np.asarray(
        pt.concat(pt.transform_from_exponential_coordinates(d), X, check=False)
    )


def _scipy_rigid(spt: Any) -> Retract:
    RT = spt.RigidTransform
    return lambda X, d: (RT.from_matrix(X) * RT.from_exp_coords(d)).as_matrix()


def _scipy_rotation(spt: Any) -> Retract:
    Rot = spt.Rotation
    return lambda R, d: (Rot.from_matrix(R) * Rot.from_rotvec(d)).as_matrix()


def _sym_pose3(sym: Any) -> Retract:
    def retract(X: FloatArray, d: FloatArray) -> FloatArray:
        P = sym.Pose3(R=sym.Rot3.from_rotation_matrix(X[:3, :3].copy()), t=X[:3, 3].copy())
        return np.asarray(P.retract(np.asarray(d, dtype=np.float64)).to_homogenous_matrix())

    return retract


def _sym_rot3(sym: Any) -> Retract:
    return lambda R, d: np.asarray(
        sym.Rot3.from_rotation_matrix(R.copy())
        .retract(np.asarray(d, dtype=np.float64))
        .to_rotation_matrix()
    )


def _mr_body(mr: Any) -> Retract:
    return lambda X, V: X @ np.asarray(mr.MatrixExp6(mr.VecTose3(V)), dtype=np.float64)


def _mr_space(mr: Any) -> Retract:
    return lambda X, V: np.asarray(mr.MatrixExp6(mr.VecTose3(V)), dtype=np.float64) @ X


def _sm_twist(sm: Any) -> Retract:
    return lambda X, d: X @ np.asarray(sm.Twist3(d).exp().A)


_NO_RETRACT = "{lib} has no retraction: the probe composes its exponential on the {side}, so the "
_NO_RETRACT += "side is the probe's; the tangent order and chart are the library's"

LIBRARIES: dict[str, Library] = {
    lib.name: lib
    for lib in (
        Library(
            "gtsam",
            "gtsam",
            "gtsam",
            (
                Probe("gtsam.Pose3.retract", "se3", "gtsam", _gtsam_pose3),
                Probe("gtsam.Rot3.retract", "so3", "gtsam", _gtsam_rot3),
            ),
            quaternion=_gtsam_quaternions,
        ),
        Library(
            "pinocchio",
            "pinocchio",
            "pin",
            (
                Probe("pin.integrate on a free-flyer joint", "se3", "pinocchio", _pin_free_flyer),
                Probe("pin.liegroups (R3 × SO3).integrate", "se3", "pinocchio_r3xso3", _pin_r3xso3),
            ),
            quaternion=lambda pin, R: [
                ("pin.SE3ToXYZQUAT(...)[3:]", _pin_xyzquat(pin, _pose(R))[3:])
            ],
            aliases=("pin",),
        ),
        Library(
            "pytransform3d",
            "pytransform3d.transformations",
            "pytransform3d",
            (
                Probe(
                    "pt.concat(X, transform_from_exponential_coordinates(d)) "
                    "(as concat_globally_uncertain_transforms)",
                    "se3",
                    "pytransform3d_global",
                    _pt_global,
                ),
                Probe(
                    "pt.concat(transform_from_exponential_coordinates(d), X) "
                    "(as concat_locally_uncertain_transforms)",
                    "se3",
                    "pytransform3d_local",
                    _pt_local,
                ),
            ),
            quaternion=lambda pt, R: [
                ("pt.pq_from_transform(...)[3:]", pt.pq_from_transform(_pose(R))[3:])
            ],
            aliases=("pt",),
        ),
        Library(
            "scipy",
            "scipy.spatial.transform",
            "scipy",
            (
                Probe(
                    "RigidTransform.from_matrix(X) * RigidTransform.from_exp_coords(d)",
                    "se3",
                    None,
                    _scipy_rigid,
                    _NO_RETRACT.format(lib="scipy", side="right"),
                ),
                Probe(
                    "Rotation.from_matrix(R) * Rotation.from_rotvec(d)",
                    "so3",
                    None,
                    _scipy_rotation,
                    _NO_RETRACT.format(lib="scipy", side="right"),
                ),
            ),
            quaternion=lambda spt, R: [
                ("Rotation.as_quat()", spt.Rotation.from_matrix(R).as_quat())
            ],
        ),
        Library(
            "symforce",
            "sym",
            "symforce-sym",
            (
                Probe("sym.Pose3.retract", "se3", "symforce", _sym_pose3),
                Probe("sym.Rot3.retract", "so3", "symforce", _sym_rot3),
            ),
            quaternion=lambda sym, R: [
                (
                    "sym.Rot3.to_storage()",
                    np.asarray(sym.Rot3.from_rotation_matrix(R.copy()).to_storage()),
                )
            ],
            aliases=("sym",),
        ),
        Library(
            "modern_robotics",
            "modern_robotics",
            "modern_robotics",
            (
                Probe(
                    "T @ MatrixExp6(VecTose3(V_b)) (body twist)",
                    "se3",
                    "mr_body",
                    _mr_body,
                    "Modern Robotics has no retraction: the side is the probe's (body twist on "
                    "the right, space twist on the left, as in the book); the order is the "
                    "library's VecTose3",
                ),
                Probe(
                    "MatrixExp6(VecTose3(V_s)) @ T (space twist)",
                    "se3",
                    "mr_space",
                    _mr_space,
                    "as above, space twist on the left",
                ),
            ),
            aliases=("mr", "modern-robotics"),
        ),
        Library(
            "spatialmath",
            "spatialmath",
            "spatialmath-python",
            (
                Probe(
                    "X @ Twist3(d).exp()",
                    "se3",
                    None,
                    _sm_twist,
                    _NO_RETRACT.format(lib="spatialmath", side="right"),
                ),
            ),
            quaternion=lambda sm, R: [
                ("UnitQuaternion(R).vec", np.asarray(sm.UnitQuaternion(R).vec))
            ],
        ),
    )
}
_ALIASES = {a: lib.name for lib in LIBRARIES.values() for a in (lib.name, *lib.aliases)}


def resolve(name: str) -> Library:
    """Return the :class:`Library` called ``name`` (or an alias); suggest one when unknown."""
    key = name.strip().lower().replace("-", "_")
    key = _ALIASES.get(key, _ALIASES.get(name.strip().lower(), key))
    if key in LIBRARIES:
        return LIBRARIES[key]
    close = difflib.get_close_matches(key, list(_ALIASES), n=3, cutoff=0.5)
    libs = list(dict.fromkeys(_ALIASES[c] for c in close))
    hint = f"; did you mean {' or '.join(repr(c) for c in libs)}?" if libs else ""
    raise LibraryError(f"unknown library {name!r}{hint} (known: {', '.join(LIBRARIES)}, or 'all')")


def import_library(lib: Library) -> tuple[Any, str]:
    """Import ``lib``'s module (one clear error if it is missing); return it and its version."""
    try:
        module = importlib.import_module(lib.module)
    except ModuleNotFoundError as exc:
        top = lib.module.split(".")[0]
        if exc.name is not None and exc.name.split(".")[0] == top:
            raise LibraryError(f"{lib.name} is not installed (pip install {lib.pip})") from None
        raise LibraryError(f"{lib.name} cannot be imported: {exc}") from None
    except Exception as exc:  # a broken installation
        raise LibraryError(f"{lib.name} cannot be imported: {type(exc).__name__}: {exc}") from None
    try:
        version = importlib.metadata.version(lib.pip)
    except importlib.metadata.PackageNotFoundError:
        version = str(
            getattr(importlib.import_module(lib.module.split(".")[0]), "__version__", "?")
        )
    return module, version


def run_probe(lib: Library, probe: Probe, module: Any, version: str) -> ProbeResult:
    """Measure one probe: its convention by :func:`detect_convention`, and the quaternion order."""
    preset = single_group(get(probe.preset)) if probe.preset else None
    measured: Convention | None = None
    error = ""
    try:
        measured = detect_convention(
            probe.make(module),
            group=probe.group,
            prefer=probe.preset,
        )
    except ConventionNotDetected as exc:
        error = str(exc)
    quats: list[tuple[str, str]] = []
    if lib.quaternion is not None:
        quats = [(_storage_order(s), via) for via, s in lib.quaternion(module, R_PROBE)]
    return ProbeResult(lib.name, version, probe, measured, preset, quats, error)


def format_result(r: ProbeResult) -> str:
    """Format a result as a small table (field, measured, preset), then the verdict."""
    head = f"{r.library} {r.version}: {r.probe.what}"
    if r.measured is None:
        return f"{head}\n  no convention of the model reproduces it:\n  " + r.error.replace(
            "\n", "\n  "
        )
    so3_only = _rotation_only(r.probe.group)
    fields = ["side", "order", "chart", "rotation", "quat_order"]
    pname = f"preset {r.preset.name!r}" if r.preset else "preset (none)"
    table = [("field", "measured", pname)]
    for f in fields:
        if f == "quat_order":
            m = r.quaternion[0][0] if r.quaternion else "(no quaternions)"
        elif so3_only and f in ("order", "chart"):
            m = "n/a (rotation)"
        else:
            m = str(getattr(r.measured, f))
        p = str(getattr(r.preset, f)) if r.preset else "-"
        if so3_only and f in ("order", "chart") and r.preset:
            p = "n/a"
        table.append((f, m, p))
    w0, w1 = (max(len(t[i]) for t in table) for i in (0, 1))
    lines = [head] + [f"  {a.ljust(w0)}  {b.ljust(w1)}  {c}".rstrip() for a, b, c in table]
    for order, via in r.quaternion:
        lines.append(f"  quaternion storage: {order} via {via}")
    if r.probe.note:
        lines.append(f"  note: {r.probe.note}")
    same = matches_so3(r.measured) if so3_only else matching_presets(r.measured)
    names = ", ".join(c.name for c in same) or "none"
    if r.agrees is None:
        lines.append(f"  => no preset for {r.library}; presets with this retraction: {names}")
    elif r.agrees:
        lines.append(f"  => agrees with preset {r.preset.name!r} (same retraction: {names})")  # type: ignore[union-attr]
    else:
        lines.append(
            f"  => DIFFERS from preset {r.preset.name!r}; presets with the measured retraction: "  # type: ignore[union-attr]
            f"{names}"
        )
    return "\n".join(lines)
