"""`liaison warm-up`: compile, into numba's on-disk cache, every kernel the shipped scenarios, the `liaison new`
templates and the commands beyond `run` (`errors`, `observability`) need, ahead of the user's first run.

The estimators read the dynamics model and the observable kinds at run time, so what a scenario compiles
depends on its estimator, its dynamics and whether an initial batch starts the EKF (read from the scenarios
through the public setup): scenarios that agree on these three share their compiled code, and one of them (the
one with the fewest epochs) stands for all. It is run once at its smallest (one run, a short span), and the
others are only set up (truth and measurements over a few epochs: what a scenario compiles before its
estimator runs, its own measurement models among it). Then `liaison errors` (LinCov and its Monte Carlo
check) and `liaison observability` run once on the smallest EKF scenario. numba compiles what is missing and
caches it; what is already cached is only loaded; every compiled entry is read back from the cache before the
warm-up says it is there (verify). Nothing is written but the caches (results stay in memory).

"Compiled" below is what numba compiled (a cache miss: its `numba:compile` event), never a load from the
cache, so a second warm-up reports nothing compiled.
"""

import time
from contextlib import contextmanager
from dataclasses import dataclass, field

from liaison_cli.errors import LiaisonError

# The span a warm-up run is cut to: a few hundred epochs of every shipped CRTBP or dated EKF scenario, so every
# part of the run is reached, and a run that costs little next to compiling. A scenario whose rules refuse the
# cut (a batch window longer than it; the 004 scenarios' initial batch of up to 96 h) runs whole.
WARM_UP_DAYS = 1.0
# The span the other scenarios of a combination are set up over (truth and measurements, no run): a few epochs.
SETUP_DAYS = 0.05


@dataclass(frozen=True)
class Source:
    """A scenario to warm up for: label (a shipped file relative to the shipped folder, or `template KIND`),
    the validated scenario and its epoch count (the smallest of a specialisation stands for it)."""

    label: str
    scenario: object
    epochs: int


@dataclass(frozen=True)
class Specialisation:
    """A combination of scenarios, and the sources that need it (the first stands for all); `command`: what is
    done with it, `run` (a run of the representative, the others set up) or a command whose kernels a run does
    not reach (COMMANDS: `errors`, LinCov and the filter model along the truth; `observability`)."""

    estimator: str
    dynamics: str
    observables: tuple[str, ...]
    initial_batch: bool
    sources: tuple[Source, ...]
    command: str = "run"

    @property
    def name(self) -> str:
        if self.command != "run":
            return f"liaison {self.command}"
        start = " + initial batch" if self.initial_batch else ""
        return f"{self.estimator}{start} · {self.dynamics} · {', '.join(self.observables)}"

    @property
    def representative(self) -> Source:
        return self.sources[0]


@dataclass(frozen=True)
class WarmUpResult:
    """One specialisation's warm-up: what numba compiled for it (function names, with repeats when several
    signatures of one function were compiled), the wall seconds, and the error of a run that failed."""

    specialisation: Specialisation
    compiled: tuple[str, ...] = ()
    seconds: float = 0.0
    error: str = ""
    signatures: tuple[str, ...] = field(default=(), repr=False)  # "function(signature)", to spot repeats
    entries: tuple = field(default=(), repr=False)  # (module, qualified name, argument types) of each, to verify


def shipped_sources() -> list[Source]:
    """Every shipped scenario file (the package's shipped_scenarios, which the repository's scenarios/ links
    to) and every template, validated. Link files and the schema are not scenarios."""
    from liaison_cli.scenario.loading import LINK_FILE_KEYS, load_scenario, read_scenario_text
    from liaison_cli.scenario.shipped import shipped_dir

    root = shipped_dir()
    sources = []
    for path in sorted(root.rglob("*.yaml")):
        data, _ = read_scenario_text(path)
        if not isinstance(data, dict) or "spacecraft" not in data or any(k in data for k in LINK_FILE_KEYS):
            continue
        sources.append(_source(path.relative_to(root).as_posix(), load_scenario(path)[0]))
    return sources + template_sources()


def template_sources() -> list[Source]:
    from liaison_cli.scenario.loading import read_yaml_value, validate_scenario
    from liaison_cli.scenario.templates import TEMPLATES, template_text

    return [_source(f"template {kind}", validate_scenario(read_yaml_value(template_text(kind)), f"template {kind}"))
            for kind in TEMPLATES]


def _source(label: str, scenario) -> Source:
    from liaison_cli.scenario.truth import measurement_times_s

    return Source(label, scenario, len(measurement_times_s(scenario)))


def specialisation_key(scenario) -> tuple:
    """(estimator, dynamics, initial batch): what a scenario's compiled code depends on. The kernels read the
    dynamics model and the observable kinds at run time, so scenarios that differ only in their observables
    share every compiled function; each is still set up by the warm-up (its own measurement models)."""
    return (scenario.estimator, scenario.dynamics, scenario.filter.initial_batch_hours is not None)


def scenario_observables(scenario) -> tuple[str, ...]:
    """The registered observables the scenario's links use, in the registry's order."""
    from liaison_cli.measurements.registry import OBSERVABLES
    from liaison_cli.scenario.truth import link_observables

    used = {observable.name for link in scenario.links for observable in link_observables(link)}
    return tuple(name for name in OBSERVABLES if name in used)


def plan(sources: list[Source] | None = None) -> list[Specialisation]:
    """The distinct specialisations of `sources` (default: the shipped scenarios and templates), most used
    first; each one's sources smallest first (its representative)."""
    from liaison_cli.measurements.registry import OBSERVABLES

    groups: dict[tuple, list[Source]] = {}
    for source in shipped_sources() if sources is None else sources:
        groups.setdefault(specialisation_key(source.scenario), []).append(source)
    specs = []
    for (estimator, dynamics, initial_batch), group in groups.items():
        used = {name for source in group for name in scenario_observables(source.scenario)}
        observables = tuple(name for name in OBSERVABLES if name in used)
        specs.append(Specialisation(estimator, dynamics, observables, initial_batch,
                                    tuple(sorted(group, key=lambda s: (s.epochs, s.label)))))
    specs.sort(key=lambda s: (-len(s.sources), s.name))
    return specs + command_items(specs)


# Commands whose kernels no run reaches, each warmed up on the smallest EKF scenario of the CRTBP (the kernels
# take the dynamics model at run time, so one model stands for both).
COMMANDS = ("errors", "observability")


def command_items(specs: list[Specialisation]) -> list[Specialisation]:
    """One Specialisation per COMMANDS entry, on the representative of the first EKF CRTBP combination."""
    ekf = next((spec for spec in specs if (spec.estimator, spec.dynamics, spec.initial_batch) == ("ekf", "crtbp",
                                                                                                   False)), None)
    if ekf is None:
        return []
    return [Specialisation(ekf.estimator, ekf.dynamics, ekf.observables, False, (ekf.representative,), command)
            for command in COMMANDS]


def chains(specs: list[Specialisation]) -> list[list[Specialisation]]:
    """Specialisations grouped by (command, estimator, dynamics), whose kernels share the most code: one chain
    runs in one process, in order, so a shared kernel is compiled by the first and loaded by the rest. The
    chain of the most used specialisation comes first."""
    grouped: dict[tuple, list[Specialisation]] = {}
    for spec in specs:
        grouped.setdefault((spec.command, spec.estimator, spec.dynamics), []).append(spec)
    return list(grouped.values())


def cut(scenario, days: tuple[float, ...]):
    """The scenario as one run over the first span of `days` its rules accept (a span longer than it, or inf:
    its own), or None if they accept none (a batch window, an initial batch or a manoeuvre past every cut)."""
    from liaison_cli.scenario.loading import apply_overrides

    runs_only = apply_overrides(scenario, {"monte_carlo.runs": 1}, "warm-up")
    for span in days:
        if scenario.duration_days <= span:
            return runs_only
        try:
            return apply_overrides(runs_only, {"duration_days": span}, "warm-up")
        except LiaisonError:
            continue
    return None


def warm_up_chain(ahead, chain) -> list[WarmUpResult]:
    """Worker side: each specialisation of the chain in turn (see `chains`), the first after the steps `ahead`."""
    from liaison_cli import interrupts

    interrupts.ignore_in_worker_process()  # in a pool: the main process stops it on Ctrl-C
    _thread_lock_for_progress_bars()
    return [warm_up_one(spec, ahead if i == 0 else ()) for i, spec in enumerate(chain)]


def compile_dated_propagators() -> str:
    """The dated model's propagators (dynamics.model), compiled with the signature the step choice and every
    estimator call them with: the parameter vector, the state, the epoch and the interval, the substeps, the
    output and the scratch. Run ahead in the process beside the first combination: they are about 16 s of that
    combination's compiling, a branch of it no earlier step needs, so the first process loads them instead of
    compiling them after its CRTBP propagator (docs/performance.md)."""
    import numpy as np
    from numba import typeof

    from liaison_cli.dynamics import model

    vector, scalar, steps, scratch = typeof(np.empty(1)), typeof(0.0), typeof(np.int64(1)), typeof(np.empty((5, 1)))
    model._ephemeris_state_stm_into.compile((vector, vector, scalar, scalar, steps, vector, scratch))
    model._ephemeris_parameter_into.compile((vector, scalar, vector, scalar, scalar, steps, vector))
    return ""


def compile_crtbp_dop853() -> str:
    """The CRTBP's compiled adaptive DOP853 (dynamics.integrators.dop853: one signature for a state and a state +
    STM), which the orbit-family corrector needs at the setup of every scenario with a family member. Run ahead in
    the second process after the dated propagators: otherwise the first process, the longest, compiled it (about
    4 s) at its first family scenario's setup."""
    import numpy as np

    from liaison_cli.dynamics.constants import MU
    from liaison_cli.dynamics.integrators.dop853 import dop853_states

    dop853_states(np.array([0.8, 0.0, 0.1, 0.0, 0.2, 0.0]), np.array([0.0, 0.01]), MU)
    return ""


def compile_shared_calls() -> str:
    """The measurement row and the covariance prediction every estimator calls by address
    (estimation.filter_loop.shared_calls), compiled for the named groups' fixed types. Run ahead in the first
    combination's process: it reaches them only after its step choice, which waits for the dated propagators
    the process beside it compiles, and neither depends on a dynamics model."""
    import numpy as np

    from liaison_cli.estimation.filter_loop import shared_covariance_prediction, shared_measurement_row
    from liaison_cli.estimation.kernel_args import BlockLayout, channels_of

    index = np.zeros(1, dtype=np.int64)
    shared_measurement_row(channels_of(index, np.zeros((1, 6)), index, np.zeros((1, 1)), np.zeros((1, 1)),
                                       np.ones(1)))
    shared_covariance_prediction(BlockLayout(index, index, index, index))
    return ""


@contextmanager
def compiling_ahead_of_the_plan(jobs: int):
    """With two processes or more, a helper process (campaign.engine.helper_process) compiles the calls by address
    and the dated model's propagators, which need no plan, while this process reads and validates every shipped
    scenario and template (plan: about 3 s with a warm cache, 7 s from an empty one, where validating the frozen
    lunar orbits compiles the lunar field's propagator). The pool's first steps (warm_up's `ahead`) then load them
    or wait for them instead of compiling them after the plan. Stopped at the block's end."""
    if jobs < 2:
        yield
        return
    from liaison_cli.campaign.engine.helper_process import Helper

    helper = Helper(None, [(compile_shared_calls, ()), (compile_dated_propagators, ())],
                    "the calls by address and the dated model's propagators, while the scenarios are read")
    helper.start()
    try:
        yield
    finally:
        helper.stop()


def _thread_lock_for_progress_bars() -> None:
    """tqdm makes a multiprocessing lock at its first bar, even a disabled one (the error budget's check has
    one), and in a pool worker the resource tracker reports that lock as leaked when the pool stops: a thread
    lock serves a worker that draws no bar."""
    import threading

    from tqdm import tqdm

    tqdm.set_lock(threading.RLock())


def warm_up_one(spec: Specialisation, ahead=()) -> WarmUpResult:
    """The steps `ahead` (callables, e.g. compile_dated_propagators), one run of the representative at its
    smallest, then the problem setup of every other scenario of the combination at its smallest, here, recording
    what numba compiles meanwhile. The setups cost little and catch what a scenario needs before its estimator
    runs (an orbit family's corrector, say)."""
    from numba.core import event

    recorder = _compile_recorder()
    started = time.perf_counter()
    first = {"run": _run_smallest, "errors": _errors_smallest, "observability": _observability_smallest}[spec.command]
    with event.install_listener("numba:compile", recorder):
        errors = [*(_reported(lambda _source, step=step: step(), spec.representative) for step in ahead),
                  _reported(first, spec.representative),
                  *(_reported(_set_up_smallest, source) for source in spec.sources[1:])]
    error = "; ".join(e for e in errors if e)
    return WarmUpResult(spec, tuple(name for name, _ in recorder.compiled), time.perf_counter() - started, error,
                        tuple(f"{name}{signature}" for name, signature in recorder.compiled),
                        tuple(recorder.entries))


def errors_kernels(scenario, check_runs: int = 0) -> None:
    """`liaison errors` on the scenario at its smallest (one day, cut): LinCov along the truth and the filter model
    on it, and with check_runs the check's EKF. What the warm-up and the run's helper (campaign.engine.ahead)
    compile for the command."""
    from liaison_cli.campaign.studies.error_budget import budget_study
    from liaison_cli.scenario.setup import prepare_problem

    budget_study(prepare_problem(cut(scenario, (WARM_UP_DAYS, float("inf")))), check_runs=check_runs)


def observability_kernels(scenario) -> None:
    """`liaison observability` on the scenario at its smallest (the information matrix along the truth)."""
    from liaison_cli.campaign.studies.observability_study import observability_study

    observability_study(cut(scenario, (WARM_UP_DAYS, float("inf"))))


def _errors_smallest(source: Source) -> str:
    """errors_kernels with a one-run Monte Carlo check on the source."""
    errors_kernels(source.scenario, check_runs=1)
    return ""


def _observability_smallest(source: Source) -> str:
    observability_kernels(source.scenario)
    return ""


def _run_smallest(source: Source) -> str:
    """One run (a run's own work unit, not run_campaign: its progress bar would leave a multiprocessing lock in
    a pool worker, which the resource tracker reports as leaked when the pool is stopped). Its error, or ''."""
    from liaison_cli.campaign.engine.worker import RunTask, execute_run
    from liaison_cli.scenario.setup import prepare_problem

    outcome = execute_run(prepare_problem(cut(source.scenario, (WARM_UP_DAYS, float("inf")))), RunTask(0))
    return outcome.reason if outcome.status == "error" else ""  # a worker reports, never raises


def _set_up_smallest(source: Source) -> str:
    """The problem setup over the shortest span the scenario accepts; skipped when it accepts no cut (its whole
    span could cost minutes of orbit correction, which is not compiling)."""
    from liaison_cli.scenario.setup import prepare_problem

    smallest = cut(source.scenario, (SETUP_DAYS, WARM_UP_DAYS))
    if smallest is not None:
        prepare_problem(smallest)
    return ""


def _reported(step, source: Source) -> str:
    """step(source)'s error as one phrase naming the scenario; a Ctrl-C is not a failure and goes on up."""
    from liaison_cli.interrupts import caused_by_interrupt

    try:
        error = step(source)
    except Exception as exc:  # noqa: BLE001 - reported with its combination
        if caused_by_interrupt(exc):
            raise
        error = f"{type(exc).__name__}: {exc}"
    return f"{source.label}: {error}" if error else ""


def _compile_recorder():
    """A numba event listener keeping (function, signature) of every cached liaison function numba compiles (a
    cache miss; a load from the cache raises no event)."""
    from numba.core import event

    class Recorder(event.Listener):
        def __init__(self):
            self.compiled = []
            self.entries = []

        def on_start(self, ev):
            pass

        def on_end(self, ev):
            dispatcher = ev.data.get("dispatcher")
            function = getattr(dispatcher, "py_func", None)
            module = getattr(function, "__module__", "") or ""
            # Kept: liaison's cached functions (an inlined one has no cache of its own: it is compiled into
            # each caller), compiled and not abandoned, so the overload is now there (numba 0.6x's
            # Event.is_failed answers the opposite of its name).
            if (module.startswith("liaison_cli") and dispatcher.stats.cache_path is not None
                    and tuple(ev.data["args"]) in dispatcher.overloads):
                self.compiled.append((f"{module}.{function.__qualname__}", str(ev.data["args"])))
                self.entries.append((module, function.__qualname__, tuple(ev.data["args"])))

    return Recorder()


def warm_up(specs: list[Specialisation], jobs: int = 2):
    """Yield the WarmUpResult of every specialisation as its chain finishes: the chains side by side in up to
    `jobs` processes, each taking the next as it finishes one. The most used specialisation (whose kernels the
    others share most) goes first, beside the other estimator's run (the batch: kernels of its own), then the
    longest chains. Two processes never compile one function side by side: the second waits for the first's
    save and loads it (compiled_cache, "Compiles in turn")."""
    from liaison_cli.campaign.engine.backends import LOCAL, map_batches

    if not specs:
        return
    groups = chains(specs)
    first, rest = groups[0][:1], [chain for chain in [groups[0][1:], *groups[1:]] if chain]
    batch = [chain for chain in rest if chain[0].estimator != groups[0][0].estimator and chain[0].command == "run"][:1]
    rest = [chain for chain in rest if chain not in batch]
    rest.sort(key=len, reverse=True)  # the longest chain first, so it does not start last and finish alone
    phase = [first, *batch, *rest]
    # The second chain starts by compiling the dated model's propagators, which the first would reach only after
    # its CRTBP propagator (compile_dated_propagators), then the corrector's DOP853 (compile_crtbp_dop853); the
    # first starts with the shared calls it would reach only after waiting for them (compile_shared_calls). With
    # one process, nothing is ahead of anything.
    ahead = ({0: (), 1: (compile_dated_propagators, compile_crtbp_dop853), 2: (compile_shared_calls,)} if jobs > 1
             else {0: ()})
    steps = ({0: 2, 1: 1}.get(i, 0) if jobs > 1 else 0 for i in range(len(phase)))
    yield from (result for results in map_batches(warm_up_chain, ahead, zip(steps, map(tuple, phase)),
                                                    LOCAL, min(jobs, len(phase)) if jobs > 1 else 1)
                for result in results)


def unloadable(entries) -> list[str]:
    """Of the (module, qualified name, argument types) numba compiled, those that numba's cache cannot load
    now ("module.name(types)"): what a warm-up reports as cached is read back before it says so."""
    import importlib

    missing = []
    for module, qualname, args in entries:
        dispatcher = importlib.import_module(module)
        for part in qualname.split("."):
            dispatcher = getattr(dispatcher, part)
        cache = getattr(dispatcher, "_cache", None)
        try:
            loaded = cache is not None and cache.probe_overload(tuple(args), dispatcher.targetctx) is not None
        except Exception:  # noqa: BLE001 - unreadable is missing
            loaded = False
        if not loaded:
            missing.append(f"{module}.{qualname}{tuple(args)}")
    return missing


def verify(results) -> list[str]:
    """Read every entry the warm-up compiled back from the on-disk cache (numba's loader reads the files, not
    this process's memory): the ones it cannot load."""
    return unloadable(tuple(entry for result in results for entry in result.entries))
