"""A 50-digit reference of a convention's stated ``retract`` and ``local``, written from its fields.

Built with mpmath only (``expm``/``logm`` of the group's algebra element, quaternions, Cayley),
never with liebridge's kernels: it decides, where a library and a preset disagree, which side is
off. The maps, as the presets state them:

* group charts (``se3``, ``se2``, ``sim3``, ``se23``, ``so2``): ``X·Exp(d)`` (right) or
  ``Exp(d)·X`` (left), ``Exp`` = the matrix exponential of the algebra element;
* split charts (``so3xr3_*``/``split_*``): ``R·ΔR`` / ``ΔR·R`` and each vector ``t + A·u`` (body,
  ``A`` the element's rotation) or ``t + u`` (world);
* rotation coordinates: ``exp`` (rotation vector), ``half_exp`` (``Exp(2r)``), ``quat_vec``
  (``q = (√(1 − |r|²), r)``), ``cayley`` (``(I − K/2)⁻¹(I + K/2)``).
"""

from __future__ import annotations

import dataclasses

import mpmath
import numpy as np

from liebridge.conventions import Convention

DPS = 50
VEC = {"so3": 0, "so2": 0, "se2": 2, "se3": 3, "sim3": 3, "se23": 6}


def _m(A: np.ndarray) -> mpmath.matrix:
    return mpmath.matrix([[mpmath.mpf(float(x)) for x in row] for row in np.atleast_2d(A)])


def _f(M: mpmath.matrix) -> np.ndarray:
    return np.array([[float(M[i, j]) for j in range(M.cols)] for i in range(M.rows)])


def _hat(w: list) -> mpmath.matrix:
    return mpmath.matrix([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def _vee(K: mpmath.matrix) -> list:
    return [(K[2, 1] - K[1, 2]) / 2, (K[0, 2] - K[2, 0]) / 2, (K[1, 0] - K[0, 1]) / 2]


def _so3_log(R: mpmath.matrix) -> list:
    """Rotation vector of ``R`` in closed form (no ``logm``: its branch is unreliable near π)."""
    c = (R[0, 0] + R[1, 1] + R[2, 2] - 1) / 2
    w = [x / 2 for x in _vee(R - R.T)]  # sin θ · axis
    s = mpmath.sqrt(w[0] ** 2 + w[1] ** 2 + w[2] ** 2)
    th = mpmath.atan2(s, c)
    if th < 3:
        f = th / s if s != 0 else mpmath.mpf(1)
        return [f * x for x in w]
    B = (R + R.T) / 2 - c * mpmath.eye(3)  # (1 − cos θ)·a·aᵀ
    k = max(range(3), key=lambda i: B[i, i])
    a = [B[i, k] for i in range(3)]
    n = mpmath.sqrt(a[0] ** 2 + a[1] ** 2 + a[2] ** 2)
    a = [x / n for x in a]
    if a[0] * w[0] + a[1] * w[1] + a[2] * w[2] < 0:
        a = [-x for x in a]
    return [th * x for x in a]


def _phi1(A: mpmath.matrix) -> mpmath.matrix:
    """``∫₀¹ exp(sA) ds``: the top-right block of ``expm([[A, I], [0, 0]])``."""
    n = A.rows
    B = mpmath.zeros(2 * n, 2 * n)
    for i in range(n):
        B[i, n + i] = 1
        for j in range(n):
            B[i, j] = A[i, j]
    E = mpmath.expm(B)
    return E[0:n, n : 2 * n]


def _split(conv: Convention, group: str, d: np.ndarray) -> tuple[list, list, list]:
    """``d`` → (rotation coords, vector part, log-scale) as mp numbers."""
    v = [mpmath.mpf(float(x)) for x in np.asarray(d).reshape(-1)]
    nr = 1 if group in ("so2", "se2") else 3
    k = VEC[group]
    if conv.embed is not None:
        v = [v[i] for i in conv.embed.index]
        return v[k:], v[:k], []
    scale = [v.pop()] if group == "sim3" else []
    if conv.order == "rot_first":
        return v[:nr], v[nr : nr + k], scale
    return v[k:], v[:k], scale


def _rotation(conv: Convention, r: list) -> mpmath.matrix:
    if len(r) == 1:
        c, s = mpmath.cos(r[0]), mpmath.sin(r[0])
        return mpmath.matrix([[c, -s], [s, c]])
    K = _hat(r)
    if conv.rotation == "exp":
        return mpmath.expm(K)
    if conv.rotation == "half_exp":
        return mpmath.expm(2 * K)
    if conv.rotation == "quat_vec":
        x, y, z = r
        w = mpmath.sqrt(1 - x * x - y * y - z * z)
        return mpmath.matrix(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
            ]
        )
    if conv.rotation == "cayley":
        eye = mpmath.eye(3)
        return mpmath.inverse(eye - K / 2) * (eye + K / 2)
    raise ValueError(conv.rotation)


def _rot_coords(conv: Convention, dR: mpmath.matrix) -> list:
    if dR.rows == 2:
        return [mpmath.atan2(dR[1, 0], dR[0, 0])]
    if conv.rotation in ("exp", "half_exp"):
        w = _so3_log(dR)
        return [x / 2 for x in w] if conv.rotation == "half_exp" else w
    if conv.rotation == "quat_vec":  # sin(θ/2)·axis, w ≥ 0 (well conditioned near π too)
        w = _so3_log(dR)
        th = mpmath.sqrt(w[0] ** 2 + w[1] ** 2 + w[2] ** 2)
        f = mpmath.sin(th / 2) / th if th != 0 else mpmath.mpf(1) / 2
        return [f * x for x in w]
    if conv.rotation == "cayley":
        eye = mpmath.eye(3)
        return _vee(2 * mpmath.inverse(dR + eye) * (dR - eye))
    raise ValueError(conv.rotation)


def _algebra(group: str, r: list, u: list, scale: list) -> mpmath.matrix:
    if group == "so2":
        return mpmath.matrix([[0, -r[0]], [r[0], 0]])
    if group == "se2":
        return mpmath.matrix([[0, -r[0], u[0]], [r[0], 0, u[1]], [0, 0, 0]])
    if group == "so3":
        return _hat(r)
    n = 4 if group in ("se3", "sim3") else 5
    A = mpmath.zeros(n, n)
    K = _hat(r)
    for i in range(3):
        for j in range(3):
            A[i, j] = K[i, j] + (scale[0] if group == "sim3" and i == j else 0)
        A[i, 3] = u[i]
        if group == "se23":
            A[i, 4] = u[3 + i]
    return A


def _blocks(group: str, X: mpmath.matrix) -> tuple[mpmath.matrix, list[list]]:
    """Rotation block and the vector columns of an element (Sim(3) only as a group chart)."""
    nr = 2 if group in ("so2", "se2") else 3
    R = X[0:nr, 0:nr]
    cols = {"se2": [2], "se3": [3], "se23": [3, 4]}.get(group, [])
    return R, [[X[i, c] for i in range(nr)] for c in cols]


def _mp_inv(X: np.ndarray) -> np.ndarray:
    """The inverse at 50 digits, rounded (for a convention that stores the inverse)."""
    with mpmath.workdps(DPS):
        return _f(mpmath.inverse(_m(X)))


def retract(conv: Convention, group: str, X: np.ndarray, d: np.ndarray) -> np.ndarray:
    """50-digit ``conv.retract(X, d)`` (``group``: what ``X`` is; ``so3`` for an SE(3) preset's
    rotation part). A convention that stores the inverse updates ``X⁻¹``."""
    if conv.stores == "inverse":
        with mpmath.workdps(DPS):
            Y = _m(retract(dataclasses.replace(conv, stores="pose"), group, _mp_inv(X), d))
            return _f(mpmath.inverse(Y))
    with mpmath.workdps(DPS):
        Xm = _m(X)
        r, u, scale = _split(conv, group, d)
        if group in ("so3", "so2") or conv.chart in ("se3", "se2", "sim3", "se23", "so2"):
            if group == "so3" or (group == "so2"):
                E = _rotation(conv, r)
            else:
                E = mpmath.expm(_algebra(group, r, u, scale))
            return _f(Xm * E if conv.side == "right" else E * Xm)
        R, cols = _blocks(group, Xm)
        dR = _rotation(conv, r)
        Y = Xm.copy()
        nr = R.rows
        R2 = R * dR if conv.side == "right" else dR * R
        body = conv.chart in ("so3xr3_body", "split_body")
        for i in range(nr):
            for j in range(nr):
                Y[i, j] = R2[i, j]
        for c, col in enumerate(cols):
            uc = mpmath.matrix(u[c * nr : (c + 1) * nr])
            inc = R * uc if body else uc
            for i in range(nr):
                Y[i, Xm.cols - len(cols) + c] = col[i] + inc[i]
        return _f(Y)


def local(conv: Convention, group: str, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """50-digit ``conv.local(X, Y)`` (the inverse of :func:`retract`)."""
    if conv.stores == "inverse":
        return local(dataclasses.replace(conv, stores="pose"), group, _mp_inv(X), _mp_inv(Y))
    with mpmath.workdps(DPS):
        Xm, Ym = _m(X), _m(Y)
        if group in ("so3", "so2") or conv.chart in ("se3", "se2", "sim3", "se23", "so2"):
            D = mpmath.inverse(Xm) * Ym if conv.side == "right" else Ym * mpmath.inverse(Xm)
            if group in ("so3", "so2"):
                r, u, scale = _rot_coords(conv, D), [], []
            else:
                nr = 2 if group == "se2" else 3
                M = D[0:nr, 0:nr]
                scale = []
                if group == "sim3":
                    sc = mpmath.cbrt(mpmath.det(M))
                    M = M / sc
                    scale = [mpmath.log(sc)]
                r = [mpmath.atan2(M[1, 0], M[0, 0])] if group == "se2" else _so3_log(M)
                A = _algebra("so2" if group == "se2" else "so3", r, [], [])
                if group == "sim3":
                    A = A + scale[0] * mpmath.eye(3)
                W = _phi1(A)
                cols = {"se2": [2], "se3": [3], "sim3": [3], "se23": [3, 4]}[group]
                u = []
                for c in cols:
                    sol = mpmath.lu_solve(W, mpmath.matrix([D[i, c] for i in range(nr)]))
                    u += [sol[i] for i in range(nr)]
        else:
            RX, cx = _blocks(group, Xm)
            RY, cy = _blocks(group, Ym)
            dR = RX.T * RY if conv.side == "right" else RY * RX.T
            r = _rot_coords(conv, dR)
            body = conv.chart in ("so3xr3_body", "split_body")
            u, scale = [], []
            for a, b in zip(cx, cy, strict=True):
                diff = mpmath.matrix([b[i] - a[i] for i in range(len(a))])
                inc = RX.T * diff if body else diff
                u += [inc[i] for i in range(len(a))]
        if conv.embed is not None:
            out = [mpmath.mpf(0)] * conv.embed.size
            for i, x in zip(conv.embed.index, u + r, strict=True):
                out[i] = x
        else:
            out = (r + u if conv.order == "rot_first" else u + r) + scale
        return np.array([float(mpmath.re(x)) for x in out])
