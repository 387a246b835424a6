"""Scenario schema: YAML (safe_load only) -> validated, frozen configuration.

Every problem is reported as one line naming the file, the key, the bad value and what is allowed. The
schema is split by concern; this module gathers its names so that `from liaison_cli.scenario.schema import
Scenario, load_scenario, apply_overrides, ...` keeps working:

- scenario.spec_base: the strict base model every section derives from;
- scenario.participants: spacecraft, ground stations, the dated (ephemeris) dynamics;
- scenario.links: links, topology, a link's noise, the measurement epochs;
- scenario.radio_settings: the noise section, link budgets, the `liaison budget` link file;
- scenario.estimation_settings: filter, batch, clock synchronisation, initial error, Monte Carlo;
- scenario.scenario_model: `Scenario`, its sections and the rules between them;
- scenario.loading: reading, validating, overriding.
"""

from liaison_cli.scenario.estimation_settings import (
    GATE_AFTER_DEFAULT, MAX_RUNS, BatchSpec, ClockSyncSpec, FilterSpec, InitialErrorSpec, MonteCarloSpec)
from liaison_cli.scenario.links import (
    LinkNoiseSpec, LinkSpec, MeasurementSpec, ObservableName, TopologySpec, expand_topology)
from liaison_cli.scenario.loading import (
    LINK_FILE_KEYS, MAX_SCENARIO_BYTES, apply_overrides, check_file, load_link_file, load_scenario,
    read_scenario_text, validate_scenario)
from liaison_cli.scenario.participants import (
    DATED_ONLY_ORBITS, DEPARTURE_ORBIT, GEOSTATIONARY_ORBIT, ICRF_STATE_ORBIT, KEPLERIAN_ORBIT, ClockSpec,
    DepartureSpec, EphemerisSpec, GroundStationSpec, KeplerianElements, ManoeuvreSpec, SpacecraftSpec, ThirdBodyName)
from liaison_cli.scenario.radio_settings import (
    CLOCK_KEYS, RANGING_METHODS, CarrierSpec, DualOneWayReceiverSpec, LinkBudgetSpec, LinkLegSpec, NoiseSpec,
    RangingLinkFile, RangingMethod)
from liaison_cli.scenario.scenario_model import MAX_EPOCHS, SMOOTHER_RECORD_MAX_BYTES, Scenario
from liaison_cli.scenario.spec_base import NAME_PATTERN, UNIQUE, StrictModel

__all__ = [
    "BatchSpec", "CLOCK_KEYS", "CarrierSpec", "ClockSpec", "ClockSyncSpec", "DATED_ONLY_ORBITS", "DEPARTURE_ORBIT",
    "DepartureSpec", "DualOneWayReceiverSpec", "EphemerisSpec", "FilterSpec", "GATE_AFTER_DEFAULT",
    "GEOSTATIONARY_ORBIT", "GroundStationSpec", "ICRF_STATE_ORBIT", "InitialErrorSpec", "KEPLERIAN_ORBIT",
    "KeplerianElements", "LINK_FILE_KEYS", "LinkBudgetSpec", "LinkLegSpec", "LinkNoiseSpec", "LinkSpec",
    "MAX_EPOCHS", "MAX_RUNS", "MAX_SCENARIO_BYTES", "ManoeuvreSpec", "MeasurementSpec", "MonteCarloSpec",
    "NAME_PATTERN", "NoiseSpec", "ObservableName", "RANGING_METHODS", "RangingLinkFile", "RangingMethod",
    "SMOOTHER_RECORD_MAX_BYTES", "Scenario", "SpacecraftSpec", "StrictModel", "ThirdBodyName", "TopologySpec",
    "UNIQUE", "apply_overrides", "check_file", "expand_topology", "load_link_file", "load_scenario",
    "read_scenario_text", "validate_scenario",
]
