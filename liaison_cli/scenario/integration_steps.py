"""Each estimated spacecraft's integration step (substeps per measurement interval) for a scenario: the key
`filter.rk4_substeps` when given (every spacecraft alike), else chosen by accuracy along the spacecraft's
nominal trajectory (dynamics.step_choice, to `filter.integration_tolerance_m`), and the per-block array the
compiled time update reads (kernel_args.Dynamics.substeps)."""

import numpy as np

from liaison_cli.dynamics.constants import M_PER_LU
from liaison_cli.dynamics.model import DynamicsModel
from liaison_cli.dynamics.step_choice import (UNREACHABLE, StepChoice, choose_substeps, sample_epochs,
                                             worst_error_lu)
from liaison_cli.estimation.blocks import BLOCK_SPACECRAFT, StateLayout
from liaison_cli.scenario.scenario_model import Scenario

SUBSTEPS_KEY = "filter.rk4_substeps"


def step_choices(scenario: Scenario, model: DynamicsModel, dt_tu: float, trajectories) -> dict[str, StepChoice]:
    """{estimated spacecraft: its StepChoice}, in the scenario's order."""
    flt = scenario.filter
    names = [sc.name for sc in scenario.spacecraft if sc.role == "estimated"]
    params = model.filter_params
    order = model.descriptor.integrator_order
    tolerance_lu = flt.integration_tolerance_m / M_PER_LU
    if flt.rk4_substeps is None:
        return {name: _chosen(model.code, params, trajectories[name].states, dt_tu, order, tolerance_lu)
                for name in names}
    out = {}
    for name in names:  # the fixed count's own error and, where it misses, what the tolerance would take
        states = trajectories[name].states
        fixed = int(flt.rk4_substeps)
        error_lu = worst_error_lu(model.code, params, np.ascontiguousarray(states, dtype=np.float64), dt_tu, fixed,
                                  order, sample_epochs(len(states)))
        accurate = 0
        if error_lu > tolerance_lu:
            search = choose_substeps(model.code, params, states, dt_tu, order, tolerance_lu, minimum=fixed)
            accurate = search.substeps if search.met else UNREACHABLE
        out[name] = StepChoice(fixed, error_lu, error_lu <= tolerance_lu, SUBSTEPS_KEY, accurate)
    return out


_CHOSEN: dict = {}  # this process's step choices by what fixes them (a design's unchanged spacecraft: once)
CHOSEN_MAX_ENTRIES = 256


def _chosen(model: int, params, states, dt_tu: float, order: int, tolerance_lu: float) -> StepChoice:
    """choose_substeps, remembered in this process under a digest of its inputs (the trajectory's bytes among
    them: 0.3 ms to hash against 10-25 ms to choose); a pure function, so a remembered choice is the same."""
    import hashlib

    digest = hashlib.blake2b(np.ascontiguousarray(states, dtype=np.float64).tobytes(), digest_size=16)
    digest.update(np.ascontiguousarray(params, dtype=np.float64).tobytes())
    key = (int(model), digest.hexdigest(), float(dt_tu), int(order), float(tolerance_lu))
    choice = _CHOSEN.get(key)
    if choice is None:
        if len(_CHOSEN) >= CHOSEN_MAX_ENTRIES:
            _CHOSEN.clear()
        choice = _CHOSEN[key] = choose_substeps(model, params, states, dt_tu, order, tolerance_lu)
    return choice  # the local, not a second look-up: another thread may clear the memo in between


def substeps_per_block(layout: StateLayout, choices: dict[str, StepChoice]) -> np.ndarray:
    """(B,) int64: each spacecraft block's substeps, 1 for other blocks (they do not integrate)."""
    return np.array([choices[block.owner].substeps if block.kind == BLOCK_SPACECRAFT else 1
                     for block in layout.blocks], dtype=np.int64)


def step_choice_line(choices: dict[str, StepChoice], interval_s: float, tolerance_m: float) -> str:
    """One line for the run text: each spacecraft's substeps and where they came from."""
    counts = ", ".join(f"{name} {choice.substeps}" for name, choice in choices.items())
    sources = {choice.source for choice in choices.values()}
    if sources == {"auto"}:
        missed = [name for name, choice in choices.items() if not choice.met]
        worst_m = max(choice.error_lu for choice in choices.values()) * M_PER_LU
        text = (f"integration: substeps per {interval_s:g} s interval: {counts} (chosen for a one-step error "
                f"within {tolerance_m:g} m; largest {worst_m:.2g} m; {SUBSTEPS_KEY} overrides)")
        if missed:
            text += f"; {', '.join(missed)} miss it at the most the ladder allows"
        return text
    missed = [name for name, choice in choices.items() if not choice.met]
    text = f"integration: substeps per {interval_s:g} s interval: {counts} ({SUBSTEPS_KEY})"
    if missed:
        text += f"; {', '.join(missed)} miss the {tolerance_m:g} m one-step tolerance at that count"
    return text
