"""Glue between analytic Python residuals and ``gtsam.CustomFactor``.

GTSAM's ``CustomFactor`` callback is ``f(this, values, H)``: ``H`` is ``None`` for error-only
calls, otherwise a list whose every entry must be *assigned* (an unset block crashes the process,
a wrongly shaped one is accepted silently — see ``docs/library-facts.md``). This module
is the only place that talks to that protocol: residuals are written as
``evaluate(values, want_jacobians) -> (error, [J_error_key, ...] | None)`` with every Jacobian
taken with respect to **GTSAM's own tangent of that variable** (``Pose3``: right, (ω, v);
vectors and ``imuBias.ConstantBias``: additive, bias order (acc, gyro)); the glue checks shapes and
finiteness and turns any exception into one naming the factor and its keys.
"""

from __future__ import annotations

import itertools
import weakref
from collections.abc import Callable, Sequence
from typing import Any

import gtsam
import numpy as np

from .. import _validate as validate
from .._validate import FloatArray

Evaluate = Callable[[Any, bool], tuple[FloatArray, "list[FloatArray] | None"]]


class FactorEvaluationError(RuntimeError):
    """A liebridge factor's residual or Jacobian could not be evaluated."""


# --------------------------------------------------------------------------- the spec registry
# :func:`liebridge.gtsam.optimize` must recognise liebridge's factors inside a GTSAM graph. Python
# wrapper identity cannot do it (pybind11 wraps the same C++ factor anew once the user's reference
# is gone), so each factor built with a ``spec`` gets a registry number, and its callback answers
# an *identification query*: evaluated on :func:`query_values`, which holds only
# :data:`QUERY_KEY`, it returns an error vector whose first entry is that number. The registry
# holds identities weakly; the callback's closure holds its identity, so an entry lives exactly
# as long as the C++ factor. No flag is flipped anywhere: the query is an ordinary evaluation.

#: Reserved key of the identification query (the largest 64-bit key).
QUERY_KEY = 2**64 - 1
_NUMBERS = itertools.count(1)


class _Identity:
    """A factor's registry number, its spec and the query's answer (held by its callback)."""

    __slots__ = ("__weakref__", "answer", "spec")

    def __init__(self, spec: Any, m: int) -> None:
        number = next(_NUMBERS) if spec is not None else 0
        self.spec = spec
        self.answer = np.zeros(m)
        self.answer[0] = number
        if spec is not None:
            _REGISTRY[number] = self


_REGISTRY: weakref.WeakValueDictionary[int, _Identity] = weakref.WeakValueDictionary()


def query_values() -> Any:
    """Build the ``Values`` that make a liebridge callback identify itself (:func:`identify`)."""
    q = gtsam.Values()
    q.insert(QUERY_KEY, np.zeros(1))
    return q


def identify(factor: Any, query: Any) -> Any:
    """Return the batch spec of a liebridge ``CustomFactor``, or None for any other factor.

    Parameters
    ----------
    factor : gtsam.NonlinearFactor
    query : gtsam.Values
        From :func:`query_values` (built once per graph by the caller).
    """
    if not isinstance(factor, gtsam.CustomFactor):
        return None
    try:
        answer = np.asarray(factor.unwhitenedError(query), dtype=np.float64)
    except Exception:  # a foreign factor reads its own keys and fails: not ours
        return None
    if answer.size == 0 or not float(answer[0]).is_integer():
        return None
    ident = _REGISTRY.get(int(answer[0]))
    return None if ident is None else ident.spec


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
        A batch description (see :mod:`liebridge.gtsam.batch`) that lets
        :func:`liebridge.gtsam.optimize` evaluate this factor together with its peers.

    Returns
    -------
    gtsam.CustomFactor
    """
    keys = [validate.key(k, f"{name}: key {n}") for n, k in enumerate(keys)]
    if len(set(keys)) != len(keys):
        dup = next(k for k in keys if keys.count(k) > 1)
        raise ValueError(f"{name}: key {dup} appears twice in keys {keys}")
    dims = [int(d) for d in dims]
    if len(keys) != len(dims):
        raise ValueError(f"{name}: {len(keys)} keys but {len(dims)} dims")
    m = int(noise_model.dim())
    ident = _Identity(spec, m)  # the closure holds it: the registry entry lives with the factor

    def callback(this: Any, values: Any, H: Any) -> FloatArray:
        if H is None and values.exists(QUERY_KEY):  # identification query (see identify)
            return ident.answer.copy()
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
