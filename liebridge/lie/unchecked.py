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

from . import se2 as _se2
from . import se3 as _se3
from . import se23 as _se23
from . import sim3 as _sim3
from . import so2 as _so2
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

# The other groups' fast paths (canonical tangent orders and matrices of their public modules).
so2_exp, so2_log, so2_inverse, so2_adjoint = _so2._exp, _so2._log, _so2._inverse, _so2._adjoint
se2_exp, se2_log, se2_inverse, se2_adjoint = _se2._exp, _se2._log, _se2._inverse, _se2._adjoint
se2_jr_inv, se2_jl_inv = _se2._jr_inv, _se2._jl_inv
sim3_exp, sim3_log, sim3_inverse = _sim3._exp, _sim3._log, _sim3._inverse
sim3_adjoint, sim3_jr_inv, sim3_jl_inv = _sim3._adjoint, _sim3._jr_inv, _sim3._jl_inv
sim3_scale = _sim3._scale
se23_exp, se23_log, se23_inverse = _se23._exp, _se23._log, _se23._inverse
se23_adjoint, se23_jr_inv, se23_jl_inv = _se23._adjoint, _se23._jr_inv, _se23._jl_inv

__all__ = [
    "se2_adjoint",
    "se2_exp",
    "se2_inverse",
    "se2_jl_inv",
    "se2_jr_inv",
    "se2_log",
    "se3_adjoint",
    "se3_assemble",
    "se3_exp",
    "se3_inverse",
    "se3_jl",
    "se3_jl_inv",
    "se3_log",
    "se23_adjoint",
    "se23_exp",
    "se23_inverse",
    "se23_jl_inv",
    "se23_jr_inv",
    "se23_log",
    "sim3_adjoint",
    "sim3_exp",
    "sim3_inverse",
    "sim3_jl_inv",
    "sim3_jr_inv",
    "sim3_log",
    "sim3_scale",
    "so2_adjoint",
    "so2_exp",
    "so2_inverse",
    "so2_log",
    "so3_exp",
    "so3_hat",
    "so3_jl",
    "so3_jl_inv",
    "so3_jr",
    "so3_jr_inv",
    "so3_log",
]
