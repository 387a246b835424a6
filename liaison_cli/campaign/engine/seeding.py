"""Reproducible randomness: a run's numbers depend only on the scenario seed and the run index."""

import numpy as np


def run_rng(scenario_seed: int, run_index: int) -> np.random.Generator:
    """Generator for one run; identical to the run_index-th child of SeedSequence(scenario_seed).spawn()."""
    return np.random.default_rng(np.random.SeedSequence(scenario_seed, spawn_key=(run_index,)))


# The stream of a run's truth forces (model_error.truth_acceleration_sigma_m_s2): a sibling of the run's own
# stream, so drawing them moves no other draw of the run.
TRUTH_FORCE_STREAM = 1


def truth_force_rng(scenario_seed: int, run_index: int) -> np.random.Generator:
    """Generator of one run's random truth forces: SeedSequence(scenario_seed, spawn_key=(run_index, 1))."""
    return np.random.default_rng(np.random.SeedSequence(scenario_seed, spawn_key=(run_index, TRUTH_FORCE_STREAM)))
