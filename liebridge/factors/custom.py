"""Glue between analytic Python residuals and ``gtsam.CustomFactor``.

GTSAM's ``CustomFactor`` callback is ``f(this, values, H)``: ``H`` is ``None`` for error-only
calls, otherwise a list whose every entry must be *assigned* (an unset block crashes the process,
a wrongly shaped one is accepted silently — see ``shared/reference/conventions.md``). This module
is the only place that talks to that protocol: residuals are written as
``evaluate(values, want_jacobians) -> (error, [J_error_key, ...] | None)`` with every Jacobian
taken with respect to **GTSAM's own tangent of that variable** (``Pose3``: right, (ω, v);
vectors and ``imuBias.ConstantBias``: additive, bias order (acc, gyro)); the glue checks shapes and
finiteness and turns any exception into one naming the factor and its keys.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from typing import Any

import gtsam
import numpy as np

from .._validate import FloatArray

Evaluate = Callable[[Any, bool], tuple[FloatArray, "list[FloatArray] | None"]]


class FactorEvaluationError(RuntimeError):
    """A liebridge factor's residual or Jacobian could not be evaluated."""


class _Probe(threading.local):
    """While ``active``, liebridge callbacks record their batch spec instead of computing.

    :func:`liebridge.factors.optimize` uses it to find its own factors inside a GTSAM graph
    without relying on Python wrapper identity (pybind11 wraps the same C++ factor anew once the
    user's reference is gone) and without keeping factors alive.
    """

    active: bool = False
    spec: Any = None


PROBE = _Probe()


def make_custom_factor(
    noise_model: Any,
    keys: Sequence[int],
    dims: Sequence[int],
    evaluate: Evaluate,
    *,
    name: str,
    spec: Any = None,
) -> Any:
    """Wrap ``evaluate`` as a ``gtsam.CustomFactor`` that always assigns correctly shaped blocks.

    Parameters
    ----------
    noise_model : gtsam.noiseModel.Base
        Noise model of the unwhitened error returned by ``evaluate``.
    keys : sequence of int
        GTSAM keys, in the order of the Jacobians ``evaluate`` returns.
    dims : sequence of int
        Tangent dimension of each key's variable (6 for ``Pose3``, 3 for a velocity, 6 for a bias).
    evaluate : callable
        ``evaluate(values, want_jacobians) -> (error (m,), [J (m, dims[i]) ...] or None)``.
    name : str
        Used in error messages.
    spec : object, optional
        A batch description (see :mod:`liebridge.factors.batch`) that lets
        :func:`liebridge.factors.optimize` evaluate this factor together with its peers.

    Returns
    -------
    gtsam.CustomFactor
    """
    keys = [int(k) for k in keys]
    dims = [int(d) for d in dims]
    if len(keys) != len(dims):
        raise ValueError(f"{name}: {len(keys)} keys but {len(dims)} dims")
    m = int(noise_model.dim())

    def callback(this: Any, values: Any, H: Any) -> FloatArray:
        if PROBE.active:
            PROBE.spec = spec
            if H is not None:
                for i, d in enumerate(dims):
                    H[i] = np.zeros((m, d))
            return np.zeros(m)
        want = H is not None
        try:
            err, jacs = evaluate(values, want)
            err = np.asarray(err, dtype=np.float64).reshape(-1)
            if err.shape != (m,) or not np.isfinite(err).all():
                raise FactorEvaluationError(f"error has shape {err.shape} (expected ({m},)) or NaN")
            if want:
                if jacs is None or len(jacs) != len(keys):
                    raise FactorEvaluationError(f"expected {len(keys)} Jacobian blocks")
                for i, (J, d) in enumerate(zip(jacs, dims, strict=True)):
                    J = np.asarray(J, dtype=np.float64)
                    if J.shape != (m, d) or not np.isfinite(J).all():
                        raise FactorEvaluationError(
                            f"Jacobian block {i} has shape {J.shape} (expected ({m}, {d})) or NaN"
                        )
                    H[i] = np.ascontiguousarray(J)
        except FactorEvaluationError as exc:
            raise FactorEvaluationError(f"{name} on keys {keys}: {exc}") from None
        except Exception as exc:  # any user/numerics error, made explicit
            raise FactorEvaluationError(
                f"{name} on keys {keys}: {type(exc).__name__}: {exc}"
            ) from exc
        return err

    return gtsam.CustomFactor(noise_model, keys, callback)
