"""`liaison warm-up`: compile, into numba's on-disk cache, every kernel specialisation the shipped scenarios and
the `liaison new` templates need, ahead of the user's first run.

What a specialisation is, is read from the scenarios through the public setup, never from the kernels: the
estimator, the dynamics model and the kind set the estimators compile for (measurements.registry.kinds_mask
of the scenario's channels), and whether an initial batch starts the EKF. Scenarios that agree on all four
share their compiled code, so one of them (the one with the fewest epochs) stands for all: it is run once at
its smallest (one run, a short span), and the others are only set up (truth and measurements over a few
epochs, for what a scenario compiles before its estimator runs). numba compiles what is missing and caches it;
what is already cached is only loaded. Nothing is written but the caches (results stay in memory).

"Compiled" below is what numba compiled (a cache miss: its `numba:compile` event), never a load from the
cache, so a second warm-up reports nothing compiled.
"""

import time
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
    """A combination the kernels are compiled for, and the sources that need it (the first stands for all)."""

    estimator: str
    dynamics: str
    observables: tuple[str, ...]
    initial_batch: bool
    sources: tuple[Source, ...]

    @property
    def name(self) -> str:
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
    """(estimator, dynamics, observables, initial batch): what the compiled estimator is specialised on,
    from the scenario's declared links through the registry's own rule for the compiled kind set."""
    from liaison_cli.measurements.registry import OBSERVABLES, kinds_mask
    from liaison_cli.scenario.truth import link_observables

    codes = [kind.code for link in scenario.links for observable in link_observables(link)
             for kind in observable.channels]
    mask = kinds_mask(codes)
    observables = tuple(name for name, observable in OBSERVABLES.items()
                        if any(mask >> kind.code & 1 for kind in observable.channels))
    return (scenario.estimator, scenario.dynamics, observables, scenario.filter.initial_batch_hours is not None)


def plan(sources: list[Source] | None = None) -> list[Specialisation]:
    """The distinct specialisations of `sources` (default: the shipped scenarios and templates), most used
    first; each one's sources smallest first (its representative)."""
    groups: dict[tuple, list[Source]] = {}
    for source in shipped_sources() if sources is None else sources:
        groups.setdefault(specialisation_key(source.scenario), []).append(source)
    specs = [Specialisation(*key, tuple(sorted(group, key=lambda s: (s.epochs, s.label))))
             for key, group in groups.items()]
    return sorted(specs, key=lambda s: (-len(s.sources), s.name))


def chains(specs: list[Specialisation]) -> list[list[Specialisation]]:
    """Specialisations grouped by (estimator, dynamics), whose kernels share the most code: one chain runs in
    one process, in order, so a shared kernel is compiled by the first and loaded by the rest. The chain of
    the most used specialisation comes first."""
    grouped: dict[tuple, list[Specialisation]] = {}
    for spec in specs:
        grouped.setdefault((spec.estimator, spec.dynamics), []).append(spec)
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


def warm_up_chain(_shared, chain) -> list[WarmUpResult]:
    """Worker side: each specialisation of the chain in turn (see `chains`)."""
    from liaison_cli import interrupts

    interrupts.ignore_in_worker_process()  # in a pool: the main process stops it on Ctrl-C
    return [warm_up_one(spec) for spec in chain]


def warm_up_one(spec: Specialisation) -> WarmUpResult:
    """One run of the representative at its smallest, then the problem setup of every other scenario of the
    combination at its smallest, here, recording what numba compiles meanwhile. The setups cost little and
    catch what a scenario needs before its estimator runs (an orbit family's corrector, say)."""
    from numba.core import event

    recorder = _compile_recorder()
    started = time.perf_counter()
    with event.install_listener("numba:compile", recorder):
        errors = [_reported(_run_smallest, spec.representative),
                  *(_reported(_set_up_smallest, source) for source in spec.sources[1:])]
    error = "; ".join(e for e in errors if e)
    return WarmUpResult(spec, tuple(name for name, _ in recorder.compiled), time.perf_counter() - started, error,
                        tuple(f"{name}{signature}" for name, signature in recorder.compiled))


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

        def on_start(self, ev):
            pass

        def on_end(self, ev):
            dispatcher = ev.data.get("dispatcher")
            function = getattr(dispatcher, "py_func", None)
            module = getattr(function, "__module__", "") or ""
            # Kept: liaison's cached functions (an inlined overload has no cache of its own: it is compiled
            # into each caller), compiled and not abandoned (numba.literally retries with constants), so the
            # overload is now there (numba 0.6x's Event.is_failed answers the opposite of its name).
            if (module.startswith("liaison_cli") and dispatcher.stats.cache_path is not None
                    and tuple(ev.data["args"]) in dispatcher.overloads):
                self.compiled.append((f"{module}.{function.__qualname__}", str(ev.data["args"])))

    return Recorder()


def warm_up(specs: list[Specialisation], jobs: int = 2):
    """Yield the WarmUpResult of every specialisation as its chain finishes. The first specialisation (the
    most used, whose kernels the others share most) runs alone first, so no two processes compile the common
    kernels at once; then the chains run side by side in up to `jobs` processes."""
    from liaison_cli.campaign.engine.backends import LOCAL, map_batches

    if not specs:
        return
    groups = chains(specs)
    first, rest = [groups[0][:1]], [chain for chain in [groups[0][1:], *groups[1:]] if chain]
    rest.sort(key=len, reverse=True)  # the longest chain first, so it does not start last and finish alone
    for phase in (first, rest):
        for results in map_batches(warm_up_chain, {0: None}, ((0, tuple(chain)) for chain in phase), LOCAL,
                                   min(jobs, max(len(phase), 1)) if jobs > 1 else 1):
            yield from results
