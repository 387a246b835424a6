"""Reproducible randomness: a run's numbers depend only on the scenario seed and the run index."""

import numpy as np


def run_rng(scenario_seed: int, run_index: int) -> np.random.Generator:
    """Generator for one run; identical to the run_index-th child of SeedSequence(scenario_seed).spawn()."""
    return np.random.default_rng(np.random.SeedSequence(scenario_seed, spawn_key=(run_index,)))
