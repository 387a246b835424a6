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


def _check_address(scheduler: str) -> None:
    """A malformed address is a usage error (exit 2), found before any connection is tried."""
    from distributed.comm import registry
    from distributed.comm.addressing import get_address_host_port, parse_address

    try:
        scheme, _ = parse_address(scheduler)
        registry.get_backend(scheme)  # an unknown scheme (http://...) is a ValueError here
        port = get_address_host_port(scheduler)[1] if scheme in ("tcp", "tls") else 1
    except (ValueError, TypeError) as exc:
        raise BackendError(f"--scheduler {scheduler!r}: not a scheduler address ({exc}); allowed: "
                           "[tcp|tls]://HOST:PORT, e.g. tcp://127.0.0.1:8786") from None
    if not 0 < port < 65536:
        raise BackendError(f"--scheduler {scheduler!r}: port {port} is out of range; allowed: 1 to 65535")


async def _identity(scheduler: str, timeout_s: float, stage: list):
    """The scheduler's reply to an identity request. distributed's own handshake read has no timeout (a
    server that accepts and says nothing holds it forever), so the caller bounds the whole exchange;
    `stage` records how far it got."""
    from distributed.comm import connect

    comm = await connect(scheduler, timeout=timeout_s)
    stage.append("connected")
    try:
        await comm.write({"op": "identity", "reply": True})
        return await comm.read()
    finally:
        comm.abort()


def probe_scheduler(scheduler: str, timeout_s: float) -> None:
    """Connect, handshake and ask the scheduler who it is, all within timeout_s; else one line, exit 3."""
    import asyncio

    _check_address(scheduler)
    where, stage = f"--scheduler {scheduler!r}", []
    try:
        reply = asyncio.run(asyncio.wait_for(_identity(scheduler, timeout_s, stage), timeout_s))
    except TimeoutError:  # asyncio.TimeoutError is TimeoutError (Python >= 3.11)
        what = "connected, but got no reply" if stage else "no dask scheduler answered"
        raise BackendUnavailableError(f"{where}: cannot connect: {what} within {timeout_s:g} s "
                                      "(--scheduler-timeout)") from None
    except OSError as exc:  # refused, reset, unreachable; distributed's CommClosedError is an OSError
        raise BackendUnavailableError(f"{where}: cannot connect ({type(exc).__name__}: {exc})") from None
    except Exception as exc:  # noqa: BLE001 - bytes that are not dask's protocol fail in many ways
        raise BackendUnavailableError(f"{where}: answered, but not as a dask scheduler "
                                      f"({type(exc).__name__})") from None
    if not (isinstance(reply, dict) and reply.get("type") == "Scheduler"):
        raise BackendUnavailableError(f"{where}: answered, but not as a dask scheduler")


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
            probe_scheduler(scheduler, connect_timeout_s)
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
