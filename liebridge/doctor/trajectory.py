"""Scan a trajectory for the failure table's sequence symptoms.

What is measured (each a finding with a severity; ``alarm`` and ``warning`` set the verdict,
``info`` is reported but is not a problem by itself):

- timestamps: duplicates and backward steps (alarm), gaps longer than ``gap_factor`` × the
  median step (warning);
- rotations that are not orthonormal, quaternions that are not unit (alarm);
- pose jumps: a step whose rotation or translation rate is ten times the median and large in
  absolute terms (alarm); a step of nearly 180°, where a between residual ``Log(R_kᵀ·R_{k+1})``
  sits on the log's branch cut (alarm);
- rotation-log branch-cut crossings: ``‖Log(R_refᵀR)‖`` near π with ``Log`` jumping between
  consecutive samples while the rotation itself moves little (info: a residual written as
  ``Log(R_refᵀR)`` would jump there, the trajectory does not);
- quaternion sign flips between consecutive samples, ``dot(q_k, q_{k+1}) < 0`` (info, with the
  angle a SLERP without the hemisphere check would turn through);
- the quaternion storage order (``xyzw`` vs ``wxyz``) measured from two independent pieces of
  evidence: the sign (writers that keep ``w ≥ 0`` leave one column never negative while the
  other end column changes sign) and the motion (a vehicle moves along a fixed body axis, so
  the body-frame velocity direction is steady under the right reading and wanders under the
  wrong one). A contradiction of the declared order with high confidence is an alarm; a
  trajectory that carries no evidence (a turn in place, constant orientation) gets
  ``"undetermined"`` and no alarm.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..lie import quaternion, so3
from .result import Diagnosis

__all__ = ["measure_quat_order", "scan_trajectory"]

#: A step counts as a jump when its rate exceeds this many median rates.
JUMP_FACTOR = 10.0
#: ... and is at least this large (rad, m).
JUMP_MIN_ROT = 0.2
JUMP_MIN_TRANS = 0.2
#: Body velocities are read from chords over this many steps (position noise averages out).
MOTION_STRIDE = 5
#: ``‖Log(R_refᵀR)‖`` within this of π counts as near the branch cut.
BRANCH_BAND = 0.35


def _finding(kind: str, severity: str, message: str, **values: Any) -> dict[str, Any]:
    return {"kind": kind, "severity": severity, "message": message, **values}


def _rotations_from_quats(q: FloatArray, order: str) -> FloatArray:
    qn = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return quaternion.to_matrix(qn, order=order)  # type: ignore[arg-type]


def _body_velocity_consistency(R: FloatArray, t: FloatArray) -> tuple[float, int]:
    """Mean resultant length of the body-frame velocity directions, and how many steps moved."""
    k = MOTION_STRIDE if len(t) >= 10 * MOTION_STRIDE else 1  # chords over k steps: less noise
    dt = t[k:] - t[:-k]
    step = np.linalg.norm(dt, axis=-1)
    if step.size == 0:
        return 0.0, 0
    moving = step > max(1e-9, 0.2 * float(np.median(step)))
    if moving.sum() < 10:
        return 0.0, int(moving.sum())
    Rmid = R[k // 2 : k // 2 + len(dt)]
    v_body = np.einsum("nji,nj->ni", Rmid[moving], dt[moving])
    u = v_body / np.linalg.norm(v_body, axis=-1, keepdims=True)
    return float(np.linalg.norm(u.mean(axis=0))), int(moving.sum())


def measure_quat_order(q: Any, positions: Any = None) -> dict[str, Any]:
    """Measure whether quaternion rows are stored ``xyzw`` or ``wxyz``.

    Parameters
    ----------
    q : array_like, shape (N, 4)
        The rows as stored.
    positions : array_like, shape (N, 3), optional
        The positions, for the motion evidence.

    Returns
    -------
    dict
        ``order`` (``"xyzw"``, ``"wxyz"`` or ``"undetermined"``), ``confidence`` (``"high"``,
        ``"low"`` or ``"none"``) and the evidence: ``sign`` (the reading whose ``w`` column is
        never negative and ≈ 0 at every sign flip — a ``w ≥ 0`` writer — or None) and
        ``motion`` (body-velocity consistency under each reading, 1 = a steady body direction).
    """
    Q = validate.as_float_array(q, "q")
    if Q.ndim != 2 or Q.shape[1] != 4:
        raise ValueError(f"q: expected shape (N, 4), got {Q.shape}")
    neg_first = float(np.mean(Q[:, 0] < 0))
    neg_last = float(np.mean(Q[:, 3] < 0))
    # a writer that keeps w ≥ 0 leaves w never negative and flips the sign where w crosses 0:
    # the column that is never negative and near 0 at every sign flip is w
    flips = np.flatnonzero(np.einsum("ni,ni->n", Q[:-1], Q[1:]) < 0)
    fits = [
        order
        for order, c in (("wxyz", 0), ("xyzw", 3))
        if flips.size
        and (Q[:, c] >= 0).all()
        and (np.abs(Q[flips, c]) < 0.3).all()
        and (np.abs(Q[flips + 1, c]) < 0.3).all()
    ]
    sign = fits[0] if len(fits) == 1 else None
    motion: dict[str, float] = {}
    motion_vote = None
    moving = 0
    if positions is not None:
        t = validate.as_float_array(positions, "positions")
        for order in ("xyzw", "wxyz"):
            c, moving = _body_velocity_consistency(_rotations_from_quats(Q, order), t)
            motion[order] = c
        if moving >= 10:
            best = max(motion, key=lambda k: motion[k])
            other = "wxyz" if best == "xyzw" else "xyzw"
            if motion[best] > 0.6 and motion[best] - motion[other] > 0.2:
                motion_vote = best
    votes = {v for v in (sign, motion_vote) if v is not None}
    if len(votes) == 1:
        order = votes.pop()
        confidence = "high"
    elif len(votes) == 2:
        order, confidence = "undetermined", "none"  # the two pieces of evidence disagree
    else:
        order, confidence = "undetermined", "none"
        if motion:
            best = max(motion, key=lambda k: motion[k])
            if motion[best] - min(motion.values()) > 0.05 and moving >= 10:
                order, confidence = best, "low"
    return {
        "order": order,
        "confidence": confidence,
        "sign": sign,
        "negative_fraction": {"first_column": neg_first, "last_column": neg_last},
        "motion": motion,
        "moving_steps": moving,
    }


def _read(
    data: Any, n: int, quat_order: str | None
) -> tuple[
    FloatArray, FloatArray | None, FloatArray | None, list[dict[str, Any]], dict[str, Any] | None
]:
    """``(R, t, q, findings, order_evidence)`` from poses, rotations, quaternions or TUM rows."""
    A = validate.as_float_array(data, "T")
    validate.check_finite(A, "T")
    findings: list[dict[str, Any]] = []
    if A.shape[:1] != (n,):
        raise ValueError(f"T: expected {n} samples to match stamps, got shape {A.shape}")
    if A.ndim == 3 and A.shape[1:] in ((4, 4), (3, 3)):
        R = A[:, :3, :3]
        t = A[:, :3, 3] if A.shape[1:] == (4, 4) else None
        err = np.abs(np.einsum("nji,njk->nik", R, R) - np.eye(3)).max(axis=(1, 2))
        det = np.linalg.det(R)
        bad = np.flatnonzero((err > 1e-6) | (det < 0))
        if bad.size:
            findings.append(
                _finding(
                    "non_orthonormal",
                    "alarm",
                    f"{bad.size} rotation(s) are not orthonormal with det +1 (first at index "
                    f"{int(bad[0])}: |RᵀR − I| = {err[bad[0]]:.2g}, det = {det[bad[0]]:.6g})",
                    indices=bad[:20].tolist(),
                )
            )
            R = so3.project(R)
        return R, t, None, findings, None
    if A.ndim == 2 and A.shape[1] in (4, 7):
        q = A[:, -4:]
        t = A[:, :3] if A.shape[1] == 7 else None
        norm = np.linalg.norm(q, axis=-1)
        bad = np.flatnonzero(np.abs(norm - 1.0) > 1e-3)
        if bad.size:
            findings.append(
                _finding(
                    "non_unit_quaternion",
                    "alarm",
                    f"{bad.size} quaternion(s) are not unit (first at index {int(bad[0])}: "
                    f"norm {norm[bad[0]]:.6g})",
                    indices=bad[:20].tolist(),
                )
            )
        if (norm < 1e-9).any():
            raise ValueError(f"T: zero quaternion at index {int(np.argmin(norm))}")
        ev = measure_quat_order(q, t)
        declared = quat_order
        use = declared or "xyzw"
        if ev["order"] in ("xyzw", "wxyz") and ev["confidence"] == "high":
            if declared is not None and ev["order"] != declared:
                findings.append(
                    _finding(
                        "quat_order",
                        "alarm",
                        f"the quaternions are stored {ev['order']} ({'w first' if ev['order'] == 'wxyz' else 'w last'}), "  # noqa: E501
                        f"but were declared {declared} (confidence high: "
                        + _order_words(ev)
                        + f"); read them as {ev['order']}",
                        measured=ev["order"],
                        declared=declared,
                    )
                )
            use = ev["order"]
        return _rotations_from_quats(q, use), t, q, findings, ev
    raise ValueError(
        "T: expected poses (N, 4, 4), rotations (N, 3, 3), quaternions (N, 4) or rows "
        f"(tx, ty, tz, q…) (N, 7); got shape {A.shape}"
    )


def _order_words(ev: dict[str, Any]) -> str:
    parts = []
    if ev["sign"] is not None:
        col = "first" if ev["sign"] == "wxyz" else "last"
        parts.append(f"the {col} column is never negative and ≈ 0 at every sign flip")
    if ev["motion"]:
        m = ev["motion"]
        parts.append(
            f"body-velocity steadiness {m['wxyz']:.2f} read wxyz vs {m['xyzw']:.2f} read xyzw"
        )
    return ", ".join(parts) or "no evidence"


def scan_trajectory(
    stamps: Any,
    T: Any,
    *,
    quat_order: str | None = None,
    reference: Any = None,
    gap_factor: float = 5.0,
) -> Diagnosis:
    """Scan a trajectory for branch-cut crossings, sign flips, bad rotations, time problems.

    Parameters
    ----------
    stamps : array_like, shape (N,)
        Timestamps (seconds).
    T : array_like
        Poses ``T_world_body`` ``(N, 4, 4)``, rotations ``(N, 3, 3)``, quaternions ``(N, 4)`` or
        TUM-style rows ``(tx, ty, tz, q0, q1, q2, q3)`` ``(N, 7)``. Quaternion storage order: see
        ``quat_order``.
    quat_order : {"xyzw", "wxyz"}, optional
        The declared storage order of quaternion data (TUM files declare ``xyzw``). The order is
        measured either way; a confident measurement that contradicts the declaration is an
        alarm, and the measured order is used for the other checks.
    reference : array_like, shape (3, 3) or (4, 4), optional
        ``R_ref`` of the branch-cut scan ``‖Log(R_refᵀR_k)‖``; default the first rotation.
    gap_factor : float
        A time step longer than this many median steps is a gap.

    Returns
    -------
    Diagnosis
        ``verdict`` ``"ok"`` (no alarm or warning; information may be listed), ``"warning"``
        or ``"alarm"``; ``evidence["findings"]`` lists every finding with its kind
        (``duplicate_stamp``, ``backward_stamp``, ``time_gap``, ``non_orthonormal``,
        ``non_unit_quaternion``, ``pose_jump``, ``between_near_pi``, ``branch_cut``, ``sign_flip``,
        ``quat_order``), severity, indices and message; ``evidence["quat_order"]`` the order
        measurement.

    Raises
    ------
    ValueError
        On shapes that do not match, NaN/Inf, fewer than two samples, a zero quaternion.
    """
    s = validate.as_float_array(stamps, "stamps")
    if s.ndim != 1:
        raise ValueError(f"stamps: expected shape (N,), got {s.shape}")
    validate.check_finite(s, "stamps")
    n = s.shape[0]
    if n < 2:
        raise ValueError(f"stamps: need at least 2 samples, got {n}")
    if quat_order is not None:
        quat_order = validate.option(quat_order, "quat_order", ("xyzw", "wxyz"))
    R, t, q, findings, order_ev = _read(T, n, quat_order)

    # --- time
    dt = np.diff(s)
    dup = np.flatnonzero(dt == 0)
    back = np.flatnonzero(dt < 0)
    if dup.size:
        findings.append(
            _finding(
                "duplicate_stamp",
                "alarm",
                f"{dup.size} duplicate timestamp(s) (first: samples {int(dup[0])} and "
                f"{int(dup[0]) + 1} at t = {s[dup[0]]:.9g})",
                indices=dup[:20].tolist(),
            )
        )
    if back.size:
        findings.append(
            _finding(
                "backward_stamp",
                "alarm",
                f"{back.size} backward time step(s) (first: {s[back[0]]:.9g} → "
                f"{s[back[0] + 1]:.9g} at sample {int(back[0]) + 1})",
                indices=back[:20].tolist(),
            )
        )
    pos = dt[dt > 0]
    med = float(np.median(pos)) if pos.size else 0.0
    if med > 0:
        gaps = np.flatnonzero(dt > gap_factor * med)
        if gaps.size:
            findings.append(
                _finding(
                    "time_gap",
                    "warning",
                    f"{gaps.size} time gap(s) over {gap_factor:g}× the median step {med:.3g} s "
                    f"(largest {dt[gaps].max():.3g} s after sample {int(gaps[np.argmax(dt[gaps])])})",  # noqa: E501
                    indices=gaps[:20].tolist(),
                )
            )

    # --- pose jumps (rates, so a gap is not a jump)
    inc = so3.log(np.einsum("nji,njk->nik", R[:-1], R[1:]))
    ang = np.linalg.norm(inc, axis=-1)
    safe_dt = np.where(dt > 0, dt, med if med > 0 else 1.0)
    rate = ang / safe_dt
    jumps = set(
        np.flatnonzero(
            (rate > JUMP_FACTOR * max(float(np.median(rate)), 1e-12)) & (ang > JUMP_MIN_ROT)
        ).tolist()
    )
    if t is not None:
        step = np.linalg.norm(np.diff(t, axis=0), axis=-1)
        vel = step / safe_dt
        jumps |= set(
            np.flatnonzero(
                (vel > JUMP_FACTOR * max(float(np.median(vel)), 1e-12)) & (step > JUMP_MIN_TRANS)
            ).tolist()
        )
    runs: list[list[int]] = []
    for k in sorted(jumps):  # consecutive jumping steps are one event (a spin, a glitch)
        if runs and k == runs[-1][-1] + 1:
            runs[-1].append(k)
        else:
            runs.append([k])
    for run in runs[:20]:
        k0, k1 = run[0], run[-1]
        steps = f"{len(run)} steps, largest" if len(run) > 1 else "rotation"
        findings.append(
            _finding(
                "pose_jump",
                "alarm",
                f"the pose jumps between samples {k0} and {k1 + 1}: {steps} "
                f"{math.degrees(float(ang[run].max())):.1f}° (median step "
                f"{math.degrees(float(np.median(ang))):.2g}°)"
                + (
                    f", translation {float(np.linalg.norm(t[k1 + 1] - t[k0])):.3g} m"
                    if t is not None
                    else ""
                ),
                index=int(k0),
                indices=[int(i) for i in run],
            )
        )

    # --- a between residual Log(R_kᵀ·R_{k+1}) on the branch cut: its axis is undefined
    near_pi = np.flatnonzero(ang > math.pi - BRANCH_BAND)
    if near_pi.size:
        findings.append(
            _finding(
                "between_near_pi",
                "alarm",
                f"{near_pi.size} consecutive step(s) rotate by nearly 180° (first between "
                f"samples {int(near_pi[0])} and {int(near_pi[0]) + 1}: "
                f"{math.degrees(float(ang[near_pi[0]])):.1f}°): a between residual "
                "Log(R_kᵀ·R_{k+1}) sits on the log's branch cut there (axis defined up to sign)",
                indices=near_pi[:20].tolist(),
            )
        )

    # --- rotation-log branch cut ‖Log(R_refᵀR)‖ near π
    if reference is None:
        Rref = R[0]
    else:
        ref = validate.as_float_array(reference, "reference")
        if ref.shape not in ((3, 3), (4, 4)):
            raise ValueError(f"reference: expected (3, 3) or (4, 4), got {ref.shape}")
        Rref = validate.rotation(ref[:3, :3], "reference")
    w = so3.log(np.einsum("ji,njk->nik", Rref, R))
    th = np.linalg.norm(w, axis=-1)
    jump_w = np.linalg.norm(np.diff(w, axis=0), axis=-1)
    near = (th[:-1] > math.pi - BRANCH_BAND) & (th[1:] > math.pi - BRANCH_BAND)
    cross = np.flatnonzero(near & (jump_w > math.pi) & (ang < 0.5 * jump_w))
    for k in cross[:20]:
        findings.append(
            _finding(
                "branch_cut",
                "info",
                f"Log(R_refᵀR) crosses the branch cut between samples {int(k)} and {int(k) + 1} "
                f"(‖Log‖ {th[k]:.3f} → {th[k + 1]:.3f} rad, Log jumps by {jump_w[k]:.2f} rad "
                f"while the rotation moves {math.degrees(ang[k]):.2g}°): a residual written as "
                "Log(R_refᵀR) would jump here",
                index=int(k),
            )
        )

    # --- quaternion sign flips
    if q is not None:
        qn = q / np.linalg.norm(q, axis=-1, keepdims=True)
        dots = np.einsum("ni,ni->n", qn[:-1], qn[1:])
        flips = np.flatnonzero(dots < 0)
        wcol = 0 if (order_ev and order_ev["order"] == "wxyz") or quat_order == "wxyz" else 3
        if order_ev and order_ev["order"] == "xyzw":
            wcol = 3
        for k in flips[:20]:
            d = float(np.clip(dots[k], -1.0, 1.0))
            at_zero = abs(qn[k, wcol]) < 0.3 and abs(qn[k + 1, wcol]) < 0.3
            spin = math.degrees(2.0 * math.acos(d))
            true_angle = math.degrees(2.0 * math.acos(-d))
            findings.append(
                _finding(
                    "sign_flip",
                    "info",
                    f"quaternion sign flip between samples {int(k)} and {int(k) + 1} "
                    f"(dot = {d:.4f}): a SLERP without the hemisphere check would turn "
                    f"{spin:.1f}° instead of {true_angle:.2g}° (negate q_b when dot < 0)"
                    + ("; w ≈ 0 here: the flip of a writer that keeps w ≥ 0" if at_zero else ""),
                    index=int(k),
                    dot=d,
                    slerp_spin_deg=spin,
                )
            )

    counts = {sev: sum(f["severity"] == sev for f in findings) for sev in ("alarm", "warning")}
    info = [f for f in findings if f["severity"] == "info"]
    problems = [f for f in findings if f["severity"] != "info"]
    verdict = "alarm" if counts["alarm"] else ("warning" if counts["warning"] else "ok")
    head = (
        f"{n} samples: no problems found"
        if verdict == "ok"
        else f"{n} samples: {counts['alarm']} alarm(s), {counts['warning']} warning(s)"
    )
    lines = [head + "."]
    lines += [f"- {f['severity']}: {f['message']}" for f in problems]
    if info:
        kinds = sorted({f["kind"] for f in info})
        lines.append(f"information ({len(info)}: {', '.join(kinds)}; not problems by themselves):")
        lines += [f"- {f['message']}" for f in info]
    if order_ev is not None:
        lines.append(
            f"quaternion storage order: measured {order_ev['order']} "
            f"(confidence {order_ev['confidence']}: {_order_words(order_ev)})"
            + (f"; declared {quat_order}" if quat_order else "")
        )
    evidence = {
        "samples": n,
        "findings": findings,
        "quat_order": order_ev,
        "median_dt": med,
        "max_log_angle": float(th.max()),
    }
    cause = problems[0]["kind"] if problems else ""
    return Diagnosis(verdict, "\n".join(lines), evidence, cause)
