"""mkdocs hooks (mkdocs.yml: hooks): the generated parts of the documentation site, made at build time.

- `<!-- liaison:cli-reference -->` in a page becomes the CLI reference, walked from the click command tree
  of `liaison_cli.cli.app` (typer builds it), so a new command or option appears without editing a page.
- `<!-- liaison:observables -->` becomes the table of observables in measurements/registry.py.
- `<!-- liaison:dynamics -->` becomes the table of dynamics models in dynamics/registry.py (what each is,
  its epochs and frame, the parameters the filter may estimate).
- `<!-- liaison:scenario-reference -->` becomes the scenario reference, rendered from the JSON Schema that
  `liaison schema` prints (`liaison_cli.scenario.json_schema.scenario_json_schema`).
- The figures under results/reference/ are added to the site as results/reference/..., so a page shows
  the very file the command wrote (tables come in through pymdownx.snippets, `--8<--`).

Nothing here computes: it reads the app and the schema as they are.
"""

import json
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:  # the `mkdocs` script's sys.path lacks the checkout; import this tree's package
    sys.path.insert(0, str(REPO))

CLI_MARKER = "<!-- liaison:cli-reference -->"
SCENARIO_MARKER = "<!-- liaison:scenario-reference -->"
OBSERVABLES_MARKER = "<!-- liaison:observables -->"
DYNAMICS_MARKER = "<!-- liaison:dynamics -->"
FIGURE_SUFFIXES = (".png", ".svg")
REFERENCE_DIR = Path("results") / "reference"


# --- CLI reference -------------------------------------------------------------------------------------


def _prose(text) -> str:
    """Help text as Markdown prose: `<name>` placeholders shown, not read as HTML tags."""
    return str(text).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def _cell(text) -> str:
    """Text safe inside a Markdown table cell."""
    return _prose(" ".join(str(text).split())).replace("|", "\\|")


def _help_text(command) -> str:
    """A command's help as Markdown paragraphs (click's \\b no-rewrap markers dropped)."""
    return _prose((command.help or "").replace("\b\n", "").strip())


def _parameter_rows(command, ctx) -> list[str]:
    """One row per argument and option, as `--help` shows them (name, value type, help with its default)."""
    rows = []
    for param in command.get_params(ctx):
        record = param.get_help_record(ctx)
        if record is None or param.name == "help":  # hidden, or click's own --help
            continue
        name, help_text = record
        rows.append(f"| `{name}` | {param.param_type_name} | {_cell(help_text)} |")
    return rows


def _command_section(command, path: list[str], parent_ctx) -> list[str]:
    # Duck-typed on click's API: typer may build the tree with click or with its own vendored copy of it.
    ctx = command.context_class(command, info_name=path[-1], parent=parent_ctx)
    title = " ".join(path)
    lines = [f"{'#' * min(len(path) + 1, 4)} `{title}`", "", _help_text(command), ""]
    usage = command.get_usage(ctx).removeprefix("Usage:").strip()
    lines += ["```", usage, "```", ""]
    rows = _parameter_rows(command, ctx)
    if rows:
        lines += ["| parameter | kind | meaning |", "|---|---|---|", *rows, ""]
    if hasattr(command, "list_commands"):
        for name in command.list_commands(ctx):
            sub = command.get_command(ctx, name)
            if sub is not None and not sub.hidden:
                lines += _command_section(sub, [*path, name], ctx)
    return lines


def cli_reference_markdown() -> str:
    """Every command, subcommand, argument and option of `liaison`, from the click tree typer builds."""
    import typer.main

    from liaison_cli.cli import app

    root = typer.main.get_command(app)
    return "\n".join(_command_section(root, ["liaison"], None)).rstrip() + "\n"


# --- scenario reference ---------------------------------------------------------------------------------


def _ref_name(ref: str) -> str:
    return ref.rsplit("/", 1)[-1]


def _anchor(name: str) -> str:
    return name.lower()


def _type_text(node: dict) -> str:
    """A schema node's type in a few words: links to sections, enums spelled out, ranges."""
    if "$ref" in node:
        name = _ref_name(node["$ref"])
        return f"[{name}](#{_anchor(name)})"
    if "const" in node:
        return f"`{json.dumps(node['const'])}`"
    if "enum" in node:
        return "one of " + ", ".join(f"`{v}`" for v in node["enum"])
    for combiner in ("anyOf", "oneOf"):
        if combiner in node:
            options = [o for o in node[combiner] if o.get("type") != "null"]
            text = " or ".join(_type_text(o) for o in options)
            return text + (" or null" if len(options) < len(node[combiner]) else "")
    kind = node.get("type", "any")
    if kind == "array":
        text = f"list of {_type_text(node.get('items', {}))}"
        if "minItems" in node or "maxItems" in node:
            text += f" ({node.get('minItems', 0)}–{node.get('maxItems', '…')} items)"
        return text
    if kind == "object" and isinstance(node.get("additionalProperties"), dict):
        return f"map of {_type_text(node['additionalProperties'])}"
    return kind + _bounds_text(node)


def _bounds_text(node: dict) -> str:
    bounds = []
    for key, symbol in (("minimum", "≥"), ("exclusiveMinimum", ">"), ("maximum", "≤"), ("exclusiveMaximum", "<")):
        if key in node:
            bounds.append(f"{symbol} {node[key]:g}" if isinstance(node[key], (int, float)) else f"{symbol} {node[key]}")
    if "pattern" in node:
        bounds.append(f"matching `{node['pattern']}`")
    return f" ({', '.join(bounds)})" if bounds else ""


def _property_rows(model: dict) -> list[str]:
    required = set(model.get("required", ()))
    rows = ["| key | type | default | meaning |", "|---|---|---|---|"]
    for key, node in model.get("properties", {}).items():
        if key in required:
            default = "required"
        elif "default" in node:
            default = f"`{json.dumps(node['default'], ensure_ascii=False)}`"
        else:
            default = ""
        rows.append(f"| `{key}` | {_cell(_type_text(node))} | {_cell(default)} | {_cell(node.get('description', ''))} |")
    return rows


def _is_given(node: dict) -> str | None:
    """`{properties: {k: {not: {type: null}}}, required: [k]}` -> 'k is given'."""
    props = node.get("properties", {})
    if len(props) == 1 and set(node) <= {"properties", "required"}:
        (key, condition), = props.items()
        if condition == {"not": {"type": "null"}}:
            return f"`{key}` is given"
        if condition == {"type": "null"}:
            return f"`{key}` is left out"
        if "enum" in condition and len(condition) == 1:
            values = ", ".join(f"`{v}`" for v in condition["enum"])
            return f"`{key}` is {values}" if len(condition["enum"]) == 1 else f"`{key}` is one of {values}"
        if "minimum" in condition and len(condition) == 1:
            return f"`{key}` ≥ {condition['minimum']}"
    return None


def rule_text(node: dict) -> str:
    """One schema rule (if/then/else, anyOf, oneOf, allOf, not) as a sentence; other shapes as compact JSON."""
    simple = _is_given(node)
    if simple:
        return simple
    if "if" in node:
        text = f"if {rule_text(node['if'])}, then {rule_text(node.get('then', {}))}"
        return text + (f"; otherwise {rule_text(node['else'])}" if "else" in node else "")
    if set(node) == {"allOf"}:
        return " and ".join(rule_text(part) for part in node["allOf"])
    if set(node) == {"anyOf"}:
        return "at least one of: " + "; ".join(f"({rule_text(part)})" for part in node["anyOf"])
    if set(node) == {"oneOf"}:
        return "exactly one of: " + "; ".join(f"({rule_text(part)})" for part in node["oneOf"])
    if set(node) == {"not"}:
        return f"not ({rule_text(node['not'])})"
    return f"`{json.dumps(node, ensure_ascii=False)}`"


def _model_section(name: str, model: dict, level: str = "###") -> list[str]:
    lines = [f"{level} {name}" + (f" {{#{_anchor(name)}}}" if level == "###" else ""), ""]
    if model.get("description"):
        lines += [model["description"], ""]
    lines += _property_rows(model) + [""]
    rules = [*model.get("allOf", ()), *([{"oneOf": model["oneOf"]}] if "oneOf" in model else []),
             *([{"anyOf": model["anyOf"]}] if "anyOf" in model else [])]
    if rules:
        lines += ["Keys that go together:", ""] + [f"- {rule_text(rule)}" for rule in rules] + [""]
    return lines


def scenario_reference_markdown() -> str:
    """The scenario file's keys, section by section, from the JSON Schema `liaison schema` prints."""
    from liaison_cli.scenario.json_schema import LOADER_ONLY_RULES, scenario_json_schema

    schema = scenario_json_schema()
    top_level = {key: value for key, value in schema.items() if key != "description"}  # its rules: listed below
    lines = ["## Top level", ""]
    lines += _model_section("scenario file", top_level, level="")[2:]
    lines += ["Checked by the loader only (`liaison validate FILE`), beyond what a JSON Schema can say:", ""]
    lines += [f"- {rule}" for rule in LOADER_ONLY_RULES] + ["", "## Sections", ""]
    for name, model in schema.get("$defs", {}).items():
        lines += _model_section(name, model)
    return "\n".join(lines).rstrip() + "\n"


# --- observables -----------------------------------------------------------------------------------------


def observables_markdown() -> str:
    """One row per observable of measurements/registry.py: its channels with their units, and what it is."""
    from liaison_cli.measurements.registry import OBSERVABLES

    rows = ["| observable | channels (unit) | what it measures |", "|---|---|---|"]
    for name, observable in OBSERVABLES.items():
        channels = ", ".join(f"{channel.label} ({channel.unit})" for channel in observable.channels)
        rows.append(f"| `{name}` | {_cell(channels)} | {_cell(observable.description)} |")
    return "\n".join(rows) + "\n"


def dynamics_markdown() -> str:
    """One row per dynamics model of dynamics/registry.py: what it is, its epochs and frame, and the parameters
    the filter may estimate (filter.estimated_parameters), each with what it is."""
    from liaison_cli.dynamics.registry import DYNAMICS

    rows = ["| dynamics | model | epochs | frame | estimable parameters |", "|---|---|---|---|---|"]
    for name, model in DYNAMICS.items():
        parameters = "; ".join(f"`{p.name}`: {p.summary}" for p in model.parameters) or "none"
        rows.append(f"| `{name}` | {_cell(model.summary)} | {'dates (TDB)' if model.dated else 'undated'} | "
                    f"{'rotating' if model.rotating_frame else 'inertial (ICRF)'} | {_cell(parameters)} |")
    return "\n".join(rows) + "\n"


# --- mkdocs events ---------------------------------------------------------------------------------------


def on_files(files, config):
    """Add the reference figures (results/reference/**.png|svg) to the site under the same path."""
    from mkdocs.structure.files import File

    for path in sorted((REPO / REFERENCE_DIR).rglob("*")):
        if path.suffix in FIGURE_SUFFIXES:
            files.append(File(path.relative_to(REPO).as_posix(), str(REPO), config["site_dir"],
                              config["use_directory_urls"]))
    return files


def on_page_markdown(markdown, page, config, files):
    if CLI_MARKER in markdown:
        markdown = markdown.replace(CLI_MARKER, cli_reference_markdown())
    if OBSERVABLES_MARKER in markdown:
        markdown = markdown.replace(OBSERVABLES_MARKER, observables_markdown())
    if DYNAMICS_MARKER in markdown:
        markdown = markdown.replace(DYNAMICS_MARKER, dynamics_markdown())
    if SCENARIO_MARKER in markdown:
        markdown = markdown.replace(SCENARIO_MARKER, scenario_reference_markdown())
    return markdown
