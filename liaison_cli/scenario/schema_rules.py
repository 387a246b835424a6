"""The scenario's "goes together" rules between keys of one section, each declared once.

A section lists its rules as `Rule(condition, message)`, the condition in JSON Schema words (given, when,
...). The same declaration makes both checks: schema_rules writes the conditions into the generated JSON
Schema, so that an editor flags a missing or stray key while the file is written, and check_rules holds the
validated section to them (`holds`: the conditions evaluated on the section's values, the subset of JSON
Schema these words use, tested against the jsonschema library in tests/unit/scenario/test_schema_rules.py),
raising the rule's one-line message. Rules that need more than one section, names, dates or arithmetic stay
in the loader only (listed in scenario.json_schema.LOADER_ONLY_RULES).

A key written as `key: null` counts as not given, as the loader reads it (pydantic's None).
"""

from dataclasses import dataclass
from typing import Callable

from pydantic import BaseModel


def given(key: str) -> dict:
    return {"required": [key], "properties": {key: {"not": {"type": "null"}}}}


def not_given(key: str) -> dict:
    return {"properties": {key: {"type": "null"}}}


def equals(key: str, *values) -> dict:
    """The key is given with one of `values`; a key left out (its default) does not match."""
    return {"required": [key], "properties": {key: {"enum": list(values)}}}


def at_least(key: str, minimum) -> dict:
    return {"required": [key], "properties": {key: {"minimum": minimum}}}


def each(key: str, condition: dict) -> dict:
    """Every item of the list under `key` (if given) meets `condition`."""
    return {"properties": {key: {"items": condition}}}


def all_of(*conditions) -> dict:
    return {"allOf": list(conditions)}


def any_of(*conditions) -> dict:
    return {"anyOf": list(conditions)}


def one_of(*conditions) -> dict:
    return {"oneOf": list(conditions)}


def negate(condition: dict) -> dict:
    return {"not": condition}


def when(condition: dict, then: dict, otherwise: dict | None = None) -> dict:
    rule = {"if": condition, "then": then}
    if otherwise is not None:
        rule["else"] = otherwise
    return rule


def together(condition: dict, key: str) -> list[dict]:
    """`key` is given exactly when `condition` holds (e.g. orbit: lunar_keplerian and elements)."""
    return [when(condition, given(key), not_given(key))]


@dataclass(frozen=True)
class Rule:
    """A rule of one section, declared once: the condition a valid section meets (JSON Schema words) and the
    one-line message when it does not (a string, or a function of the section for one that names values)."""

    condition: dict
    message: str | Callable


def check_rules(section, rules):
    """The section (a validated model), if it meets every rule; else ValueError with the first broken rule's
    message, in the order the rules are declared."""
    for rule in rules:
        if not holds(rule.condition, section):
            raise ValueError(rule.message(section) if callable(rule.message) else rule.message)
    return section


def _field(value, key):
    return value.get(key) if isinstance(value, dict) else getattr(value, key, None)


def _is_object(value) -> bool:
    """A section (a model) or a mapping: what JSON Schema's object words (required, properties) apply to."""
    return isinstance(value, (dict, BaseModel))


def _is_array(value) -> bool:
    return isinstance(value, (list, tuple))


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _same(value, option) -> bool:
    """JSON equality: true and 1 differ, 1 and 1.0 do not."""
    if isinstance(value, bool) or isinstance(option, bool):
        return isinstance(value, bool) and isinstance(option, bool) and value == option
    return value == option


def _type(sub, value) -> bool:
    if sub != "null":  # the rules say "not given" only; another type word would be read wrongly, so it is refused
        raise ValueError(f"rule word type: {sub!r} is not one check_rules evaluates (only 'null')")
    return value is None


_WORDS = {
    "required": lambda sub, value: not _is_object(value) or all(_field(value, key) is not None for key in sub),
    # A key the section leaves unset (None) is absent to JSON Schema, whose `properties` skip absent keys.
    "properties": lambda sub, value: not _is_object(value) or all(
        holds(rule, _field(value, key)) for key, rule in sub.items() if _field(value, key) is not None),
    "not": lambda sub, value: not holds(sub, value),
    "type": _type,
    "enum": lambda sub, value: any(_same(value, option) for option in sub),
    "const": lambda sub, value: _same(value, sub),
    "minimum": lambda sub, value: not _is_number(value) or value >= sub,
    "items": lambda sub, value: not _is_array(value) or all(holds(sub, item) for item in value),
    "contains": lambda sub, value: not _is_array(value) or any(holds(sub, item) for item in value),
    "allOf": lambda sub, value: all(holds(rule, value) for rule in sub),
    "anyOf": lambda sub, value: any(holds(rule, value) for rule in sub),
    "oneOf": lambda sub, value: sum(holds(rule, value) for rule in sub) == 1,
}


def holds(condition: dict, value) -> bool:
    """Whether `value` (a section model, a dict, a list or a scalar) meets `condition`, written in the JSON
    Schema words of this module (if / then / else included); a word outside them is refused (ValueError), so
    that no rule is silently taken for true."""
    for word, sub in condition.items():
        if word in ("if", "then", "else"):
            continue
        if word not in _WORDS:
            raise ValueError(f"rule word {word!r} is not one check_rules evaluates")
        if not _WORDS[word](sub, value):
            return False
    if "if" in condition:
        branch = condition.get("then") if holds(condition["if"], value) else condition.get("else")
        return branch is None or holds(branch, value)
    return True


def schema_rules(*rules, optional: tuple[str, ...] = ()):
    """A pydantic json_schema_extra: the rules (Rule, or bare conditions a section checks in its own code)
    joined with allOf; `optional` keys leave pydantic's `required` (a rule above says when they are needed,
    e.g. latitude_deg unless a site gives it)."""
    conditions = [rule.condition if isinstance(rule, Rule) else rule for rule in rules]
    flat = [r for rule in conditions for r in (rule if isinstance(rule, list) else [rule])]

    def extra(schema: dict, _model) -> None:
        if optional:
            schema["required"] = [k for k in schema.get("required", []) if k not in optional]
        if flat:  # an empty allOf is not a valid schema
            schema["allOf"] = flat

    return extra
