"""A batch at a glance: per-metric distributions, worst runs first, and the failed logs."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from typing import Any

__all__ = ["SUMMARY_COLUMNS", "plot_summary", "summary_lines", "worst"]

#: The column each metric is ranked by (higher is worse).
SUMMARY_COLUMNS: dict[str, str] = {
    "ape": "ape_rmse",
    "rpe": "rpe_rmse",
    "nees": "nees_anees",
}


def _num(v: Any) -> float | None:
    if isinstance(v, bool) or v is None or v == "":
        return None
    try:
        x = float(v)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def _label(row: dict[str, Any]) -> str:
    return str(row.get("est") or row.get("src") or row.get("job", "?"))


def worst(rows: Sequence[dict[str, Any]], column: str, k: int = 5) -> list[tuple[float, str]]:
    """Return the ``k`` largest values of ``column`` with their logs, largest first."""
    vals = [(x, _label(r)) for r in rows if (x := _num(r.get(column))) is not None]
    return sorted(vals, key=lambda v: -v[0])[:k]


def _quantile(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    pos = q * (len(xs) - 1)
    lo = math.floor(pos)
    hi = min(lo + 1, len(xs) - 1)
    return xs[lo] + (xs[hi] - xs[lo]) * (pos - lo)


def summary_lines(rows: Sequence[dict[str, Any]], k: int = 5, max_errors: int = 20) -> list[str]:
    """Text summary: counts, each metric's median / 90 % / max and its worst runs, the errors."""
    failed = [r for r in rows if r.get("status") == "error"]
    out = [f"{len(rows)} logs: {len(rows) - len(failed)} ok, {len(failed)} failed"]
    for metric, col in SUMMARY_COLUMNS.items():
        xs = [x for r in rows if (x := _num(r.get(col))) is not None]
        if not xs:
            continue
        out.append(
            f"{col}: median {_quantile(xs, 0.5):.4g}, 90% {_quantile(xs, 0.9):.4g}, "
            f"max {max(xs):.4g} ({len(xs)} logs)"
        )
        for x, name in worst(rows, col, k):
            out.append(f"  {x:12.4g}  {name}")
        if metric == "nees":
            skipped = sum(1 for r in rows if "nees skipped" in str(r.get("note", "")))
            if skipped:
                out.append(f"  nees skipped for {skipped} logs without covariances")
    for r in failed[:max_errors]:
        out.append(f"FAILED {_label(r)}: {r.get('error', '')}")
    if len(failed) > max_errors:
        out.append(f"... and {len(failed) - max_errors} more failed logs (see the table)")
    return out


def plot_summary(
    rows: Sequence[dict[str, Any]], path: str | os.PathLike[str], title: str = "", k: int = 5
) -> bool:
    """Histogram of each metric's ranking column with the worst ``k`` runs listed beside it.

    Returns False (and writes nothing) when no row has a number to plot. Needs matplotlib.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [
        (col, xs)
        for col in SUMMARY_COLUMNS.values()
        if (xs := [x for r in rows if (x := _num(r.get(col))) is not None])
    ]
    if not panels:
        return False
    fig, axes = plt.subplots(1, len(panels), figsize=(5.2 * len(panels), 4.2), squeeze=False)
    for ax, (col, xs) in zip(axes[0], panels, strict=True):
        ax.hist(xs, bins=min(40, max(5, len(xs) // 5)), color="C0", alpha=0.8)
        ax.set_xlabel(col)
        ax.set_ylabel("logs")
        ax.grid(True, alpha=0.3)
        text = "worst:\n" + "\n".join(
            f"{x:.3g} {os.path.basename(name)[:28]}" for x, name in worst(rows, col, k)
        )
        ax.text(0.98, 0.97, text, transform=ax.transAxes, ha="right", va="top", fontsize=7,
                family="monospace", bbox={"facecolor": "white", "alpha": 0.8, "lw": 0})  # fmt: skip
        for x, _ in worst(rows, col, k):
            ax.axvline(x, color="C3", lw=0.8, alpha=0.7)
    failed = sum(1 for r in rows if r.get("status") == "error")
    fig.suptitle(f"{title} {len(rows)} logs, {failed} failed".strip(), fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return True
