"""Fleet scale: one picklable call per log, mapped over thousands of logs by an existing engine.

* :func:`evaluate` — ``liebridge traj``'s APE / RPE / NEES of one (REF, EST) pair as one flat,
  JSON-ready row (the error text in the row instead of an exception);
* :func:`convert` — one log (file or bag topic) to a TUM / KITTI / EuRoC file, one row;
* :func:`run` — map either over many jobs with ``engine="serial" | "processes" | "dask"``
  (:func:`map_jobs`), journal each finished row so a rerun computes only what is missing, and
  write the table (CSV, Parquet with pyarrow) in job order, identical whatever the engine;
* :func:`read_log` — the one adapter between the readers (:mod:`liebridge.io`,
  :mod:`liebridge.ros`) and the jobs.

The command line is ``liebridge batch evaluate|convert``; see ``docs/fleet.md``. The dask
engine needs the extra ``dask`` (``pip install ".[dask]" (from the checkout)``).
"""

from .engine import CONNECT_TIMEOUT, ENGINES, local_cluster, map_jobs
from .jobs import CONVERT_OPTIONS, EVALUATE_OPTIONS, METRICS, STAT_KEYS, convert, evaluate
from .read import Log, read_log, split_topic
from .summary import SUMMARY_COLUMNS, plot_summary, summary_lines, worst
from .table import BatchResult, job_key, read_journal, run, write_table

__all__ = [
    "CONNECT_TIMEOUT",
    "CONVERT_OPTIONS",
    "ENGINES",
    "EVALUATE_OPTIONS",
    "METRICS",
    "STAT_KEYS",
    "SUMMARY_COLUMNS",
    "BatchResult",
    "Log",
    "convert",
    "evaluate",
    "job_key",
    "local_cluster",
    "map_jobs",
    "plot_summary",
    "read_journal",
    "read_log",
    "run",
    "split_topic",
    "summary_lines",
    "worst",
    "write_table",
]
