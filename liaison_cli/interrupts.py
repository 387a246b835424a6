"""Ctrl-C means stop, everywhere: one SIGINT handler for the CLI process that remembers the request and then
raises KeyboardInterrupt as Python's own handler does.

Why the memory: a KeyboardInterrupt raised while numba-compiled code runs comes back as
`SystemError: ... returned a result with an exception set`, an ordinary Exception that a worker (which
never raises) would record as a failed run, and the campaign would go on and report "ok". A worker finds the
request (`caused_by_interrupt`: the flag, or a KeyboardInterrupt in the exception's chain) and re-raises;
the campaign runner and the result swap (storage.staged_output) ask `requested()` too, so an interrupt
that compiled code swallowed whole still stops the command before a result is swapped in.

SIGTERM is handled as SIGINT (`install`). A pool worker ends itself when its parent is gone (`_watch_parent`:
a SIGKILL of the CLI reaches no handler).

Pool worker processes receive the terminal's SIGINT too; they must leave the stop to the main process,
which cancels the pool, so that no worker prints a traceback. `shield_pool_workers` makes joblib's (loky's)
workers start with SIGINT blocked (a blocked signal stays blocked across fork and exec: a Ctrl-C reaching a
starting worker waits, unhandled), and `ignore_in_worker_process`, the first thing a worker's task does, turns
that into ignored (dropping what waited). Blocked, not ignored, in the launching thread: a SIGINT ignored there
would be dropped for the whole process, and a Ctrl-C pressed while the pool starts was lost (issue 35, fault 7:
the command ran to its end, exit 0, and replaced the earlier result).

A Ctrl-C whose handler runs inside Python that numba's compiled code called back into (`_inside_a_compiled_call`:
numba unpickling a constant on a function's first calls) is not raised there, where compiled code would not see
the error (a NULL in its result, a segmentation fault): it is noted and sent again a few milliseconds later
(`_redeliver_later`), unless the stop is acted on first. Clean-up after a stop notes a further Ctrl-C instead of
raising it (`noted_not_raised`).
"""

import os
import signal
import sys
import threading
from contextlib import contextmanager

# The one line of a Ctrl-C before anything was written (cli.common's and the entry point's).
INTERRUPTED_MESSAGE = ("interrupted: nothing was written and no earlier result was replaced; rerun the same "
                       "command")

_requested = False
_written: list = []  # result folders this command has swapped in (storage.staged_output)

# The Python functions numba's compiled code calls back into in liaison's compiled calls: an environment constant
# (a returned array's dtype) or an exception's arguments are unpickled on a compiled function's first calls after
# it is loaded. (Returning a namedtuple, an enum or a typed container to Python would call Python classes too; no
# compiled entry point of liaison's does.)
# Their callers in compiled code do not check for an error: a KeyboardInterrupt raised in them leaves a NULL
# in the returned tuple, and the command dies of a segmentation fault (exit -11, seen in a clean-clone CI run:
# a Ctrl-C while run 0 of `run --jobs 2` started) or ends in a SystemError.
_CALLED_FROM_COMPILED_CODE = frozenset({"_numba_unpickle", "runtime_build_excinfo_struct"})
_REDELIVER_AFTER_S = 0.005


def _on_sigint(signum, frame):
    global _requested
    _requested = True
    if _inside_a_compiled_call(frame):
        _redeliver_later(signum)
        return
    raise KeyboardInterrupt


def _inside_a_compiled_call(frame) -> bool:
    """The handler runs in Python code that numba's compiled code called (at any depth), where an exception
    cannot be raised safely."""
    while frame is not None:
        code = frame.f_code
        if code.co_name in _CALLED_FROM_COMPILED_CODE and os.path.basename(code.co_filename) == "serialize.py":
            return True
        frame = frame.f_back
    return False


# The pending re-delivery of a deferred interrupt (a threading.Timer), None when there is none. Reentrant: the
# handler may run in the main thread while that thread holds it.
_redelivery = None
_redelivery_lock = threading.RLock()


def _redeliver_later(signum: int) -> None:
    """The same signal to the main thread a few milliseconds later: by then the compiled call has returned (the
    callback is microseconds; a compiled run runs no Python code, so the handler next runs after it), and the
    interrupt is raised where Python can unwind. Still inside, it is deferred again. Cancelled when the stop is
    acted on first (_cancel_redelivery): re-delivered later, it would interrupt the stop's own clean-up (a staging
    folder's removal was cut short, found by a fault hunt)."""
    global _redelivery
    with _redelivery_lock:
        if _redelivery is not None:
            return
        _redelivery = threading.Timer(_REDELIVER_AFTER_S, _signal_main_thread, (threading.main_thread().ident, signum))
        _redelivery.daemon = True
        _redelivery.start()


def _signal_main_thread(ident: int, signum: int) -> None:
    global _redelivery
    with _redelivery_lock:
        if _redelivery is None:  # cancelled: the stop was acted on meanwhile
            return
        _redelivery = None
        try:
            signal.pthread_kill(ident, signum)
        except (OSError, ValueError):  # the main thread has ended meanwhile: the process is exiting
            pass


def _cancel_redelivery() -> None:
    """The stop is being acted on (requested() or caused_by_interrupt() said so, or the CLI stops listening): a
    deferred interrupt is not re-delivered."""
    global _redelivery
    with _redelivery_lock:
        if _redelivery is not None:
            _redelivery.cancel()
            _redelivery = None


@contextmanager
def noted_not_raised():
    """For clean-up after a stop was decided (a staging folder's removal): a Ctrl-C meanwhile, a second one or a
    deferred one, is noted (requested()) and not raised, so the clean-up finishes; the stop goes on as it was.
    Elsewhere than the main thread, or when SIGINT is not this CLI's, nothing changes."""
    if threading.current_thread() is not threading.main_thread() or signal.getsignal(signal.SIGINT) is not _on_sigint:
        yield
        return

    def note(signum, frame):
        global _requested
        _requested = True

    previous_term = signal.getsignal(signal.SIGTERM)
    signal.signal(signal.SIGINT, note)
    if previous_term is _on_sigint:
        signal.signal(signal.SIGTERM, note)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, _on_sigint)
        if previous_term is _on_sigint:
            signal.signal(signal.SIGTERM, _on_sigint)


def install() -> None:
    """Use the remembering handler in this (main) process, unless SIGINT is ignored or handled by someone
    else (a shell that started us in the background, a test runner's own handler). Clears an earlier request.
    SIGTERM (a service manager's or `kill`'s stop) is handled as SIGINT when it is at its default: the same one
    line, staging removed and workers stopped, where the default died at once with the pool still running."""
    global _requested
    _requested = False
    _written.clear()
    _cancel_redelivery()
    if threading.current_thread() is not threading.main_thread():
        return
    if signal.getsignal(signal.SIGTERM) in (signal.SIG_DFL, _on_sigint):
        signal.signal(signal.SIGTERM, _on_sigint)
        _default_sigterm_in_forked_children()
    if signal.getsignal(signal.SIGINT) in (signal.default_int_handler, _on_sigint):
        signal.signal(signal.SIGINT, _on_sigint)
        if sys.unraisablehook is not _quiet_unraisable:
            _quiet_unraisable.previous = sys.unraisablehook
            sys.unraisablehook = _quiet_unraisable
        if threading.excepthook is not _quiet_pool_thread:
            _quiet_pool_thread.previous = threading.excepthook
            threading.excepthook = _quiet_pool_thread


_FORK_HOOK = False


def _default_sigterm_in_forked_children() -> None:
    """A process forked from the CLI (a concurrent.futures pool's worker) gets SIGTERM back at its default: its
    pool stops it with SIGTERM, which must end it quietly, not raise the CLI's KeyboardInterrupt in it."""
    import os

    global _FORK_HOOK
    if _FORK_HOOK:
        return
    _FORK_HOOK = True

    def reset():
        if signal.getsignal(signal.SIGTERM) is _on_sigint:
            signal.signal(signal.SIGTERM, signal.SIG_DFL)

    os.register_at_fork(after_in_child=reset)


def _quiet_unraisable(unraisable) -> None:
    """A Ctrl-C that lands in a C callback or a finaliser (llvmlite's, while numba compiles on a cold cache)
    cannot propagate: Python would print it as an "Exception ignored ... Traceback". It is not printed; the
    request is remembered (`requested`) and, this CLI's, raised again a few milliseconds later where Python can
    unwind (`_redeliver_later`). Only remembered, the command went on compiling to its next check of the request
    (once in eight suite runs, `errors` interrupted on a cold cache stopped after 70 s instead of 4, as a swallowed
    Ctrl-C would). Anything else goes to the previous hook."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt):
        if _requested and signal.getsignal(signal.SIGINT) is _on_sigint:
            _redeliver_later(signal.SIGINT)
        return
    _quiet_unraisable.previous(unraisable)


_quiet_unraisable.previous = sys.unraisablehook

# loky's manager threads of the process pool; a Ctrl-C that cancels the pool while one of them hands out work
# can make it fail (KeyError on a work item already cancelled) and print a thread traceback after the command's
# own one line (seen in a clean-clone CI run of tests/cli/test_interrupts.py: a KeyError in loky's thread).
_POOL_THREADS = ("ExecutorManagerThread", "QueueManagerThread")


def _quiet_pool_thread(args) -> None:
    """After a requested stop, a pool manager thread's failure is the cancellation's, not news: dropped; every
    other thread exception goes to the previous hook."""
    name = getattr(args.thread, "name", "") or ""
    if _requested and any(marker in name for marker in _POOL_THREADS):
        return
    _quiet_pool_thread.previous(args)


_quiet_pool_thread.previous = threading.excepthook


def ignore_from_now_on() -> None:
    """After a stop was decided: a later SIGINT (a second Ctrl-C, or one still pending while the pool shuts
    down) must not turn the documented exit code into death by signal."""
    _cancel_redelivery()
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        if signal.getsignal(signal.SIGTERM) is _on_sigint:
            signal.signal(signal.SIGTERM, signal.SIG_IGN)
    # CPython (3.11-3.13) marks "the program ended by an unhandled KeyboardInterrupt" whenever one escapes code
    # run through exec() of a string (generated dataclass, numba and joblib code), even if we catch it later;
    # at exit it then kills itself with SIGINT instead of exiting 130. Each exec() of a string clears the mark.
    exec("None")  # noqa: S102 - a constant: resets that interpreter flag, see above


def record_from_now_on() -> list | None:
    """After the command has finished (its line printed, its result written): a Ctrl-C during the wind-down (the
    pool's shutdown, the exit handlers) is noted in the returned list instead of raised, so the caller can still
    say so in one line. None when SIGINT is not this CLI's to handle (ignored by a shell, another handler)."""
    _cancel_redelivery()
    if threading.current_thread() is not threading.main_thread() or signal.getsignal(signal.SIGINT) is not _on_sigint:
        return None
    caught: list = []
    signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    if signal.getsignal(signal.SIGTERM) is _on_sigint:
        signal.signal(signal.SIGTERM, lambda signum, frame: caught.append(signum))
    return caught


def result_written(path) -> None:
    """storage: a complete result is now at `path` (an interrupt after this must not say nothing was written)."""
    _written.append(str(path))


def written() -> list:
    """The result folders this command completed before it was interrupted."""
    return list(_written)


def requested() -> bool:
    """True once Ctrl-C was pressed in this process (since `install`). The caller acts on it (stops): a deferred
    interrupt is not re-delivered."""
    if _requested:
        _cancel_redelivery()
    return _requested


def caused_by_interrupt(exc: BaseException) -> bool:
    """True when Ctrl-C was requested, or `exc` is (or was raised while handling, or from) a KeyboardInterrupt."""
    if _requested:
        _cancel_redelivery()  # the caller acts on it
        return True
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def ignore_in_worker_process() -> None:
    """In a pool's worker process (not the CLI's own), ignore SIGINT: the main process stops the pool. A worker
    that `shield_pool_workers` started with SIGINT blocked drops the Ctrl-C that waited, then unblocks it."""
    import multiprocessing

    if multiprocessing.parent_process() is not None and threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
        _watch_parent()


PARENT_WATCH_S = 0.5


def _name_this_thread(name: bytes) -> None:
    """The OS-level name of the calling thread (Linux: /proc/PID/task/TID/comm), so a test or an operator sees
    that a worker watches its parent; nothing where prctl is not there."""
    try:
        import ctypes

        ctypes.CDLL(None).prctl(15, ctypes.c_char_p(name[:15]), 0, 0, 0)  # PR_SET_NAME
    except (OSError, AttributeError):
        pass
_watching = False


def _watch_parent(parent: int | None = None) -> None:
    """In a pool worker: a daemon thread that ends the worker when its parent is gone (killed with SIGKILL, which
    no handler sees: the worker is handed to another parent, so its parent pid changes). Without it the workers
    went on computing for a command nobody waits for. Started once per worker process, with its first task: a
    worker killed before it had one is idle, and loky ends idle workers after its timeout (300 s)."""
    import os

    global _watching
    if _watching:
        return
    _watching = True
    if parent is None:  # a pool worker: its parent now (a live one started it)
        parent = os.getppid()
    elif os.getppid() != parent:  # handed to another parent already
        os._exit(1)

    def watch():
        import time

        _name_this_thread(b"liaison-watch")
        while True:
            time.sleep(PARENT_WATCH_S)
            if os.getppid() != parent:
                os._exit(1)

    threading.Thread(target=watch, name="liaison-parent-watch", daemon=True).start()


def end_with_parent(parent_pid: int) -> None:
    """In a helper process liaison started itself (campaign.engine.ahead): end it when its parent, parent_pid, is
    gone, as a pool worker ends (_watch_parent), at once if it is gone already."""
    _watch_parent(parent_pid)


@contextmanager
def sigint_held():
    """SIGINT blocked in this thread for the block, then unblocked: a Ctrl-C meanwhile waits (or goes at once to
    another thread of this process, whose handler hands it to the main thread) and is delivered after the block,
    never dropped. A thread or process started inside the block inherits the mask: SIGINT stays blocked there
    (a pool's workers and the threads that start them leave the stop to this process)."""
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


_SHIELDED = False


def shield_pool_workers() -> bool:
    """Make loky (joblib's process pool) start its workers with SIGINT blocked: its process launcher is
    wrapped so that, for the few milliseconds of the fork + exec, SIGINT is blocked in the launching thread
    (the child inherits its mask), then unblocked. A Ctrl-C meanwhile is delivered to this process when the
    mask is restored (or at once to another of its threads), never dropped. True when the launcher was found
    and wrapped (tested, so a joblib that moves it is noticed); False leaves loky as it is."""
    global _SHIELDED
    if _SHIELDED:
        return True
    try:
        from joblib.externals.loky.backend import fork_exec as launcher
    except ImportError:
        return False
    original = getattr(launcher, "fork_exec", None)
    if original is None:
        return False

    def fork_exec_sigint_blocked(*args, **kwargs):
        with sigint_held():
            return original(*args, **kwargs)

    launcher.fork_exec = fork_exec_sigint_blocked
    _SHIELDED = True
    return True
