"""The doctor's answer: a verdict, an explanation in plain words, and the measured evidence."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["Diagnosis"]

#: Verdicts that mean "nothing wrong found".
CLEAN_VERDICTS = ("correct", "ok")


def _plain(x: Any) -> Any:
    """``x`` with numpy scalars and arrays turned into JSON-ready Python objects."""
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return _plain(x.tolist())
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, float) and not np.isfinite(x):
        return None if np.isnan(x) else ("inf" if x > 0 else "-inf")
    return x


@dataclass(frozen=True)
class Diagnosis:
    """What the doctor found.

    Attributes
    ----------
    verdict : str
        One word. ``"correct"`` / ``"ok"``: nothing wrong found. Otherwise the kind of finding:
        ``"convention_mismatch"`` (a valid Jacobian of another convention than the solver's),
        ``"mistake"`` (a known mistake of the catalogue, named by ``cause``),
        ``"small_angle_only"`` (right near zero, wrong at large angles), ``"unexplained"``
        (nothing in the model reproduces it), and for trajectories ``"alarm"``.
    explanation : str
        The diagnosis in plain words, with the fix where there is one.
    evidence : dict
        The measurements behind it (errors per candidate, per angle, per check); JSON-ready.
    cause : str
        Short machine-readable name of the best explanation (``"right_vs_left"``,
        ``"skew_sign"``, ``"jr_inv_omitted"``, ...; ``""`` when clean).
    """

    verdict: str
    explanation: str
    evidence: dict[str, Any] = field(default_factory=dict)
    cause: str = ""

    @property
    def ok(self) -> bool:
        """Whether nothing wrong was found."""
        return self.verdict in CLEAN_VERDICTS

    def to_dict(self) -> dict[str, Any]:
        """``{"verdict", "cause", "explanation", "evidence"}`` as plain JSON types."""
        return {
            "verdict": self.verdict,
            "cause": self.cause,
            "explanation": self.explanation,
            "evidence": _plain(self.evidence),
        }

    def to_json(self, indent: int | None = 2) -> str:
        """:meth:`to_dict` as a JSON string."""
        return json.dumps(self.to_dict(), indent=indent, ensure_ascii=False)

    def __str__(self) -> str:
        return f"verdict: {self.verdict}\n{self.explanation}"
