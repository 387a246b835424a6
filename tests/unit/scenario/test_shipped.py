"""The shipped scenarios are package data (scenario.shipped): the paper commands' defaults resolve to the
installed package's files from any working folder, a path the user gives wins, and a scenarios/ folder in
the working folder is not taken for a default. The repository's scenarios/ is the package's folder (one copy)."""

from pathlib import Path

import pytest
from typer.testing import CliRunner

from liaison_cli.campaign.studies.table3 import FORMATIONS
from liaison_cli.cli import app
from liaison_cli.cli.studies import STUDY003_MISSIONS, STUDY004_TRANSMITTERS
from liaison_cli.cli.sweep import PAPER_FORMATIONS
from liaison_cli.errors import LiaisonError
from liaison_cli.scenario.loading import load_scenario
from liaison_cli.scenario.shipped import scenario_folder, scenario_paths, shipped_dir, shipped_scenario
from tests.conftest import SCENARIOS, stderr_lines

DEFAULTS = [*STUDY003_MISSIONS, *STUDY004_TRANSMITTERS, *(f"{f}.yaml" for f in {*PAPER_FORMATIONS, *FORMATIONS})]


@pytest.fixture
def elsewhere(tmp_path, monkeypatch):
    """An empty working folder outside the repository, with a decoy scenarios/ that a default must not take."""
    monkeypatch.chdir(tmp_path)
    for name in DEFAULTS:
        decoy = tmp_path / "scenarios" / name
        decoy.parent.mkdir(parents=True, exist_ok=True)
        decoy.write_text("not: a scenario\n")
    return tmp_path


def test_the_repository_scenarios_folder_is_the_shipped_one():
    """One copy: scenarios/ at the repository root is a link to the package's folder, not a second set."""
    assert SCENARIOS.is_symlink() and SCENARIOS.resolve() == shipped_dir().resolve()
    assert (shipped_dir() / "liaison-scenario.schema.json").is_file()
    assert sorted((shipped_dir() / "links").glob("*.yaml"))


def test_the_defaults_resolve_to_the_package_from_any_folder(elsewhere):
    paths = scenario_paths(None, STUDY004_TRANSMITTERS) + scenario_paths([], STUDY003_MISSIONS)
    paths += [scenario_folder(None) / f"{f}.yaml" for f in PAPER_FORMATIONS]
    assert len(paths) == 9
    for path in paths:
        assert path.is_absolute() and path.is_file(), path
        assert path.resolve().is_relative_to(shipped_dir().resolve()), path
        assert not path.resolve().is_relative_to(elsewhere.resolve()), path  # not the decoy
        load_scenario(path)  # a valid scenario


def test_a_path_the_user_gives_wins(elsewhere):
    mine = elsewhere / "mine.yaml"
    mine.write_text((SCENARIOS / "004" / "dro.yaml").read_text())
    assert scenario_paths(["mine.yaml"], STUDY004_TRANSMITTERS) == [mine.relative_to(elsewhere)]
    assert scenario_paths(["mine.yaml"], STUDY004_TRANSMITTERS)[0].resolve() == mine.resolve()
    assert scenario_folder("scenarios") == Path("scenarios")  # the decoy, when named


def test_a_missing_shipped_file_is_named():
    with pytest.raises(LiaisonError, match="no_such.yaml: a shipped scenario is missing"):
        shipped_scenario("004/no_such.yaml")


def _cli(*args):
    result = CliRunner().invoke(app, [str(a) for a in args])
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    return result


def test_sweep_loads_the_shipped_formations_from_an_empty_folder(elsewhere):
    """`liaison sweep --sigma ...` outside the repository: its three default files load (the refused --name is
    checked only after loading them, so this runs no campaign); --scenarios DIR wins over them."""
    result = _cli("sweep", "--sigma", "100", "--runs", "1", "--name", "../x")
    assert result.exit_code == 2 and stderr_lines(result.stderr)[-1].startswith("error: --name '../x'"), result.stderr
    result = _cli("sweep", "--sigma", "100", "--runs", "1", "--name", "../x", "--scenarios", "scenarios")
    assert result.exit_code == 2 and "scenarios/eml2_lunar.yaml" in result.stderr, result.stderr  # the decoy
    assert "--name" not in result.stderr
    assert not (elsewhere / "results").exists()
