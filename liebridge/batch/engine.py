"""Map one per-log function over many logs on an existing engine: serial, processes, Dask.

liebridge has no scheduler of its own. ``"processes"`` is the standard library's
:class:`concurrent.futures.ProcessPoolExecutor` (``spawn`` start method: no state inherited from
the parent, the same on every OS); ``"dask"`` is a :class:`distributed.Client` — on an existing
cluster (``scheduler`` an address or a ``Client``) or on a :class:`distributed.LocalCluster`
started for the batch and closed after it. Every engine calls the same function with the same
arguments, so the rows are identical whatever the engine; they come back in completion order,
tagged with their index.
"""

from __future__ import annotations

import contextlib
import logging
import os
import warnings
from collections.abc import Callable, Iterator, Sequence
from typing import Any

__all__ = [
    "CONNECT_TIMEOUT",
    "ENGINES",
    "WORKER_ENV",
    "close_quietly",
    "local_cluster",
    "map_jobs",
]

#: Engines by name.
ENGINES: tuple[str, ...] = ("serial", "processes", "dask")

#: Environment of the ``processes`` engine's workers where the caller's has not set it: one
#: BLAS/OpenMP thread per worker process (the workers are the parallelism; more threads per
#: worker oversubscribe the cores). The same values dask puts into its workers' environment.
WORKER_ENV: dict[str, str] = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
                              "OPENBLAS_NUM_THREADS": "1"}  # fmt: skip

#: Seconds a ``Client(address)`` waits for a scheduler before failing (dask's own default: 30).
CONNECT_TIMEOUT = 10.0


def _call(
    func: Callable[..., dict[str, Any]], index: int, job: dict[str, Any]
) -> tuple[int, dict[str, Any]]:
    """Run one job; whatever escapes the job function becomes an error row, never an exception."""
    try:
        return index, func(**job)
    except Exception as exc:
        return index, {**job, "status": "error", "error": f"{type(exc).__name__}: {exc}"}


def _lost(job: dict[str, Any], exc: BaseException) -> dict[str, Any]:
    """Build the row of a job whose worker died (a crash, or killed for memory)."""
    text = " ".join(str(exc).split()) or "worker lost"
    return {**job, "status": "error", "error": f"{type(exc).__name__}: {text}"}


def map_jobs(
    func: Callable[..., dict[str, Any]],
    jobs: Sequence[dict[str, Any]],
    *,
    engine: str = "serial",
    workers: int | None = None,
    scheduler: Any = None,
    connect_timeout: float = CONNECT_TIMEOUT,
) -> Iterator[tuple[int, dict[str, Any]]]:
    """Yield ``(index, row)`` for every job, ``row = func(**jobs[index])``, as they finish.

    Parameters
    ----------
    func : callable
        A module-level function (picklable by reference), e.g. :func:`liebridge.batch.evaluate`.
    jobs : sequence of dict
        Keyword arguments of each call (plain data: str, numbers, bool, None).
    engine : {"serial", "processes", "dask"}
        ``processes`` workers get one BLAS/OpenMP thread each (:data:`WORKER_ENV`, where the
        caller's environment does not set those variables), as dask's workers do.
    workers : int, optional
        Pool size for ``processes`` (default ``os.cpu_count()``) and the number of workers of
        the ``LocalCluster`` that ``dask`` starts when no ``scheduler`` is given (default 2,
        one thread each).
    scheduler : str or distributed.Client, optional
        ``dask`` only: an existing cluster's address (``tcp://host:8786``) or a connected
        client. Without it, a ``LocalCluster`` is started with dask's ``MALLOC_TRIM_THRESHOLD_``
        worker setting removed (``distributed.nanny.pre-spawn-environ``): it made this numpy
        work markedly slower.
    connect_timeout : float
        Seconds to wait for ``scheduler`` before a ``ConnectionError``.

    Raises
    ------
    ValueError
        An unknown engine, ``workers < 1``, or ``scheduler`` with an engine other than dask.
    ImportError
        ``dask`` without ``dask.distributed`` (``pip install ".[dask]"`` from the checkout).
    ConnectionError
        No scheduler answered at ``scheduler`` within ``connect_timeout``.
    """
    engine = engine.strip().lower() if isinstance(engine, str) else engine
    if engine not in ENGINES:
        raise ValueError(f"engine: expected one of {', '.join(ENGINES)}, got {engine!r}")
    if workers is not None and (isinstance(workers, bool) or int(workers) < 1):
        raise ValueError(f"workers: expected a positive integer, got {workers!r}")
    if scheduler is not None and engine != "dask":
        raise ValueError(f"scheduler: only the dask engine has one (engine is {engine!r})")
    if engine == "serial":
        for i, job in enumerate(jobs):
            yield _call(func, i, job)
    elif engine == "processes":
        yield from _processes(func, jobs, workers or os.cpu_count() or 1)
    else:
        yield from _dask(func, jobs, workers or 2, scheduler, connect_timeout)


def _processes(
    func: Callable[..., dict[str, Any]], jobs: Sequence[dict[str, Any]], workers: int
) -> Iterator[tuple[int, dict[str, Any]]]:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    if not jobs:
        return
    pool = ProcessPoolExecutor(
        max_workers=min(workers, len(jobs)), mp_context=multiprocessing.get_context("spawn")
    )
    try:
        # the workers are spawned by the submissions and take the environment of that moment
        with _environment(WORKER_ENV):
            futures = {pool.submit(_call, func, i, job): i for i, job in enumerate(jobs)}
        for fut in as_completed(futures):
            i = futures.pop(fut)
            try:
                yield fut.result()
            except Exception as exc:  # BrokenProcessPool: a worker died
                yield i, _lost(jobs[i], exc)
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


@contextlib.contextmanager
def _environment(defaults: dict[str, str]) -> Iterator[None]:
    """Set the variables of ``defaults`` that ``os.environ`` lacks; restore it afterwards."""
    added = [k for k in defaults if k not in os.environ]
    for k in added:
        os.environ[k] = defaults[k]
    try:
        yield
    finally:
        for k in added:
            os.environ.pop(k, None)


def _import_distributed() -> Any:
    try:
        import distributed
    except ImportError:
        raise ImportError(
            "the dask engine needs dask.distributed, an optional extra: "
            'pip install ".[dask]" (from the checkout)'
        ) from None
    return distributed


def local_cluster(workers: int = 2, *, trim_env: bool = False, **kwargs: Any) -> Any:
    """Start the ``distributed.LocalCluster`` the dask engine uses when no scheduler is given.

    ``workers`` processes of one thread each, no dashboard, and — unless ``trim_env`` — without
    the ``MALLOC_TRIM_THRESHOLD_=65536`` that dask puts into its workers' environment
    (``distributed.nanny.pre-spawn-environ``): with it, this numpy work (many mid-size
    temporary arrays) ran markedly slower (``docs/fleet.md``). Other keyword arguments go to
    ``LocalCluster``. The caller closes the cluster.
    """
    _import_distributed()
    import dask
    from distributed import LocalCluster

    opts: dict[str, Any] = {
        "n_workers": workers,
        "threads_per_worker": 1,
        "processes": True,
        "dashboard_address": None,
        "silence_logs": logging.ERROR,
        **kwargs,
    }
    env = {} if trim_env else {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}
    with dask.config.set(env), warnings.catch_warnings():
        # without a dashboard the scheduler still serves /health on 8787, or any free port
        warnings.filterwarnings("ignore", message="Port 8787 is already in use")
        return LocalCluster(**opts)


def close_quietly(*objects: Any) -> None:
    """Close dask clients and clusters without the INFO lines their shutdown logs on stderr."""
    loggers = [logging.getLogger("distributed")] + [
        logging.getLogger(n)
        for n in list(logging.root.manager.loggerDict)
        if n.startswith("distributed.")
    ]
    saved: list[tuple[Any, int]] = []
    for lg in loggers:
        saved.append((lg, lg.level))
        saved += [(h, h.level) for h in lg.handlers]
    for obj, _ in saved:
        obj.setLevel(logging.ERROR)
    try:
        for obj in objects:
            if obj is not None:
                obj.close()
    finally:
        for obj, level in saved:
            obj.setLevel(level)


def _connect(scheduler: Any, timeout: float) -> Any:
    from distributed import Client

    if isinstance(scheduler, Client):
        return scheduler
    if not isinstance(scheduler, str) or not scheduler.strip():
        raise ValueError(
            f"scheduler: expected an address such as tcp://host:8786, got {scheduler!r}"
        )
    try:
        return Client(scheduler, timeout=timeout)
    except (OSError, TimeoutError) as exc:
        raise ConnectionError(
            f"scheduler: no Dask scheduler answered at {scheduler} within {timeout:g} s "
            f"({type(exc).__name__})"
        ) from None


def _dask(
    func: Callable[..., dict[str, Any]],
    jobs: Sequence[dict[str, Any]],
    workers: int,
    scheduler: Any,
    connect_timeout: float,
) -> Iterator[tuple[int, dict[str, Any]]]:
    _import_distributed()
    from distributed import Client, as_completed

    own_cluster = None
    own_client = None
    if scheduler is None:
        own_cluster = local_cluster(workers)
        client = own_client = Client(own_cluster)
    else:
        client = _connect(scheduler, connect_timeout)
        if client is not scheduler:
            own_client = client
    futures: list[Any] = []
    try:
        if not jobs:
            return
        futures = client.map(_call, [func] * len(jobs), range(len(jobs)), list(jobs), pure=False)
        where = {f.key: i for i, f in enumerate(futures)}
        for fut in as_completed(futures):
            i = where[fut.key]
            try:
                yield fut.result()
            except Exception as exc:  # KilledWorker and the like
                yield i, _lost(jobs[i], exc)
            fut.release()
    finally:
        pending = [f for f in futures if not f.done()]
        if pending and own_client is None:  # interrupted on a cluster that is not ours
            client.cancel(pending)
        close_quietly(own_client, own_cluster)
