"""Fan-out backends: run `fn(shared[key], tasks)` for every batch and yield results as they finish.

- `joblib` (default): local processes; `jobs=1` runs in this process.
- `dask`: a dask.distributed cluster (`scheduler="tcp://host:8786"`), or a LocalCluster of `jobs`
  workers when no scheduler is given. Shared objects (a scenario's truth arrays) are scattered once.

Order of completion is not defined; callers key results by task id, so numbers never depend on it.
"""

from collections.abc import Callable, Iterator

from liaison_cli.errors import LiaisonError
from liaison_cli.interrupts import shield_pool_workers

BACKENDS = ("joblib", "dask")


class BackendError(LiaisonError):
    """The requested backend is unknown or not installed (usage: exit 2)."""


class BackendUnavailableError(LiaisonError):
    """The dask scheduler cannot be reached (environment, not input: exit 3)."""

    exit_code = 3


def check_backend(backend: str, scheduler: str | None) -> None:
    if backend not in BACKENDS:
        raise BackendError(f"--backend {backend!r}: unknown; allowed: {', '.join(BACKENDS)}")
    if backend == "joblib" and scheduler:
        raise BackendError("--scheduler is only used with --backend dask")
    if backend == "dask":
        from importlib.util import find_spec

        if find_spec("distributed") is None:
            raise BackendError("--backend dask needs dask.distributed: pip install 'liaison[dask]'")


def map_batches(fn: Callable, shared: dict, batches: list, backend: str = "joblib", jobs: int = 2,
                scheduler: str | None = None, connect_timeout_s: float = 20.0) -> Iterator:
    """batches: list of (key, tasks); yields fn(shared[key], tasks) in completion order."""
    check_backend(backend, scheduler)
    if not batches:
        return iter(())
    if backend == "dask":
        return _dask(fn, shared, batches, jobs, scheduler, connect_timeout_s)
    if jobs == 1:
        return (fn(shared[key], tasks) for key, tasks in batches)
    from joblib import Parallel, delayed

    shield_pool_workers()
    parallel = Parallel(n_jobs=jobs, return_as="generator_unordered")
    return parallel(delayed(fn)(shared[key], tasks) for key, tasks in batches)


def _dask(fn, shared, batches, jobs, scheduler, connect_timeout_s):
    from distributed import Client, LocalCluster, as_completed

    cluster = None
    try:
        if scheduler:
            client = Client(scheduler, timeout=f"{connect_timeout_s}s")
        else:
            cluster = LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True, dashboard_address=None)
            client = Client(cluster)
    except (OSError, TimeoutError) as exc:
        raise BackendUnavailableError(f"--scheduler {scheduler!r}: cannot connect ({type(exc).__name__}: {exc})") from None

    def generate():
        try:
            scattered = {key: client.scatter(value, broadcast=False) for key, value in shared.items()}
            futures = [client.submit(fn, scattered[key], tasks, pure=False) for key, tasks in batches]
            for future in as_completed(futures):
                yield future.result()
                future.release()
        finally:
            client.close()
            if cluster is not None:
                cluster.close()

    return generate()
