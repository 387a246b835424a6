"""Compiling ahead on the idle core: while `liaison run` compiles the numeric core for its scenario (a cache
miss), a second process compiles what the next commands on the same scenario need and a run never reaches.

A first run on a 2-core machine compiles in one process for most of a minute while the other core waits. The helper
started here uses it: the shared calls every estimator makes by address (warmup.compile_shared_calls, and the dated
model's propagators for a dated scenario), then `liaison errors`' kernels (LinCov along the truth, the filter's
model on it, the default noise's LinCov check) and `liaison observability`'s on the scenario cut to a day, as
`liaison warm-up` does for its shipped combinations. Two processes never compile one function side by side: the one
that comes second waits for the other's save and loads it (compiled_cache, "Compiles in turn"), so the run loses
nothing and loads what the helper compiled first.

Only when it pays: the helper starts at the run's first cache miss of liaison code (a warm cache starts nothing),
for a scenario whose estimator has an error budget (the EKF), with --jobs 2 or more on the local fan-out and two or
more cores this process may use. It writes nothing but numba's cache (the truth cache is off in it), prints nothing
(its output goes nowhere) and never fails the run: a step that fails is skipped, and the command then compiles what
it needs itself. It ends with the run: the run stops it on the way out, finished or not (a function it was compiling
is released, compiled_cache), and it ends itself if the run is killed (it watches its parent). `--jobs 1` keeps the
run to one process.
"""

import json
import logging
import os
import pickle
import signal
import subprocess
import sys
import threading
from contextlib import contextmanager


class SCENARIO:
    """In a step's arguments: the scenario (pickled by reference, so the helper knows it)."""


def steps_for(scenario) -> list:
    """The helper's steps for `scenario`: the calls by address first (no setup needed, so they are compiled while
    the run sets its scenario up), then `liaison errors` and `liaison observability` on the scenario at its
    smallest (warmup.COMMANDS, the commands whose kernels no run reaches)."""
    from liaison_cli.campaign.engine import warmup
    from liaison_cli.dynamics.registry import DYNAMICS

    ahead = [(warmup.compile_shared_calls, ())]
    if DYNAMICS[scenario.dynamics].dated:
        ahead.insert(0, (warmup.compile_dated_propagators, ()))
    return [*ahead, (errors_smallest, (SCENARIO,)), (observability_smallest, (SCENARIO,))]


def errors_smallest(scenario) -> None:
    """What `liaison errors` compiles for `scenario`, on its first day (warmup.cut): the problem with the default
    noise's LinCov check, then the budget along the truth."""
    from liaison_cli.campaign.engine.noise_check import prepare_checked_problem
    from liaison_cli.campaign.engine.warmup import WARM_UP_DAYS, cut
    from liaison_cli.campaign.studies.error_budget import budget_study

    smallest = cut(scenario, (WARM_UP_DAYS, float("inf")))
    if smallest is not None:
        budget_study(prepare_checked_problem(smallest), check_runs=0)


def observability_smallest(scenario) -> None:
    """What `liaison observability` compiles for `scenario` (the information matrix along the truth), on its first
    day."""
    from liaison_cli.campaign.engine.warmup import WARM_UP_DAYS, cut
    from liaison_cli.campaign.studies.observability_study import observability_study

    smallest = cut(scenario, (WARM_UP_DAYS, float("inf")))
    if smallest is not None:
        observability_study(smallest)


def usable_cores() -> int:
    """The cores this process may run on (its affinity where the OS tells it)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


def worth_it(scenario, jobs: int, where_name: str) -> bool:
    """A helper is started for a scenario whose estimator has an error budget (`liaison errors` then runs on it:
    the EKF), run with --jobs 2 or more on the local fan-out with 2 cores or more (module docstring)."""
    from liaison_cli.estimation.estimators import ESTIMATORS

    return ESTIMATORS[scenario.estimator].error_budget and jobs >= 2 and where_name == "joblib" and usable_cores() >= 2


class Helper:
    """The helper process: started once (start), stopped once (stop). `steps`: its (callable, arguments) pairs,
    SCENARIO standing for the scenario; the callables must be importable by name (they are pickled)."""

    def __init__(self, scenario, steps):
        self.payload = pickle.dumps((scenario, steps))
        self.process = None
        self.lock = threading.Lock()

    def start(self) -> None:
        with self.lock:
            if self.process is not None:
                return
            try:
                self.process = subprocess.Popen(_helper_command(), stdin=subprocess.PIPE,
                                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                                env={**os.environ, "LIAISON_TRUTH_CACHE": "off"})
            except OSError:  # no second process: the run compiles alone, as before
                self.process = False
                return
            logging.getLogger("liaison").info("compiling ahead in a second process (pid %d): what `liaison errors` "
                                              "and `liaison observability` need for this scenario", self.process.pid)
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


def _helper_command() -> list:
    """The helper's command line: this interpreter, its import path set to this process's exact sys.path before
    anything is imported (-P: not the working folder's modules; so the helper compiles the code the run runs, a
    checkout or an installed copy, with the same numba and numpy), and this process's id, which it watches from
    its first instant."""
    start = ("import sys, json; sys.path[:] = json.loads(sys.argv[1]); "
             f"from {__name__} import main; main(int(sys.argv[2]))")
    return [sys.executable, "-P", "-c", start, json.dumps(sys.path), str(os.getpid())]


class _FirstLiaisonCompile:
    """A numba event listener that calls `start` at the first compile of a liaison function (a cache miss; a load
    from the cache raises no event)."""

    def __init__(self, start):
        from numba.core import event

        class Listener(event.Listener):
            def on_start(self, ev):
                function = getattr(ev.data.get("dispatcher"), "py_func", None)
                if getattr(function, "__module__", "").startswith("liaison_cli"):
                    start()

            def on_end(self, ev):
                pass

        self.listener = Listener()


@contextmanager
def compiling_ahead(scenario, jobs: int, where_name: str, steps=None):
    """Within the block, the first compile of liaison code starts the helper (module docstring) on `steps`
    (default: steps_for(scenario)); at its end, however it ends, the helper is stopped. Yields the Helper, or
    None where it is not worth it (worth_it)."""
    if not worth_it(scenario, jobs, where_name):
        yield None
        return
    from numba.core import event

    helper = Helper(scenario, steps_for(scenario) if steps is None else steps)
    trigger = _FirstLiaisonCompile(helper.start)
    event.register("numba:compile", trigger.listener)
    try:
        yield helper
    finally:
        event.unregister("numba:compile", trigger.listener)
        helper.stop()


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
