"""Ctrl-C means stop, everywhere: one SIGINT handler for the CLI process that remembers the request and then
raises KeyboardInterrupt as Python's own handler does.

Why the memory: a KeyboardInterrupt raised while numba-compiled code runs comes back as
`SystemError: ... returned a result with an exception set`, an ordinary Exception that a worker (which
never raises) would record as a failed run, and the campaign would go on and report "ok". A worker finds the
request (`caused_by_interrupt`: the flag, or a KeyboardInterrupt in the exception's chain) and re-raises;
the campaign runner and the result swap (storage.staged_output) ask `requested()` too, so an interrupt
that compiled code swallowed whole still stops the command before a result is swapped in.

Pool worker processes receive the terminal's SIGINT too; they must leave the stop to the main process,
which cancels the pool, so that no worker prints a traceback. `shield_pool_workers` makes joblib's (loky's)
workers start with SIGINT ignored (an ignored signal stays ignored across exec, and Python then installs
no handler of its own); `ignore_in_worker_process` covers a worker started some other way.
"""

import signal
import sys
import threading

_requested = False
_written: list = []  # result folders this command has swapped in (storage.staged_output)


def _on_sigint(signum, frame):
    global _requested
    _requested = True
    raise KeyboardInterrupt


def install() -> None:
    """Use the remembering handler in this (main) process, unless SIGINT is ignored or handled by someone
    else (a shell that started us in the background, a test runner's own handler). Clears an earlier request."""
    global _requested
    _requested = False
    _written.clear()
    if threading.current_thread() is not threading.main_thread():
        return
    if signal.getsignal(signal.SIGINT) in (signal.default_int_handler, _on_sigint):
        signal.signal(signal.SIGINT, _on_sigint)
        if sys.unraisablehook is not _quiet_unraisable:
            _quiet_unraisable.previous = sys.unraisablehook
            sys.unraisablehook = _quiet_unraisable
        if threading.excepthook is not _quiet_pool_thread:
            _quiet_pool_thread.previous = threading.excepthook
            threading.excepthook = _quiet_pool_thread


def _quiet_unraisable(unraisable) -> None:
    """A Ctrl-C that lands in a C callback (LLVM's, while numba compiles on a cold cache) cannot propagate:
    Python would print it as an "Exception ignored ... Traceback". The request is remembered (`requested`) and
    the command stops with its one line; anything else goes to the previous hook."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt):
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
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    # CPython (3.11-3.13) marks "the program ended by an unhandled KeyboardInterrupt" whenever one escapes code
    # run through exec() of a string (generated dataclass, numba and joblib code), even if we catch it later;
    # at exit it then kills itself with SIGINT instead of exiting 130. Each exec() of a string clears the mark.
    exec("None")  # noqa: S102 - a constant: resets that interpreter flag, see above


def result_written(path) -> None:
    """storage: a complete result is now at `path` (an interrupt after this must not say nothing was written)."""
    _written.append(str(path))


def written() -> list:
    """The result folders this command completed before it was interrupted."""
    return list(_written)


def requested() -> bool:
    """True once Ctrl-C was pressed in this process (since `install`)."""
    return _requested


def caused_by_interrupt(exc: BaseException) -> bool:
    """True when Ctrl-C was requested, or `exc` is (or was raised while handling, or from) a KeyboardInterrupt."""
    if _requested:
        return True
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def ignore_in_worker_process() -> None:
    """In a pool's worker process (not the CLI's own), ignore SIGINT: the main process stops the pool."""
    import multiprocessing

    if multiprocessing.parent_process() is not None and threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


_SHIELDED = False


def shield_pool_workers() -> bool:
    """Make loky (joblib's process pool) start its workers with SIGINT ignored: its process launcher is
    wrapped so that, for the few milliseconds of the fork + exec, SIGINT is ignored in this process (the
    child inherits that), then restored. True when the launcher was found and wrapped (tested, so a joblib
    that moves it is noticed); False leaves loky as it is."""
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

    def fork_exec_ignoring_sigint(*args, **kwargs):
        if threading.current_thread() is not threading.main_thread():
            return original(*args, **kwargs)
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            return original(*args, **kwargs)
        finally:
            signal.signal(signal.SIGINT, previous)

    launcher.fork_exec = fork_exec_ignoring_sigint
    _SHIELDED = True
    return True
