"""The kernels' fast paths without validation, for liebridge's own layers.

**No validation**: inputs must already be float64 arrays of the right trailing shape, finite,
with rotation parts in SO(3) (the public functions of :mod:`~liebridge.lie.so3` and
:mod:`~liebridge.lie.se3` check that and then call these). Nothing here copies its input, raises
on bad input or checks its output; a wrong shape or a non-rotation gives a wrong answer, not an
error. Conventions are those of the public kernels: rotation-first twists ``(ω, v)``, ``jr``/``jl``
the right/left Jacobians, ``Ad(T)`` in ``(ω, v)``.

Users should call the public modules; the conventions, the GTSAM factors and the IMU kernel call
these after validating once at their own boundary.
"""

from __future__ import annotations

from . import se3 as _se3
from . import so3 as _so3

#: ``hat(w) @ p == cross(w, p)``, ``(..., 3)`` → ``(..., 3, 3)``.
so3_hat = _so3._hat
#: Rodrigues' formula, ``(..., 3)`` → ``(..., 3, 3)``.
so3_exp = _so3._exp
#: Principal logarithm (exact at θ = π), ``(..., 3, 3)`` → ``(..., 3)``.
so3_log = _so3._log
#: ``Exp(ω + δ) ≈ Exp(ω)·Exp(jr(ω) δ)``.
so3_jr = _so3._jr
#: ``Exp(ω + δ) ≈ Exp(jl(ω) δ)·Exp(ω)``.
so3_jl = _so3._jl
so3_jr_inv = _so3._jr_inv
so3_jl_inv = _so3._jl_inv

#: ``[[R, t], [0, 1]]`` from ``R (..., 3, 3)`` and ``t (..., 3)``.
se3_assemble = _se3._assemble
#: True SE(3) exponential of ``ξ = (ω, v)``.
se3_exp = _se3._exp
#: Principal logarithm, ``(..., 4, 4)`` → ``(..., 6)`` in ``(ω, v)``.
se3_log = _se3._log
#: ``T⁻¹ = [[Rᵀ, −Rᵀt], [0, 1]]`` (closed form, no matrix inversion).
se3_inverse = _se3._inverse
#: ``Ad(T) = [[R, 0], [hat(t) R, R]]`` in ``(ω, v)``.
se3_adjoint = _se3._adjoint
se3_jl = _se3._jl
se3_jl_inv = _se3._jl_inv

__all__ = [
    "se3_adjoint",
    "se3_assemble",
    "se3_exp",
    "se3_inverse",
    "se3_jl",
    "se3_jl_inv",
    "se3_log",
    "so3_exp",
    "so3_hat",
    "so3_jl",
    "so3_jl_inv",
    "so3_jr",
    "so3_jr_inv",
    "so3_log",
]
