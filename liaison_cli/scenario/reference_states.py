"""A spacecraft's CRTBP reference state from its scenario entry: a catalog orbit, a family member (by
period or amplitude) or lunar Keplerian elements; periodic orbits can be advanced by a phase of their
period (dated scenarios map the result into DE421 by multiple shooting)."""

import numpy as np

from liaison_cli.dynamics.constants import MU
from liaison_cli.dynamics.integrators.rk4 import rk4_states
from liaison_cli.orbits.catalog import CATALOG
from liaison_cli.orbits.keplerian import lunar_orbiter_state_lu
from liaison_cli.scenario.participants import KEPLERIAN_ORBIT


def initial_state_lu(spec) -> np.ndarray:
    if spec.period_days is not None:
        from liaison_cli.orbits.family_store import member_state

        return np.array(member_state(spec.orbit, float(spec.period_days)).state)
    if spec.amplitude_km is not None:
        from liaison_cli.orbits.family_store import member_by_amplitude_km

        return np.array(member_by_amplitude_km(spec.orbit, float(spec.amplitude_km)).state)
    if spec.orbit == KEPLERIAN_ORBIT:
        el = spec.elements
        return lunar_orbiter_state_lu(el.semi_major_axis_km, el.eccentricity, el.inclination_deg, el.raan_deg,
                                      el.argument_of_perilune_deg, el.ta_deg)
    return CATALOG[spec.orbit].state()


def period_tu(spec) -> float:
    """The period of a catalog or family orbit (TU)."""
    if spec.period_days is not None:
        from liaison_cli.orbits.family_store import member_state

        return member_state(spec.orbit, float(spec.period_days)).period_tu
    if spec.amplitude_km is not None:
        from liaison_cli.orbits.family_store import member_by_amplitude_km

        return member_by_amplitude_km(spec.orbit, float(spec.amplitude_km)).period_tu
    return CATALOG[spec.orbit].period_tu


def phased_state_lu(spec) -> np.ndarray:
    """initial_state_lu advanced by `phase` of the orbit's period in the CRTBP (a phased pair: 0.5)."""
    state = initial_state_lu(spec)
    if spec.phase == 0.0:
        return state
    return rk4_states(state, np.array([0.0, spec.phase * period_tu(spec)]), 1e-3, np.array([MU]))[-1]
