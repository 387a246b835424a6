"""The scenario's JSON Schema, generated from the loader's model (scenario.scenario_model.Scenario).

An editor with a YAML language server reads it through the modeline at the top of a scenario
(`# yaml-language-server: $schema=...`) and offers keys, descriptions, units and allowed names while the file
is written. The shipped copy, scenarios/liaison-scenario.schema.json, is this text (a test keeps it so);
`liaison schema --output FILE` writes it again after the model changes.
"""

import json

SCHEMA_DIALECT = "https://json-schema.org/draft/2020-12/schema"  # pydantic's model_json_schema targets 2020-12
SCHEMA_ID = "urn:liaison:scenario"
SCHEMA_FILE_NAME = "liaison-scenario.schema.json"
MODELINE_PREFIX = "# yaml-language-server: $schema="

# What the schema does not say: rules that compare values, match names across sections, need dates or
# recorded tables. The loader checks them (and `liaison validate` runs the loader without propagating).
LOADER_ONLY_RULES = (
    "names: link ends, topology.hub and station_priority name defined participants; participant names are "
    "unique; a link does not join a participant to itself, repeat another link, or join known participants "
    "only; a second_receiver differs from both other ends; links given beside topology are its expansion; a "
    "site's coordinates are not contradicted",
    "observables: each has what it needs (an antenna_baseline_m on the receiver for los, the clocks a "
    "clock-timed observable reads, its noise sigma); the batch estimator takes no observable carrying clock "
    "states, no filter.bias: consider and no residual gate; clock_sync needs a dual_one_way_derived link",
    "time: measurement.interval_s fits in duration_days and gives at most 500,000 epochs per run; "
    "filter.settle_days ends before the last epoch; batch span plus prediction fit in duration_days, span at "
    "least two intervals, renewal_hours a whole number of intervals and no longer than the span; a manoeuvre "
    "falls inside the scenario and needs the ekf; clock_sync.window_hours covers two intervals",
    "orbits: a family member lies in the family's recorded period or amplitude range; the perilune clears the "
    "Moon; state_km lies outside the Earth; parking_inclination_deg is at least |dla_deg|",
    "dynamics: ephemeris: epoch_utc is an ISO 8601 date and time from 1972 on (leap seconds), the whole span "
    "inside DE421 (1899-07-29 to 2053-10-09) and, with ground stations or a geostationary spacecraft, inside "
    "the IERS Earth orientation table (from 1973-01-02); a departure mission's epoch is within 3 h after its "
    "injection; only the observables that model supports; measurement.light_time: true only with tdoa / fdoa",
    "estimated parameters: filter.estimated_parameters names parameters of the scenario's dynamics model (cr: "
    "dynamics: ephemeris), with the ekf",
    "filter states: filter.empirical_acceleration with the ekf and with time_constant_s at least "
    "measurement.interval_s; process_noise_psd_ric_m2_s3 without filter.initial_batch_hours",
    "model error: model_error.cr_bias / cr_sigma need dynamics: ephemeris, and one spelling of the C_R sigma; "
    "a lunar GM error needs the filter's Moon; a truth acceleration needs spacecraft whose truth liaison "
    "propagates (no OEM truth, no corrected dated orbit; the random one no estimated geostationary station "
    "either); truth_acceleration_sigma_m_s2 and truth_acceleration_time_constant_s go together (a sigma "
    "of 0: no force), the time constant at least measurement.interval_s, with simulated measurements",
    "numbers are finite (no .inf or .nan)",
)


def _description() -> str:
    rules = "; ".join(f"({i}) {rule}" for i, rule in enumerate(LOADER_ONLY_RULES, 1))
    return ("A liaison Monte Carlo scenario (YAML): participants, links, noise, estimator and runs. This schema "
            "states every key's type, unit, range and allowed names, and which keys of one section go together. "
            f"Checked by the loader only (`liaison validate FILE`): {rules}.")


def scenario_json_schema() -> dict:
    """The JSON Schema of a scenario file, with $schema, $id, title and description first."""
    from liaison_cli.scenario.scenario_model import Scenario

    body = Scenario.model_json_schema()
    body.pop("title", None)
    body.pop("description", None)
    head = {"$schema": SCHEMA_DIALECT, "$id": SCHEMA_ID, "title": "liaison scenario", "description": _description()}
    return {**head, **body}


def scenario_json_schema_text() -> str:
    """The schema as the shipped file holds it: two-space indent, UTF-8 text, one newline at the end."""
    return json.dumps(scenario_json_schema(), indent=2, ensure_ascii=False) + "\n"
