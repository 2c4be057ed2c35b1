"""A user's covariance transformation against Monte Carlo through conventions."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..check import monte_carlo_covariance
from ..conventions import Convention, ConventionLike, get, single_group, tangent_map
from .elements import as_element, conventions_classes, label
from .jacobian import _Call, _cause_of
from .result import Diagnosis

__all__ = ["diagnose_covariance"]


def _rel(A: FloatArray, B: FloatArray) -> float:
    return float(np.linalg.norm(A - B) / max(1e-300, float(np.linalg.norm(B))))


def diagnose_covariance(
    propagate: Callable[[Any, Any], Any],
    T: Any,
    cov: Any,
    *,
    src: ConventionLike | None = None,
    dst: ConventionLike | None = None,
    n: int = 20000,
    rng: np.random.Generator | None = None,
    tol: float = 1e-6,
) -> Diagnosis:
    """Check a user's covariance transformation at a pose against the conventions' own maps.

    ``propagate(cov, T)`` claims to turn the covariance of a perturbation of ``T`` in one
    convention's tangent (``src``) into the covariance of the same uncertainty in another's
    (``dst``) — the frame change ``Σ_left = Ad_T·Σ_right·Ad_Tᵀ`` of the failure table is the
    case ``src`` right, ``dst`` left. The result is compared with the first-order map
    ``M·Σ·Mᵀ``, ``M = lb.tangent_map(T, a, b)``, for every pair of candidate conventions
    ``(a, b)`` (grouped into classes), and with the catalogue of mistakes for the given
    ``src``/``dst``: the adjoint missing (``Σ`` returned as it came), the wrong 6-vector order,
    the adjoint block layout of the other order (docs/common-formula-errors.md, E4), the inverse
    adjoint. The given pair (or the best-matching one) is also checked by Monte Carlo
    (:func:`liebridge.check.monte_carlo_covariance`, ``n`` samples; sampling error about
    ``√(2/n)``).

    Parameters
    ----------
    propagate : callable
        ``propagate(cov, T)`` → ``(d, d)`` covariance (the package's argument order).
    T : array_like, shape (4, 4) or (3, 3)
        The pose (or rotation).
    cov : array_like, shape (d, d)
        The input covariance in ``src``'s tangent.
    src, dst : Convention or str, optional
        What ``propagate`` is meant to do, when known.
    n : int
        Monte Carlo samples.
    rng : numpy.random.Generator, optional
        Default: seeded (deterministic).
    tol : float
        Relative (Frobenius) error below which a first-order candidate explains the result.

    Returns
    -------
    Diagnosis
        ``verdict`` ``"correct"``, ``"mistake"``, ``"convention_mismatch"`` or
        ``"unexplained"``; ``cause`` ``"missing_adjoint"``, ``"wrong_order"``,
        ``"adjoint_block_layout"``, ``"inverse_adjoint"``, ...; ``evidence`` the errors of the
        best candidates and the Monte Carlo comparison.

    Raises
    ------
    ValueError
        When ``propagate`` raises, returns NaN/Inf or the wrong shape, or ``cov`` is not a
        covariance.
    """
    if not callable(propagate):
        raise TypeError(f"propagate: expected a callable, got {type(propagate).__name__}")
    el = as_element(T, "T")
    rec = el.record
    if rec is None:
        raise ValueError(f"T: expected a pose or rotation, got shape {el.array.shape}")
    d = el.dim
    C = validate.covariance(cov, "cov", d)
    a0 = single_group(get(src), "src") if src is not None else None
    b0 = single_group(get(dst), "dst") if dst is not None else None
    U = _Call(propagate, "propagate")([C.copy(), el.rebuild(el.array.copy())], "T")
    if U.shape != (d, d):
        raise ValueError(f"propagate: returned shape {U.shape}, expected ({d}, {d})")
    Tm = el.array
    extra = [c for c in (a0, b0) if c is not None]
    classes = conventions_classes(el.kind, [Tm], extra)
    cands: list[tuple[str, str, float, Convention, Convention]] = []
    for ca in classes:
        for cb in classes:
            M = np.asarray(tangent_map(Tm, ca.rep, cb.rep), dtype=np.float64)
            if M.shape != (d, d):
                continue
            pred = M @ C @ M.T
            words = f"{label(ca.members, el.kind)} → {label(cb.members, el.kind)}"
            cands.append(("", words, _rel(U, pred), ca.rep, cb.rep))
    cands.sort(key=lambda c: (c[2] > tol, 0 if c[3] == c[4] else 1, c[2]))

    def cls_of(c: Convention) -> Any:
        return next(k for k in classes if c in k.members)

    mistakes: list[tuple[str, str, float]] = []
    if a0 is not None and b0 is not None:
        M = np.asarray(tangent_map(Tm, a0, b0), dtype=np.float64)
        mistakes.append(("", f"{a0.name} → {b0.name} (M·Σ·Mᵀ)", _rel(U, M @ C @ M.T)))
        if cls_of(a0) is not cls_of(b0):
            mistakes.append(("missing_adjoint", "Σ returned unchanged", _rel(U, C)))
        Mi = np.linalg.inv(M)
        mistakes.append(("inverse_adjoint", "M⁻¹·Σ·M⁻ᵀ (Ad_T⁻¹ for Ad_T)", _rel(U, Mi @ C @ Mi.T)))
        if rec.vecs:  # a tangent with translation blocks: the other order is a mistake
            other = "trans_first" if rec.canonical_order == "rot_first" else "rot_first"
            P = np.eye(d)[rec.perm(other)]  # canonical → the other order
            for W, side in ((P @ M, "output"), (P.T @ M, "output"), (M @ P, "input")):
                mistakes.append(
                    (
                        "wrong_order",
                        f"the intended map with its {side} in the other order",
                        _rel(U, W @ C @ W.T),
                    )
                )
            L = P @ M @ P.T  # M's blocks laid out in the other order
            mistakes.append(
                (
                    "adjoint_block_layout",
                    "the map's blocks laid out for the other order",
                    _rel(U, L @ C @ L.T),
                )
            )
    evidence: dict[str, Any] = {
        "candidates": [
            {"explanation": w, "error": e, "src": a.name, "dst": b.name}
            for _, w, e, a, b in cands[:8]
        ],
        "catalogue": [
            {"cause": c or "intended", "explanation": w, "error": e} for c, w, e in mistakes
        ],
    }
    mc_pair = (a0, b0) if (a0 is not None and b0 is not None) else (cands[0][3], cands[0][4])
    ref = monte_carlo_covariance(
        C, Tm, mc_pair[0], mc_pair[1], n=n, rng=rng or np.random.default_rng(0)
    )
    mc_err = _rel(U, ref)
    evidence["monte_carlo"] = {
        "src": mc_pair[0].name,
        "dst": mc_pair[1].name,
        "samples": n,
        "relative_error": mc_err,
        "sampling_error": math.sqrt(2.0 / n),
    }
    mc_words = (
        f"Monte Carlo through {mc_pair[0].name} → {mc_pair[1].name} ({n} samples): relative "
        f"error {mc_err:.2%} (sampling error ≈ {math.sqrt(2.0 / n):.1%})"
    )
    if mistakes and a0 is not None and b0 is not None:
        best = min(mistakes, key=lambda m: (m[2] > tol, m[0] != "", m[2]))
        if best[2] <= tol:
            if best[0] == "":
                return Diagnosis(
                    "correct",
                    f"your propagation is the first-order map {a0.name} → {b0.name} "
                    f"(error {best[2]:.1e}); {mc_words}.",
                    evidence,
                )
            fix = {
                "missing_adjoint": "apply M = lb.tangent_map(T, src, dst): Σ' = M·Σ·Mᵀ",
                "inverse_adjoint": "use Ad_T where Ad_T⁻¹ stands (δ_left = Ad_T·δ_right)",
                "wrong_order": "permute to the destination's order (rotation/translation blocks)",
                "adjoint_block_layout": "for (v, ω) Ad_T = [[R, hat(t)R], [0, R]]; for (ω, v) "
                "[[R, 0], [hat(t)R, R]] (a common swap: docs/common-formula-errors.md, E4)",
            }[best[0]]
            return Diagnosis(
                "mistake",
                f"your propagation is {best[1]} (error {best[2]:.1e}) instead of {a0.name} → "
                f"{b0.name}; {mc_words}. Fix: {fix}.",
                evidence,
                best[0],
            )
    top = cands[0]
    if top[2] <= tol:
        if a0 is None or b0 is None:
            return Diagnosis(
                "correct",
                f"your propagation maps {top[1]} (error {top[2]:.1e}); {mc_words}.",
                evidence,
            )
        causes = [
            _cause_of(found, want, el.kind)
            for found, want in ((top[3], a0), (top[4], b0))
            if cls_of(found) is not cls_of(want)
        ]
        cause = "+".join(dict.fromkeys("+".join(causes).split("+"))) or "convention"
        return Diagnosis(
            "convention_mismatch",
            f"your propagation maps {top[1]} (error {top[2]:.1e}), not {a0.name} → "
            f"{b0.name} ({cause.replace('+', ', ')}); {mc_words}.",
            evidence,
            cause,
        )
    return Diagnosis(
        "unexplained",
        f"no pair of conventions or known mistake reproduces your propagation (closest: "
        f"{top[1]}, error {top[2]:.2g}); {mc_words}.",
        evidence,
        "unexplained",
    )
