"""The scenario JSON Schema (liaison schema) and the checks without propagation (liaison validate), issue 27.

- The shipped schema file is the generated one; every key has a description, every number a unit.
- Every shipped scenario starts with the yaml-language-server modeline and passes the independent jsonschema
  validator; each "goes together" rule the schema states is refused by the schema and by the loader alike.
- `liaison validate`: one line per file, exit 2 if any is bad, all shipped scenarios in a few seconds.
"""

import copy
import os
import re
import time

import pytest

from tests.conftest import REPO, SCENARIOS, assert_one_line_error, run_cli_in_process
from liaison_cli.errors import ScenarioError
from liaison_cli.scenario.json_schema import (
    LOADER_ONLY_RULES, MODELINE_PREFIX, SCHEMA_FILE_NAME, scenario_json_schema, scenario_json_schema_text)
from liaison_cli.scenario.loading import check_file, load_link_file, read_scenario_text, validate_scenario

SCHEMA_FILE = SCENARIOS / SCHEMA_FILE_NAME
SHIPPED = sorted(SCENARIOS.glob("*.yaml")) + sorted(p for p in SCENARIOS.glob("*/*.yaml") if p.parent.name != "links")
LINK_FILES = sorted((SCENARIOS / "links").glob("*.yaml"))
UNIT_AT_END = re.compile(r"\([^()]+\)$")


@pytest.fixture(scope="module")
def validator():
    try:
        import jsonschema
    except ImportError:  # a failure, not a skip: the independent check must run (pip install -e '.[test]')
        pytest.fail("jsonschema is not installed: pip install -e '.[test]'")
    jsonschema.Draft202012Validator.check_schema(scenario_json_schema())
    return jsonschema.Draft202012Validator(scenario_json_schema())


def _ids(paths):
    return [str(p.relative_to(SCENARIOS)) for p in paths]


def test_shipped_schema_is_the_generated_one():
    assert SCHEMA_FILE.read_text(encoding="utf-8") == scenario_json_schema_text(), (
        f"regenerate it: liaison schema --output {SCHEMA_FILE.relative_to(REPO)}")


def _properties(schema):
    yield "Scenario", schema
    yield from schema["$defs"].items()


def _is_numeric(prop) -> bool:
    types = {prop.get("type"), prop.get("items", {}).get("type")} | {a.get("type") for a in prop.get("anyOf", [])}
    return bool(types & {"number", "integer"}) and "enum" not in prop


def test_every_key_has_a_description_and_every_number_a_unit():
    schema = scenario_json_schema()
    assert schema["$schema"].endswith("2020-12/schema") and schema["$id"] and schema["title"]
    assert all(rule in schema["description"] for rule in LOADER_ONLY_RULES)
    missing, no_unit, keys = [], [], 0
    for name, section in _properties(schema):
        assert section.get("description"), f"{name} has no description (its class docstring)"
        for key, prop in section["properties"].items():
            keys += 1
            text = prop.get("description", "")
            missing += [f"{name}.{key}"] if not text else []
            no_unit += [f"{name}.{key}: {text}"] if _is_numeric(prop) and not UNIT_AT_END.search(text) else []
    assert keys > 140 and not missing and not no_unit, (missing, no_unit)


@pytest.mark.parametrize("path", SHIPPED, ids=_ids(SHIPPED))
def test_shipped_scenario_has_the_modeline_and_passes_the_schema(path, validator):
    first = path.read_text(encoding="utf-8").splitlines()[0]
    assert first == MODELINE_PREFIX + os.path.relpath(SCHEMA_FILE, path.parent), first
    assert (path.parent / first.removeprefix(MODELINE_PREFIX)).resolve() == SCHEMA_FILE.resolve()
    errors = [f"{'.'.join(map(str, e.absolute_path))}: {e.message}" for e in validator.iter_errors(
        read_scenario_text(path)[0])]
    assert not errors, errors


@pytest.mark.parametrize("path", LINK_FILES, ids=_ids(LINK_FILES))
def test_the_links_folder_holds_budget_link_files_not_scenarios(path):
    """Why they carry no modeline and are not checked against the scenario schema: another format."""
    load_link_file(path)
    with pytest.raises(ScenarioError, match="unknown key"):
        validate_scenario(read_scenario_text(path)[0], str(path))
    assert check_file(path) == "link file"


def test_exponents_without_a_dot_or_sign_are_numbers():
    """PyYAML's YAML 1.1 read 1.0e5 as text (editors read a number); the loader reads it as YAML 1.2 does."""
    data, _ = read_scenario_text(SCENARIOS / "004" / "dro.yaml")
    assert data["noise"]["carrier_frequency_hz"] == 2.25e9 and data["filter"]["divergence_position_km"] == 1e5


def test_libyamls_parser_reads_every_shipped_file_as_the_pure_python_one():
    """The loader parses with libyaml where PyYAML has it (ten times faster); the resolver and constructor are
    PyYAML's, so every shipped scenario, link file and template, and the tricky values, read the same."""
    import math

    import yaml

    from liaison_cli.scenario import loading
    from liaison_cli.scenario.templates import TEMPLATES, template_text

    pure = type("Pure", (yaml.SafeLoader,), {})
    pure.yaml_implicit_resolvers = loading._YamlLoader.yaml_implicit_resolvers  # the 1e5 rule too
    texts = [path.read_text() for path in sorted(SCENARIOS.rglob("*.yaml"))] + [template_text(k) for k in TEMPLATES]
    values = ["1e5", "1.0e5", "-6e-5", "0x1A", "1_000", "on", "~", ".inf", ".nan", "2026-11-29", "1:20:30",
              "[1, 2e3]", "{a: 1e-3}", "'1e5'"]
    assert issubclass(loading._YamlLoader, yaml.CSafeLoader) or not yaml.__with_libyaml__
    for text in texts + values:
        fast, slow = yaml.load(text, Loader=loading._YamlLoader), yaml.load(text, Loader=pure)
        assert fast == slow or (isinstance(fast, float) and math.isnan(fast) and math.isnan(slow)), text


DROP = object()
SMOKE, MESH, STAR, CLOCK, MT, BATCH = ("smoke.yaml", "m4_mesh_eml2_lyapunov.yaml", "c1_star_eml2_hub.yaml",
                                       "clock_one_way_eml2_lunar.yaml", "mt_eml2_lunar_range_rate.yaml",
                                       "nrho_gateway_anchors.yaml")
DATED, CASSINI, TDOA = "eph_eml1_eml2_dsn.yaml", "003/cassini.yaml", "004/low_energy_transfer.yaml"
ELEMENTS = {"a_km": 9000, "e": 0.4, "i_deg": 60}
CARRIER = {"power_fraction_db": -3, "loop_bandwidth_hz": 10, "doppler_count_s": 1}
CLOCK_SPEC = {"preset": "uso", "initial_offset_sigma_s": 1e-6, "initial_frequency_sigma": 1e-11}
MANOEUVRE = {"epoch_days": 1, "delta_v_m_s": [0, 0, 0.1], "apriori_sigma_m_s": 0.1}
GEO = {"name": "GEO", "role": "known", "orbit": "geostationary", "longitude_deg": 0}

# (shipped scenario, edits (dotted key, value or DROP), a fragment of the loader's one line): every rule and
# allowed-name list the schema states, broken once; the schema and the loader must both refuse it.
BROKEN = [
    (SMOKE, [("spacecraft.1.elements", DROP)], "needs an 'elements' mapping"),
    (SMOKE, [("spacecraft.0.elements", ELEMENTS)], "'elements' is only allowed"),
    (MESH, [("spacecraft.1.amplitude_km", 10000)], "exactly one of 'period_days' or 'amplitude_km'"),
    (MESH, [("spacecraft.1.period_days", DROP)], "exactly one of 'period_days' or 'amplitude_km'"),
    (SMOKE, [("spacecraft.0.period_days", 12)], "only allowed with an orbit family"),
    (TDOA, [("spacecraft.0.state_km", DROP)], "'icrf_state' and 'state_km'"),
    (SMOKE, [("spacecraft.0.state_km", [7000, 0, 0, 0, 7, 0])], "'icrf_state' and 'state_km'"),
    (TDOA, [("spacecraft.0.state_km", [7000, 0, 0, 0, 7])], "needs 6 numbers"),
    (CASSINI, [("spacecraft.1.departure", DROP)], "'departure' and a 'departure' section"),
    (TDOA, [("spacecraft.1.longitude_deg", DROP)], "'geostationary' and 'longitude_deg'"),
    (TDOA, [("spacecraft.1.role", DROP)], "give it role: known"),
    (SMOKE, [("spacecraft.1.phase", 0.5)], "'phase' advances a periodic orbit"),
    (SMOKE, [("spacecraft.0.role", "known"), ("spacecraft.0.clock", CLOCK_SPEC)], "clock is not estimated"),
    (SMOKE, [("spacecraft.1.role", "known"), ("spacecraft.1.manoeuvre", MANOEUVRE)], "to an estimated spacecraft"),
    (SMOKE, [("spacecraft.0.role", "known"), ("spacecraft.1.role", "known")], "no spacecraft to estimate"),
    (CLOCK, [("spacecraft.0.clock.sigma2_per_sqrt_s", DROP)], "give a 'preset'"),
    (CASSINI, [("spacecraft.1.departure.c3_km2_s2", 9)], "derives c3_km2_s2"),
    (CASSINI, [("spacecraft.1.departure", {"c3_km2_s2": 9, "dla_deg": 5})], "all of c3_km2_s2, dla_deg"),
    (CASSINI, [("spacecraft.1.departure", {"c3_km2_s2": -2, "dla_deg": 5, "rla_deg": 9})], "needs C3 > 0"),
    (TDOA, [("ground_stations.0.site", DROP)], "latitude_deg' is missing"),
    (SMOKE, [("links", DROP)], "key 'links' is missing"),
    (STAR, [("topology.hub", DROP)], "needs a 'hub'"),
    (MESH, [("topology.hub", "EML2")], "takes no 'hub'"),
    (TDOA, [("links.0.observables", ["range"])], "carries tdoa / fdoa only"),
    (TDOA, [("links.0.second_receiver", DROP)], "give 'second_receiver'"),
    (SMOKE, [("links.0.observables", ["range", "range"])], "repeated observable"),
    (SMOKE, [("noise.ranging_method", "tone")], "not both"),
    (SMOKE, [("noise.sigma_m", DROP)], "give 'sigma_m' or both"),
    (MT, [("noise.link_budget", DROP)], "'ranging_method' and 'link_budget' go together"),
    (MT, [("noise.ranging_method", DROP), ("noise.carrier", DROP), ("noise.sigma_m", 10)], "'link_budget' is used"),
    (MT, [("noise.ranging_clock_hz", DROP)], "needs ranging_clock_hz"),
    (MT, [("noise.pn_chip_rate_offset_hz", 1.0)], "applies to ranging_method 'pn' only"),
    (MT, [("noise.range_rate_sigma_m_s", 0.001)], "or 'carrier' (which derives it)"),
    (SMOKE, [("noise.carrier", CARRIER)], "give 'link_budget'"),
    (SMOKE, [("filter", {"bias": "estimate"})], "needs 'bias_apriori_sigma_m'"),
    (SMOKE, [("filter", {"process_noise_psd_m2_s3": 1e-12, "process_noise_accel_m_s2": 1e-7})], "at most one of"),
    (SMOKE, [("spacecraft.0.process_noise_psd_m2_s3", 1e-12)], "at most one of"),
    (BATCH, [("batch.windows", 2)], "needs 'renewal_hours'"),
    (BATCH, [("batch", DROP)], "'batch' section go together"),
    (SMOKE, [("batch", {"span_days": 1})], "'batch' section go together"),
    (SMOKE, [("ephemeris", {"epoch_utc": "2020-01-01T00:00:00"})], "needs dynamics: ephemeris"),
    (DATED, [("ephemeris", DROP)], "needs an 'ephemeris' section"),
    (DATED, [("estimator", "batch"), ("batch", {"span_days": 1, "prediction_hours": 0})], "runs the ekf today"),
    (SMOKE, [("spacecraft.2", GEO)], "'geostationary' needs dynamics: ephemeris"),
    (SMOKE, [("ground_stations", [{"name": "GS", "site": "goldstone"}])], "needs dynamics: ephemeris"),
    (DATED, [("ephemeris.filter_bodies", ["moon", "moon"])], "repeated body"),
    (CASSINI, [("station_priority", ["Madrid", "Madrid"])], "lists a station twice"),
    (SMOKE, [("spacecraft.0.orbit", "halo")], "unknown orbit 'halo'"),
    (CLOCK, [("spacecraft.0.clock.preset", "quartz")], "unknown clock preset"),
    (CASSINI, [("spacecraft.1.departure.mission", "voyager")], "unknown mission"),
    (TDOA, [("ground_stations.0.site", "arecibo")], "unknown site"),
    (SMOKE, [("monte_carlo.sed", 1)], "unknown key 'sed'"),
    (DATED, [("filter.estimated_parameters", {"gm": 0.1})], "has no such parameter; allowed: cr"),
    (DATED, [("filter.estimated_parameters", {"cr": 0.0})], "greater than 0"),
]


def _edited(base: str, edits) -> dict:
    data = copy.deepcopy(read_scenario_text(SCENARIOS / base)[0])
    for dotted, value in edits:
        *parents, last = [int(p) if p.isdigit() else p for p in dotted.split(".")]
        node = data
        for part in parents:
            node = node[part]
        if value is DROP:
            del node[last]
        elif isinstance(node, list) and last == len(node):
            node.append(value)
        else:
            node[last] = value
    return data


@pytest.mark.parametrize("base, edits, fragment", BROKEN, ids=[f"{b}:{e[0][0]}" for b, e, _ in BROKEN])
def test_the_schema_and_the_loader_refuse_the_same_broken_rule(base, edits, fragment, validator):
    data = _edited(base, edits)
    assert list(validator.iter_errors(data)), "the schema accepts it"
    with pytest.raises(ScenarioError) as refused:
        validate_scenario(data, "broken.yaml")
    assert fragment in str(refused.value), str(refused.value)


def test_schema_command_prints_and_writes_the_generated_schema(tmp_path):
    printed = run_cli_in_process("schema")
    assert printed.returncode == 0 and printed.stdout == scenario_json_schema_text(), printed.stderr
    out = tmp_path / "new" / SCHEMA_FILE_NAME
    wrote = run_cli_in_process("schema", "--output", out)
    assert wrote.returncode == 0 and out.read_text(encoding="utf-8") == scenario_json_schema_text(), wrote.stderr
    assert_one_line_error(run_cli_in_process("schema", "--output", tmp_path), tmp_path, ["a directory"])


def test_validate_passes_every_shipped_file_quickly():
    """The issue's command line (link files included); no propagation, no compilation: measured 1.0 s (1.4 s
    under load) on the shared 2-core machine against the issue's 2 s; asserted with room for a busy machine."""
    files = sorted(SCENARIOS.glob("*.yaml")) + sorted(SCENARIOS.glob("*/*.yaml"))
    start = time.perf_counter()
    proc = run_cli_in_process("validate", *files)
    seconds = time.perf_counter() - start
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    assert proc.stdout.splitlines() == [f"ok: {path}" for path in files]
    assert len(files) >= 42 and seconds < 10, seconds


def _written(tmp_path, name, base, old, new):
    text = (SCENARIOS / base).read_text(encoding="utf-8")
    assert old in text, old
    path = tmp_path / name
    path.write_text(text.replace(old, new), encoding="utf-8")
    return path


def test_validate_gives_one_line_per_bad_file_and_exit_2(tmp_path):
    (tmp_path / "folder").mkdir()
    bad = {
        _written(tmp_path, "unknown.yaml", SMOKE, "name: smoke", "name: smoke\ncolour: blue"): "unknown key 'colour'",
        _written(tmp_path, "value.yaml", SMOKE, "sigma_m: 150", "sigma_m: -1"): "noise.sigma_m' = -1",
        _written(tmp_path, "ends.yaml", SMOKE, "receiver: EML2", "receiver: Earth"): "is not a spacecraft",
        _written(tmp_path, "family.yaml", MESH, "period_days: 15.5", "period_days: 99"): "outside orbit family",
        _written(tmp_path, "de421.yaml", DATED, '"2011-11-26T15:52:12.383"', '"2060-01-01T00:00:00"'): "outside DE421",
        _written(tmp_path, "eop.yaml", DATED, '"2011-11-26T15:52:12.383"', '"1972-06-01T00:00:00"'): "IERS Earth",
        _written(tmp_path, "link.yaml", "links/sirbu2023_ka_dual_one_way.yaml", "0.488e-6", "1.0e-6"): "< 2 chips",
        tmp_path / "folder": "a directory",
        tmp_path / "missing.yaml": "no such scenario file",
    }
    good = SCENARIOS / SMOKE
    proc = run_cli_in_process("validate", *bad, good)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr
    assert proc.stdout.splitlines() == [f"ok: {good}"]
    lines = proc.stderr.splitlines()
    assert len(lines) == len(bad), proc.stderr
    for line, (path, fragment) in zip(lines, bad.items()):
        assert line.startswith(f"error: {path}: ") and fragment in line, (line, fragment)


def test_a_directory_alone_is_one_line():
    assert_one_line_error(run_cli_in_process("validate", SCENARIOS), SCENARIOS, ["a directory; allowed: a regular YAML file"])
