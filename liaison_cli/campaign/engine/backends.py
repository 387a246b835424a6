"""The one fan-out of liaison: run `fn(shared[key], tasks)` for every batch and yield results as they finish
(map_batches). Every long command goes through it: `run`, `compare`, `table3`, the 003 / 004 studies and the
check runs of `errors` (studies.error_budget) through runner.run_tasks_in_order (its ordered layer); `sweep`,
`tune` and `warm-up` directly.

- `joblib` (default): local processes (joblib's loky pool); `jobs=1` runs in this process. With `fork=True`
  (the sweep) the workers are forked from this process at the first batch instead (where the platform forks):
  they start in milliseconds with everything this process has loaded, the compiled kernels included.
- `dask`: a dask.distributed cluster (`scheduler="tcp://host:8786"`), or a LocalCluster of `jobs`
  workers when no scheduler is given. Shared objects (a scenario's truth arrays) are scattered once.

Results come in completion order, or with `ordered=True` in the order of the batches (a bounded reorder
buffer); callers key results by task id, so numbers never depend on the order.
"""

import itertools
import logging
import os
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from liaison_cli.errors import LiaisonError
from liaison_cli.interrupts import shield_pool_workers, sigint_held

BACKENDS = ("joblib", "dask")
# Batches submitted and not yet consumed, per worker: enough that no worker waits for the next batch while the
# caller handles a result, few enough that memory stays bounded whatever the number of runs.
WINDOW_PER_WORKER = 4


@dataclass(frozen=True)
class Backend:
    """Where batches run: `name` joblib (local processes) or dask (the cluster at `scheduler`, or a LocalCluster
    when it is None); `connect_timeout_s` bounds the wait for that scheduler."""

    name: str = "joblib"
    scheduler: str | None = None
    connect_timeout_s: float = 20.0


LOCAL = Backend()
# The thread-pool sizes a worker process reads at start (OpenMP, the BLAS libraries, numba, numexpr).
THREAD_POOL_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS",
                         "VECLIB_MAXIMUM_THREADS", "NUMBA_NUM_THREADS", "NUMEXPR_NUM_THREADS")


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


def check_scheduler_address(scheduler: str) -> None:
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

    check_scheduler_address(scheduler)
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
        if not stage:  # it failed before a connection was made: nothing answered (issue 47)
            raise BackendUnavailableError(f"{where}: cannot connect ({type(exc).__name__}: {exc})") from None
        raise BackendUnavailableError(f"{where}: answered, but not as a dask scheduler "
                                      f"({type(exc).__name__})") from None
    if not (isinstance(reply, dict) and reply.get("type") == "Scheduler"):
        raise BackendUnavailableError(f"{where}: answered, but not as a dask scheduler")


def local_workers(jobs: int) -> int:
    """`jobs`, capped at this machine's cores: more processes cannot run at once and each holds its own copy of
    the compiled core (issue 47: --jobs 16 on 2 cores started 17 processes, 3.4 GB). Said once per value, as
    a note; the numbers never depend on it."""
    cores = os.cpu_count() or 1
    if jobs <= cores:
        return jobs
    if jobs not in _CAPPED:
        _CAPPED.add(jobs)
        logging.getLogger("liaison").warning(f"--jobs {jobs} on {cores} cores: {cores} worker processes (more "
                                             "cannot run at once; the numbers do not depend on it)")
    return cores


_CAPPED: set = set()


def map_batches(fn: Callable, shared: dict, batches: Iterable, where: Backend = LOCAL, jobs: int = 2,
                window: int | None = None, ordered: bool = False, fork: bool = False) -> Iterator:
    """batches: (key, tasks) pairs, read lazily; yields fn(shared[key], tasks) as they finish, or, with
    `ordered`, in the order of `batches`. `shared[key]` is looked up as its batch is submitted (a mapping may
    prepare it then); `fork`: local workers forked from this process (see the module docstring).

    At most `window` batches (default: WINDOW_PER_WORKER per worker) are submitted and not yet yielded: in
    order, a finished batch waiting for an earlier one counts too, so what is held here, in the pipes and in
    the workers does not grow with the number of batches. A generator left early (Ctrl-C, an error in the
    caller) stops the workers and drops what is queued."""
    check_backend(where.name, where.scheduler)
    queued = iter(batches)
    first = next(queued, None)
    if first is None:  # nothing to do: no pool, no cluster
        return iter(())
    batches = itertools.chain([first], queued)
    if where.name != "dask" or not where.scheduler:  # this machine's processes: no more than its cores
        jobs = local_workers(jobs)
    if where.name == "dask":
        return _dask(fn, shared, batches, jobs, where, window, ordered)
    if jobs == 1:
        return (fn(shared[key], tasks) for key, tasks in batches)
    if fork and can_fork():
        return _forked_processes(fn, shared, batches, jobs, window or WINDOW_PER_WORKER * jobs, ordered)
    return _local_processes(fn, shared, batches, jobs, window or WINDOW_PER_WORKER * jobs, ordered)


def _windowed(submit: Callable, wait_first: Callable, batches: Iterator, window: int, in_flight_limit: int,
              ordered: bool) -> Iterator:
    """Yield (future, last) for the future of `submit(key, tasks)` of every batch once done (in completion or
    batch order), keeping at most `window` submitted and not yet yielded, and at most `in_flight_limit` not yet
    done. `last`: no batch is left after this one (known when the batches ran out before it was yielded: the
    next one is read as the last outstanding one is yielded, when the window has room for it)."""
    queued = enumerate(batches)
    outstanding: dict = {}  # batch index -> future, submitted and not yet yielded
    exhausted = False
    while True:
        in_flight = sum(not future.done() for future in outstanding.values())
        while not exhausted and len(outstanding) < window and in_flight < in_flight_limit:
            item = next(queued, None)
            exhausted = item is None
            if not exhausted:
                index, (key, tasks) = item
                outstanding[index] = submit(key, tasks)
                in_flight += 1
        if not outstanding:
            return
        ready = _ready(outstanding, ordered)
        if not ready:
            wait_first([future for future in outstanding.values() if not future.done()])
        for index in ready:
            future = outstanding.pop(index)
            if not outstanding and not exhausted and window > 1:
                item = next(queued, None)
                exhausted = item is None
                if not exhausted:
                    outstanding[item[0]] = submit(*item[1])
            yield future, exhausted and not outstanding


def _ready(outstanding: dict, ordered: bool) -> list:
    """The batch indexes that may be yielded now: every finished one, or in order, the finished run of them
    from the oldest on."""
    if not ordered:
        return [index for index, future in outstanding.items() if future.done()]
    ready, index = [], min(outstanding)
    while index in outstanding and outstanding[index].done():
        ready.append(index)
        index += 1
    return ready


def _worker_environment(jobs: int) -> dict:
    """What joblib gives its workers: thread pools (BLAS, OpenMP, numba) sized to the cores per worker, unless
    this process's environment already sets them, so `jobs` workers do not oversubscribe the machine."""
    from joblib import cpu_count

    threads = max(cpu_count() // jobs, 1)
    return {var: str(os.environ.get(var, threads)) for var in THREAD_POOL_VARIABLES}


def _executor(jobs: int):
    """loky's reusable executor of `jobs` workers: the same one for every call with the same `jobs`."""
    from joblib.externals.loky import get_reusable_executor

    shield_pool_workers()
    return get_reusable_executor(max_workers=jobs, env=_worker_environment(jobs))


def start_workers(where: Backend, jobs: int, module: str) -> None:
    """Start the local pool now, each worker importing `module` (the one of the function its batches will call),
    and return at once: the workers' start (a process spawn and about a second of imports each) then overlaps
    what the caller does before its first batch (a sweep's truth propagation and warm-up) instead of following
    it. The later fan-out finds the same pool. joblib with jobs > 1 only: a dask cluster starts with its fan-out,
    and jobs=1 runs in this process."""
    if where.name != "joblib" or jobs == 1:
        return
    import importlib

    executor = _executor(jobs)
    for _ in range(jobs):  # one each (loky gives a task to an idle worker; the first is busy importing)
        executor.submit(importlib.import_module, module)


def _local_processes(fn, shared, batches, jobs, window, ordered):
    """joblib's process pool (loky's reusable executor: started once per process, kept between calls)."""
    from concurrent.futures import FIRST_COMPLETED, wait

    executor = _executor(jobs)
    # Not more undone than loky's call queue holds (2 per worker + 1), as joblib's pre_dispatch: a work item
    # still waiting outside that queue when the pool is killed trips loky's manager thread (a KeyError).
    futures = _windowed(lambda key, tasks: executor.submit(fn, shared[key], tasks),
                        lambda running: wait(running, return_when=FIRST_COMPLETED), batches, window, 2 * jobs, ordered)
    # On an abort, killing the pool fails what is queued (cancelling it first trips loky's manager thread), as
    # joblib aborts: the workers are gone on return.
    yield from _results_or_abort(futures, lambda: executor.shutdown(wait=True, kill_workers=True))


def _results_or_abort(futures, abort):
    """Each finished future's result in turn (futures: _windowed's (future, key) pairs); `abort()` when the
    fan-out ends before its last result (an error, a Ctrl-C, a consumer that stops reading)."""
    finished = False
    try:
        for future, _ in futures:
            yield future.result()
        finished = True
    finally:
        if not finished:
            abort()


def can_fork() -> bool:
    """Worker processes can be forked here (Linux; not macOS, where forking a process that has loaded system
    frameworks is unsafe, nor Windows)."""
    import multiprocessing
    import sys

    return sys.platform.startswith("linux") and "fork" in multiprocessing.get_all_start_methods()


def _forked_processes(fn, shared, batches, jobs, window, ordered):
    """`jobs` workers forked from this process at the first batch (concurrent.futures' pool, fork context): no
    interpreter start, no imports, and the compiled kernels this process has loaded are there already (a
    spawned worker pays about 1.3 s of CPU for them). Forked with SIGINT blocked (as loky's workers start,
    `shield_pool_workers`); each worker then ignores it and keeps the BLAS threads a spawned one would. A worker
    that dies fails the fan-out (BrokenProcessPool) instead of hanging it. A new pool per call: forking costs
    milliseconds.

    The shared values go through files (_spool), not the pool's pipe: a value of a few hundred kB (a problem
    and its truth) fills the pipe, and a Ctrl-C that terminates the workers then would leave the pool's feeder
    thread blocked in its write for ever (and the command with it). Messages stay a few hundred bytes."""
    import multiprocessing
    import tempfile
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    blas_threads = int(_worker_environment(jobs)["OPENBLAS_NUM_THREADS"])
    executor = ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("fork"),
                                   initializer=_forked_worker_start, initargs=(blas_threads,))
    folder, spooled = tempfile.TemporaryDirectory(prefix="liaison-fan-out-"), {}

    def submit(key, tasks):
        if key not in spooled:  # prepared here, maybe now (see map_batches), and written once
            spooled[key] = _spool(shared[key], folder.name, len(spooled))
        with sigint_held():  # the first submit forks the workers: they inherit the mask
            return executor.submit(_run_spooled, fn, spooled[key], tasks)

    futures = _windowed(submit, lambda running: wait(running, return_when=FIRST_COMPLETED), batches, window,
                        window, ordered)
    try:
        yield from _results_or_abort(futures, lambda: _kill_forked(executor))
    finally:
        executor.shutdown(wait=True)
        folder.cleanup()


def _spool(value, folder: str, index: int) -> str:
    import pickle

    path = os.path.join(folder, f"{index}.pickle")
    with open(path, "wb") as handle:
        pickle.dump(value, handle, protocol=pickle.HIGHEST_PROTOCOL)
    return path


_SPOOLED: dict = {}  # in a forked worker: the last shared value read (path -> value); batches come key by key


def _run_spooled(fn, path: str, tasks):
    """Worker side of _forked_processes: fn(the value spooled at `path`, tasks)."""
    import pickle

    if path not in _SPOOLED:
        _SPOOLED.clear()
        with open(path, "rb") as handle:
            _SPOOLED[path] = pickle.load(handle)
    return fn(_SPOOLED[path], tasks)


def _kill_forked(executor) -> None:
    """Stop a forked pool at once: the workers are terminated and what is queued is dropped (Python 3.14 has
    terminate_workers; before, the processes are taken from the pool's own table, which shutdown empties)."""
    terminate = getattr(executor, "terminate_workers", None)
    if terminate is not None:
        terminate()
        return
    processes = list((getattr(executor, "_processes", None) or {}).values())
    for process in processes:
        process.terminate()
    executor.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.join()


def _forked_worker_start(blas_threads: int) -> None:
    """A forked worker's first step: SIGINT ignored (the parent stops the pool), and the BLAS thread pool a
    spawned worker gets from _worker_environment (the parent's, inherited, would oversubscribe the cores)."""
    import ctypes

    from liaison_cli.interrupts import ignore_in_worker_process

    ignore_in_worker_process()
    with open("/proc/self/maps") as maps:
        libraries = {line.split()[-1] for line in maps if "openblas" in os.path.basename(line.split()[-1]).lower()}
    for path in sorted(libraries):
        library = ctypes.CDLL(path)
        for name in ("openblas_set_num_threads", "scipy_openblas_set_num_threads64_",
                     "scipy_openblas_set_num_threads"):
            setter = getattr(library, name, None)
            if setter is not None:
                setter(blas_threads)
                break


def _dask_client(jobs: int, where: Backend):
    """A client of the scheduler at `where`, or of a new LocalCluster (returned too, to be closed with it).

    The LocalCluster is started with SIGINT blocked in this thread: its event-loop thread, and through it the
    worker processes it spawns, inherit the mask, so a Ctrl-C reaches this process only (as joblib's shielded
    workers). Before, each worker took the terminal's SIGINT too and died mid-task: the sweep's futures were
    cancelled and the command ended in a FuturesCancelledError traceback, exit 1 (issue 35, fault 8). A Ctrl-C
    during the start is delivered when the block ends; the cluster just started is then closed."""
    from multiprocessing import resource_tracker

    from distributed import Client, LocalCluster

    opened = None
    try:
        if where.scheduler:
            probe_scheduler(where.scheduler, where.connect_timeout_s)
            return Client(where.scheduler, timeout=f"{where.connect_timeout_s}s"), None
        # multiprocessing's resource tracker, started by the first worker's spawn, unblocks SIGINT in the thread
        # that starts it (the cluster's event loop): started here first, outside the block, it is not started there.
        resource_tracker.ensure_running()
        # silence_logs: the workers' and scheduler's log lines go to this terminal; after a stop they report the
        # cancellation (warnings, heartbeat tracebacks) below the command's one line. Task errors come back
        # through the futures, not the logs.
        with sigint_held():
            cluster = LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True, dashboard_address=None,
                                   silence_logs=logging.CRITICAL)
            opened = Client(cluster), cluster
        return opened
    except (OSError, TimeoutError) as exc:
        raise BackendUnavailableError(f"--scheduler {where.scheduler!r}: cannot connect "
                                      f"({type(exc).__name__}: {exc})") from None
    except BaseException:
        if opened is not None:
            _close(*opened)
        raise


_SESSIONS: dict = {}  # (backend, jobs) -> (client, cluster) of an open `session` block, once first used


@contextmanager
def session(where: Backend, jobs: int):
    """One dask client (and its LocalCluster) for every fan-out inside the block (a study's cells), started at
    the first, instead of one per fan-out: a LocalCluster takes seconds to start. joblib needs none: its pool
    is kept between calls."""
    key = (where, jobs)
    if where.name != "dask" or key in _SESSIONS:
        yield
        return
    _SESSIONS[key] = None
    try:
        yield
    finally:
        opened = _SESSIONS.pop(key)
        if opened is not None:
            _close(*opened)


def _close(client, cluster) -> None:
    client.close()
    if cluster is not None:
        cluster.close()


def _dask(fn, shared, batches, jobs, where, window, ordered):
    from distributed import wait

    in_session = (where, jobs)
    owned = in_session not in _SESSIONS
    if owned:
        opened = _dask_client(jobs, where)
    else:
        if _SESSIONS[in_session] is None:
            _SESSIONS[in_session] = _dask_client(jobs, where)
        opened = _SESSIONS[in_session]
    client = opened[0]

    def generate():
        to_close = [opened] if owned else []  # this fan-out's own client and cluster (not a session's): closed once
        try:
            # A cluster reached by address may have more workers than --jobs: keep every one of them busy.
            limit = window or WINDOW_PER_WORKER * max(jobs, sum(client.nthreads().values()))
            scattered = {key: client.scatter(value, broadcast=False) for key, value in shared.items()}
            futures = _windowed(lambda key, tasks: client.submit(fn, scattered[key], tasks, pure=False),
                                lambda running: wait(running, return_when="FIRST_COMPLETED"), batches, limit, limit,
                                ordered)
            for future, last in futures:
                result = future.result()
                future.release()
                if last and to_close:  # closing takes a second: done before the caller's last check for a Ctrl-C
                    _close(*to_close.pop())  # (a sweep's, between batches), not after it, where one was lost
                yield result
        finally:
            if to_close:
                _close(*to_close.pop())

    return generate()
