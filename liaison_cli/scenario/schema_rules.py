"""JSON Schema words for the scenario's "goes together" rules between keys of one section.

The loader (scenario.schema) checks these rules with its own one-line messages; the same rules are written
into the generated JSON Schema as well, so that an editor flags a missing or stray key while the file is
written. Each rule here mirrors one loader check and is tested against it (tests/unit/scenario/test_schema_validate.py);
rules that need more than one section, names, dates or arithmetic stay in the loader only (listed in
scenario.json_schema.LOADER_ONLY_RULES).

A key written as `key: null` counts as not given, as the loader reads it (pydantic's None).
"""


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


def schema_rules(*rules, optional: tuple[str, ...] = ()):
    """A pydantic json_schema_extra: the rules joined with allOf; `optional` keys leave pydantic's `required`
    (a rule above says when they are needed, e.g. latitude_deg unless a site gives it)."""
    flat = [r for rule in rules for r in (rule if isinstance(rule, list) else [rule])]

    def extra(schema: dict, _model) -> None:
        if optional:
            schema["required"] = [k for k in schema.get("required", []) if k not in optional]
        if flat:  # an empty allOf is not a valid schema
            schema["allOf"] = flat

    return extra
