"""Compiling ahead on the idle core: while `liaison run` compiles the numeric core for its scenario (a cache
miss), a second process compiles what the next commands on the same scenario need and a run never reaches.

A first run on a 2-core machine compiles in one process for most of a minute while the other core waits. The helper
started here uses it: the shared calls every estimator makes by address (warmup.compile_shared_calls, and the dated
model's propagators for a dated scenario), then `liaison errors`' kernels (LinCov along the truth, the filter's
model on it) and `liaison observability`'s on the scenario cut to a day (warmup.errors_kernels,
observability_kernels), as `liaison warm-up` does for its shipped combinations. Two processes never compile one function side by side: the one
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

import os
from contextlib import contextmanager

from liaison_cli.campaign.engine.helper_process import SCENARIO, Helper


def steps_for(scenario) -> list:
    """The helper's steps for `scenario`: the calls by address first (no setup needed, so they are compiled while
    the run sets its scenario up), then `liaison errors` and `liaison observability` on the scenario at its
    smallest (warmup.COMMANDS, the commands whose kernels no run reaches)."""
    from liaison_cli.campaign.engine import warmup
    from liaison_cli.dynamics.registry import DYNAMICS

    ahead = [(warmup.compile_shared_calls, ())]
    if DYNAMICS[scenario.dynamics].dated:
        ahead.insert(0, (warmup.compile_dated_propagators, ()))
    return [*ahead, (warmup.errors_kernels, (SCENARIO,)), (warmup.observability_kernels, (SCENARIO,))]


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

    helper = Helper(scenario, steps_for(scenario) if steps is None else steps,
                    "what `liaison errors` and `liaison observability` need for this scenario")
    trigger = _FirstLiaisonCompile(helper.start)
    event.register("numba:compile", trigger.listener)
    try:
        yield helper
    finally:
        event.unregister("numba:compile", trigger.listener)
        helper.stop()
