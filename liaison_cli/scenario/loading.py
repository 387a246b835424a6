"""Scenario loading: read a file (bounded, YAML safe_load), validate it into a `Scenario` or a link file with
one line per problem naming the file, the key, the value and what is allowed, and apply dotted overrides."""

import copy
import logging
import re
from pathlib import Path

import yaml
from pydantic import ValidationError

from liaison_cli.errors import ScenarioError
from liaison_cli.orbits.family_catalogue import member_range
from liaison_cli.orbits.families import FAMILIES
from liaison_cli.scenario.exchange_specs import resolve_exchange_files
from liaison_cli.scenario.radio_settings import RangingLinkFile
from liaison_cli.scenario.scenario_model import Scenario


MAX_SCENARIO_BYTES = 1 << 20  # a scenario or link file (the shipped ones are < 5 kB)


def _format_loc(loc) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def _one_line(source: str, error: ValidationError) -> str:
    first = error.errors()[0]
    key = _format_loc(first["loc"])
    message = first["msg"].removeprefix("Value error, ")
    if first["type"] in ("model_type", "model_attributes_type", "dict_type"):
        message = "must be a mapping of keys (key: value lines)"
    if first["type"] == "missing":
        return f"{source}: key '{key}' is missing (required)"
    value = first.get("input")
    shown = "" if isinstance(value, (dict, list)) else f" = {value!r}"
    where = f"key '{key}'{shown}: " if key else ""
    return f"{source}: {where}{message}"


def validate_scenario(data, source: str = "<scenario>", model=Scenario):
    if not isinstance(data, dict):
        raise ScenarioError(f"{source}: the file must be a YAML mapping of keys, got {type(data).__name__}")
    try:
        validated = model.model_validate(data)
    except ValidationError as exc:
        raise ScenarioError(_one_line(source, exc)) from None
    if isinstance(validated, Scenario):
        _check_family_periods(validated, source)
    return validated


def _check_family_periods(scenario: Scenario, source: str) -> None:
    """A family member must exist: its period (or amplitude) has to lie in the family's range (recorded
    data: validation never reads or generates families on disk)."""
    for i, sc in enumerate(scenario.spacecraft):
        if sc.orbit not in FAMILIES:
            continue
        key, unit, digits = ("period_days", "days", 3) if sc.period_days is not None else ("amplitude_km", "km", 0)
        value = getattr(sc, key)
        lo, hi = member_range(sc.orbit, key)
        if not lo <= value <= hi:
            raise ScenarioError(
                f"{source}: key 'spacecraft[{i}].{key}' = {value!r}: outside orbit family "
                f"{sc.orbit!r}; valid {lo:.{digits}f} to {hi:.{digits}f} {unit}"
            )


def _read_bounded(path: Path) -> str:
    """The file's text, refused before reading anything that is not a regular file (a FIFO would block,
    /dev/zero never ends, a directory has no text) or is larger than MAX_SCENARIO_BYTES; at most that many
    bytes are read even if the file grows meanwhile."""
    import os
    import stat

    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise ScenarioError(f"{path}: no such scenario file") from None
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read the scenario ({exc.__class__.__name__}: {exc})") from None
    if not stat.S_ISREG(info.st_mode):
        kind = "a directory" if stat.S_ISDIR(info.st_mode) else "not a regular file"
        raise ScenarioError(f"{path}: {kind}; allowed: a regular YAML file")
    if info.st_size > MAX_SCENARIO_BYTES:
        raise ScenarioError(f"{path}: {info.st_size:,} bytes; allowed: a YAML file of at most "
                            f"{MAX_SCENARIO_BYTES:,} bytes (1 MiB)")
    try:
        with open(path, "rb") as handle:
            data = handle.read(MAX_SCENARIO_BYTES + 1)
        if len(data) > MAX_SCENARIO_BYTES:
            raise ScenarioError(f"{path}: grew past {MAX_SCENARIO_BYTES:,} bytes while being read; allowed: a YAML "
                                "file of at most 1 MiB")
        return data.decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{path}: cannot read the scenario ({exc.__class__.__name__}: {exc})") from None


class _YamlLoader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):
    """safe_load, with 1e5 and 1.0e5 read as numbers, as YAML 1.2 and editors read them (PyYAML's YAML 1.1
    rule wants a dot and a signed exponent, 1.0e+5, and gave the text '1.0e5', which only pydantic's coercion
    turned into a number: the JSON Schema saw a string where the editor saw a number). libyaml's parser where
    PyYAML has it (its wheels do): the same values (the resolver and constructor are PyYAML's own), about ten
    times faster to read than the pure-Python parser."""


_YamlLoader.add_implicit_resolver("tag:yaml.org,2002:float",
                                  re.compile(r"^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
                                  list("-+0123456789"))


def read_yaml_value(text: str):
    """One YAML value as a scenario file reads it (1e5 and 6e-5 are numbers): a --grid or --set value. A character
    libyaml cannot take (a bad byte on the command line arrives as a lone surrogate) is a yaml.YAMLError, as the
    pure-Python parser's "special characters are not allowed" was."""
    try:
        return yaml.load(text, Loader=_YamlLoader)
    except UnicodeEncodeError as exc:
        raise yaml.YAMLError(f"special characters are not allowed ({exc.reason})") from None


def _too_deep(path) -> ScenarioError:
    return ScenarioError(f"{path}: YAML nested too deeply to read; allowed: at most {MAX_NESTING} levels of mappings "
                         "and lists (a scenario needs fewer than 10)")


def read_scenario_text(path) -> tuple[dict, str]:
    path = Path(path)
    text = _read_bounded(path)
    try:
        data = yaml.load(text, Loader=_YamlLoader)  # a SafeLoader: no Python objects from the file
    except yaml.YAMLError as exc:
        if "maximum nesting depth" in str(getattr(exc, "problem", "")):  # libyaml's own bound (1,000 levels)
            raise _too_deep(path) from None
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ScenarioError(f"{path}: malformed YAML{where}: {problem}") from None
    except RecursionError:  # the pure-Python parser composes nested collections recursively
        raise _too_deep(path) from None
    if _nesting(data) > MAX_NESTING:  # validation, copies and the schema recurse too
        raise ScenarioError(f"{path}: YAML nested deeper than {MAX_NESTING} levels of mappings and lists; "
                            f"allowed: at most {MAX_NESTING} (a scenario needs fewer than 10)")
    return data, text


MAX_NESTING = 64  # levels of mappings and lists a scenario or link file may nest (issue 47: a RecursionError)


def _nesting(data) -> int:
    """How many levels of mappings and lists `data` nests (0 for a scalar), without recursion."""
    deepest, stack = 0, [(data, 0)]
    while stack:
        value, depth = stack.pop()
        if isinstance(value, dict):
            stack.extend((v, depth + 1) for v in value.values())
        elif isinstance(value, list):
            stack.extend((v, depth + 1) for v in value)
        else:
            deepest = max(deepest, depth)
            continue
        deepest = max(deepest, depth + 1)
        if deepest > MAX_NESTING:
            return deepest
    return deepest


def scenario_file(path, links: bool = False) -> Path:
    """`path` itself, or, when no such file exists here, the shipped scenario it names (scenario.shipped:
    `liaison run eml2_lunar` from any folder) or, with `links`, the shipped link file (`liaison budget
    turan2022_table2`), said in one note."""
    from liaison_cli.scenario.shipped import shipped_by_name, shipped_link_by_name

    shipped = shipped_by_name(path) or (shipped_link_by_name(path) if links else None)
    if shipped is None:
        return Path(path)
    kind = "link file" if shipped.parent.name == "links" else "scenario"
    logging.getLogger("liaison").warning(f"{path}: no such file here; the shipped {kind} {shipped}")
    return shipped


def load_scenario(path) -> tuple[Scenario, str]:
    """Read and validate a scenario file (or the shipped one its name stands for: scenario_file). Returns
    (scenario, original text)."""
    path = scenario_file(path)
    data, text = read_scenario_text(path)
    return validate_scenario(resolve_exchange_files(data, Path(path).parent), str(path)), text


def load_link_file(path) -> RangingLinkFile:
    """Read and validate a `liaison budget` link file (or the shipped one its name stands for: scenario_file)."""
    path = scenario_file(path, links=True)
    data, _ = read_scenario_text(path)
    return validate_scenario(data, str(path), RangingLinkFile)


LINK_FILE_KEYS = ("link_budget", "dual_one_way")  # top-level keys of a link file, never of a scenario


def check_file(path) -> str:
    """Every check `liaison run` makes of a scenario before it computes (reading, keys, values, the rules
    between them, dates, orbit families' ranges), or `liaison budget` of a link file; nothing is propagated
    or compiled. Returns what the file is ('scenario' or 'link file'); a problem raises ScenarioError."""
    path = scenario_file(path, links=True)
    data, _ = read_scenario_text(path)
    if isinstance(data, dict) and "spacecraft" not in data and any(k in data for k in LINK_FILE_KEYS):
        validate_scenario(data, str(path), RangingLinkFile)
        return "link file"
    validate_scenario(data, str(path))
    return "scenario"


def apply_overrides(scenario: Scenario, overrides: dict, source: str = "<override>") -> Scenario:
    """Set dotted-path keys (e.g. {'noise.sigma_m': 300}) and re-validate. A value of None removes the
    key, so its default applies (e.g. {'noise.ranging_method': None} before setting 'noise.sigma_m')."""
    data = copy.deepcopy(scenario.model_dump(exclude_none=True))
    for dotted, value in overrides.items():
        node = data
        parts = [int(p) if p.isdigit() else p for p in dotted.split(".")]
        for part in parts[:-1]:
            try:
                node = node[part]
            except (KeyError, IndexError, TypeError):
                raise ScenarioError(f"{source}: key '{dotted}' does not exist in the scenario") from None
        if isinstance(node, list) and not (isinstance(parts[-1], int) and parts[-1] < len(node)):
            raise ScenarioError(f"{source}: key '{dotted}' does not exist in the scenario")
        if value is None:
            if isinstance(node, dict):
                node.pop(parts[-1], None)
            else:
                raise ScenarioError(f"{source}: key '{dotted}' is a list item and cannot be removed")
        else:
            node[parts[-1]] = value
    return validate_scenario(data, source)
