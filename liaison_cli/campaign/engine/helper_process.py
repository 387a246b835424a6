"""A helper process liaison starts itself to compile ahead (campaign.engine.ahead for `liaison run`, warmup for
`liaison warm-up`): given a scenario and steps, it runs them in a second Python process, silent, at a lower
priority, with the starting process's exact import path, and ends with that process.
"""

import json
import logging
import os
import pickle
import signal
import subprocess
import sys
import threading


class SCENARIO:
    """In a step's arguments: the scenario (pickled by reference, so the helper knows it)."""


class Helper:
    """The helper process: started once (start), stopped once (stop). `steps`: its (callable, arguments) pairs,
    SCENARIO standing for the scenario; the callables must be importable by name (they are pickled). `what`: what
    it compiles, for -v's line."""

    def __init__(self, scenario, steps, what: str):
        self.payload = pickle.dumps((scenario, steps))
        self.what = what
        self.process = None
        self.lock = threading.Lock()

    def start(self) -> None:
        with self.lock:
            if self.process is not None:
                return
            try:
                self.process = subprocess.Popen(helper_command(), stdin=subprocess.PIPE,
                                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                                env={**os.environ, "LIAISON_TRUTH_CACHE": "off"})
            except OSError:  # no second process: the run compiles alone, as before
                self.process = False
                return
            logging.getLogger("liaison").info("compiling ahead in a second process (pid %d): %s", self.process.pid,
                                              self.what)
            # Fed from a thread: a payload larger than the pipe would otherwise hold the compiling run.
            threading.Thread(target=self._feed, args=(self.process,), daemon=True).start()

    def _feed(self, process) -> None:
        try:
            process.stdin.write(self.payload)
            process.stdin.close()
        except OSError:  # the helper is gone already
            pass

    def stop(self) -> None:
        with self.lock:
            process, self.process = self.process, False
        if process:
            if process.poll() is None:
                process.terminate()
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()

    @property
    def started(self) -> bool:
        return bool(self.process)


def helper_command() -> list:
    """The helper's command line: this interpreter, its import path set to this process's exact sys.path before
    anything is imported (-P: not the working folder's modules; so the helper compiles the code the run runs, a
    checkout or an installed copy, with the same numba and numpy), and this process's id, which it watches from
    its first instant."""
    start = ("import sys, json; sys.path[:] = json.loads(sys.argv[1]); "
             f"from {__name__} import main; main(int(sys.argv[2]))")
    return [sys.executable, "-P", "-c", start, json.dumps(sys.path), str(os.getpid())]


def main(parent_pid: int) -> None:
    """The helper process: read (scenario, steps) from stdin and run each step, skipping one that fails; end at
    a Ctrl-C (the terminal's, which reaches the run too) or when the run that started it, `parent_pid`, is gone
    (already at its start: a run killed within its first instants). At a lower priority than the run, which
    keeps the cores it needs when others want them too. The truth cache stays off (its environment): the day's
    truth it flies is no user's."""
    from liaison_cli import interrupts

    signal.signal(signal.SIGINT, signal.SIG_DFL)
    interrupts.end_with_parent(parent_pid)
    try:
        os.nice(10)
    except (AttributeError, OSError):  # no nice here: the same priority as the run
        pass
    scenario, steps = pickle.loads(sys.stdin.buffer.read())
    for step, arguments in steps:
        try:
            step(*(scenario if a is SCENARIO else a for a in arguments))
        except Exception:  # noqa: BLE001 - a step that fails is left to the command that needs it
            continue
