"""The shipped scenarios: the papers' scenario files, link files and JSON Schema, package data in
liaison_cli/shipped_scenarios/ (the repository's scenarios/ is a link to that folder, so there is one copy).

The rule, for every command with default scenarios (`sweep` without a scenario, `table3`, `study003`,
`study004`): a default, named relative to the shipped folder ("004/eml2_halo.yaml"), is the installed
package's file, wherever the command runs; a path the user gives is used as given (relative to the working
folder), and wins. A scenarios/ folder in the working folder is not looked at for a default: the package's
copy is the one that matches the code that runs it.

A scenario named on the command line that is no file here is looked up among the shipped ones (shipped_by_name:
`eml2_lunar`, `eml2_lunar.yaml`, `scenarios/eml2_lunar.yaml`, `004/dro`), so what `liaison warm-up --list`
names runs from any folder after `pip install`; a file here always wins, and the run says which it took. A link
file (`liaison budget`, `liaison validate`) is looked up the same way among the shipped links/
(shipped_link_by_name: `links/turan2022_table2.yaml`, `turan2022_table2`).
"""

from importlib.resources import files
from pathlib import Path

from liaison_cli.errors import LiaisonError

SHIPPED_FOLDER = "shipped_scenarios"


def shipped_dir() -> Path:
    """The folder of the shipped scenarios, in the installed package (a regular or an editable install)."""
    root = files("liaison_cli") / SHIPPED_FOLDER
    if not isinstance(root, Path):  # a zipped package: not how pip installs a wheel
        raise LiaisonError(f"{root}: the shipped scenarios are not on the file system; install liaison with pip "
                           "(an unpacked wheel)")
    return root


def shipped_scenario(name: str) -> Path:
    """The shipped file `name` ("eml2_lunar.yaml", "004/dro.yaml"); an error naming it if the install lacks it."""
    path = shipped_dir() / name
    if not path.is_file():
        raise LiaisonError(f"{path}: a shipped scenario is missing from this installation (package data "
                           "liaison_cli/shipped_scenarios); reinstall liaison, or name the scenario files")
    return path


def shipped_by_name(given) -> Path | None:
    """The shipped scenario a name that is no file in the working folder stands for (the module docstring), or
    None: the name relative to the shipped folder, with or without `.yaml` and a leading `scenarios/`."""
    text = str(given).replace("\\", "/")
    if Path(given).exists() or Path(text).is_absolute() or ".." in Path(text).parts:
        return None
    if text.startswith("scenarios/"):
        text = text[len("scenarios/"):]
    try:
        root = shipped_dir()
    except LiaisonError:
        return None
    for candidate in (text, f"{text}.yaml"):
        path = root / candidate
        if candidate.endswith(".yaml") and path.is_file() and "links" not in Path(candidate).parts[:1]:
            return path
    return None


def shipped_link_by_name(given) -> Path | None:
    """The shipped link file (links/) a name that is no file in the working folder stands for, or None: with or
    without `.yaml`, a leading `scenarios/` and `links/`."""
    text = str(given).replace("\\", "/")
    if Path(given).exists() or Path(text).is_absolute() or ".." in Path(text).parts:
        return None
    text = text.removeprefix("scenarios/").removeprefix("links/")
    try:
        root = shipped_dir() / "links"
    except LiaisonError:
        return None
    for candidate in (text, f"{text}.yaml"):
        if candidate.endswith(".yaml") and "/" not in candidate and (root / candidate).is_file():
            return root / candidate
    return None


def shipped_catalogue() -> list[dict]:
    """Every shipped scenario and link file: {"name": what `liaison run` (or `budget`) takes from any folder,
    "kind": "scenario" or "link file", "description": its description (a link file's: its first comment line)},
    scenarios first, by name."""
    import yaml

    root = shipped_dir()
    rows = []
    for path in sorted(root.rglob("*.yaml")):
        relative = path.relative_to(root).as_posix()
        link = relative.startswith("links/")
        text = path.read_text()
        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError:
            data = None
        description = data.get("description", "") if isinstance(data, dict) else ""
        if link and not description:
            description = next((line.lstrip("# ").strip() for line in text.splitlines() if line.startswith("#")), "")
        rows.append({"name": relative.removesuffix(".yaml"), "kind": "link file" if link else "scenario",
                     "description": str(description)})
    return sorted(rows, key=lambda row: (row["kind"] != "scenario", row["name"]))


def scenario_paths(given, defaults) -> list[Path]:
    """The paths the user gave (as given, relative to the working folder), or else the shipped `defaults`."""
    return [Path(p) for p in given] if given else [shipped_scenario(name) for name in defaults]


def scenario_folder(given) -> Path:
    """A folder of scenario files the user gave (as given), or else the shipped folder."""
    return Path(given) if given is not None else shipped_dir()
