"""Each in-section rule is declared once (scenario.schema_rules.Rule) and makes both the JSON Schema's check
and the loader's: `holds`, the loader's reading of the rule words, agrees with the jsonschema library on every
rule of every section, for the shipped scenarios' sections and variants with the rules' keys dropped, set to
null or given values seen elsewhere."""

import itertools
import random

import jsonschema
import pytest

from liaison_cli.scenario.estimation_settings import BatchSpec, FilterSpec
from liaison_cli.scenario.loading import read_scenario_text
from liaison_cli.scenario.participants import ClockSpec, DepartureSpec, SpacecraftSpec
from liaison_cli.scenario.radio_settings import NoiseSpec
from liaison_cli.scenario.schema_rules import Rule, holds
from tests.conftest import SCENARIOS

SECTIONS = {NoiseSpec: "noise", FilterSpec: "filter", BatchSpec: "batch", ClockSpec: "clock",
            DepartureSpec: "departure", SpacecraftSpec: "spacecraft"}


def _section_dicts(kind: str) -> list[dict]:
    out = []
    for path in sorted(SCENARIOS.rglob("*.yaml")):
        data = read_scenario_text(path)[0]
        if not isinstance(data, dict):
            continue
        spacecraft = [sc for sc in data.get("spacecraft", []) if isinstance(sc, dict)]
        if kind == "spacecraft":
            out += spacecraft
        elif kind in ("clock", "departure"):
            out += [sc[kind] for sc in spacecraft if isinstance(sc.get(kind), dict)]
        elif isinstance(data.get(kind), dict):
            out.append(data[kind])
    return out


def _keys(condition) -> set[str]:
    if isinstance(condition, dict):
        keys = set(condition.get("required", [])) | set(condition.get("properties", {}))
        return keys | set().union(*(_keys(v) for v in condition.values()))
    if isinstance(condition, list):
        return set().union(*(_keys(v) for v in condition)) if condition else set()
    return set()


def _variants(instances: list[dict], keys: set[str], nullable: set[str], rng) -> list[dict]:
    """Each instance, and copies with one or two of the rule's keys dropped, null (the keys whose type takes
    null: any other the section's types refuse before a rule is read), or given a value some instance has (or
    a stand-in value)."""
    pool = {key: [inst[key] for inst in instances if inst.get(key) is not None] or ["x", 2, 0.5] for key in keys}
    out = list(instances)
    for instance in instances:
        for chosen in itertools.chain(itertools.combinations(sorted(keys), 1), itertools.combinations(sorted(keys), 2)):
            variant = dict(instance)
            for key in chosen:
                action = rng.randrange(3)
                if action == 1 and key not in nullable:
                    action = 0
                if action == 0:
                    variant.pop(key, None)
                elif action == 1:
                    variant[key] = None
                else:
                    variant[key] = rng.choice(pool[key])
            out.append(variant)
    return out


@pytest.mark.parametrize("section", list(SECTIONS), ids=[s.__name__ for s in SECTIONS])
def test_the_loader_reads_each_rule_as_jsonschema_does(section):
    rng = random.Random(5)
    instances = _section_dicts(SECTIONS[section])
    assert instances, "no shipped scenario has this section"
    assert section.RULES and all(isinstance(rule, Rule) for rule in section.RULES)
    checked = 0
    for rule in section.RULES:
        validator = jsonschema.Draft202012Validator(rule.condition)
        nullable = {name for name, field in section.model_fields.items() if field.default is None}
        for instance in _variants(instances, _keys(rule.condition), nullable, rng):
            assert holds(rule.condition, instance) == validator.is_valid(instance), (rule.message, instance)
            checked += 1
    assert checked >= 10 * len(section.RULES)


def test_a_word_the_loader_does_not_read_is_refused():
    with pytest.raises(ValueError, match="patternProperties"):
        holds({"patternProperties": {}}, {})


@pytest.mark.parametrize("condition, value", [
    ({"enum": [1]}, True), ({"const": 0}, False), ({"enum": [0.5, 1]}, 1.0), ({"required": ["a"]}, 5),
    ({"items": {"enum": ["x"]}}, "ab"), ({"contains": {"enum": ["x"]}}, None), ({"contains": {"enum": ["x"]}}, ["x"]),
    ({"properties": {"a": {"minimum": 2}}}, {"a": 1}), ({"properties": {"a": {"minimum": 2}}}, {"a": "text"}),
    ({"not": {"type": "null"}}, None), ({"oneOf": [{"enum": [1]}, {"minimum": 0}]}, 1),
], ids=lambda item: repr(item)[:30])
def test_the_words_on_values_the_rules_do_not_meet_yet(condition, value):
    """Corner cases no shipped section reaches today, read as jsonschema reads them: booleans against numbers,
    object words on a number, array words on a string or None."""
    assert holds(condition, value) == jsonschema.Draft202012Validator(condition).is_valid(value)


def test_a_type_other_than_null_is_refused():
    with pytest.raises(ValueError, match="only 'null'"):
        holds({"type": "string"}, 3)
