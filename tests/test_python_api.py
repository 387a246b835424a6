"""docs/python-api.md: its example is run as written and prints what the page shows (numbers aside), and the
calls the page describes exist with the parameters it names. Measured: about 3 s with the compiled code
cached (the smoke scenario, 2 runs, in this process)."""

import contextlib
import importlib
import inspect
import io
import re

import pytest

from tests.conftest import REPO, SCENARIOS

PAGE = REPO / "docs" / "python-api.md"
NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?")


def _blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", PAGE.read_text(), flags=re.S)


def _shape(text: str) -> list[str]:
    """Lines with every number replaced by N and runs of blanks collapsed: what the page promises."""
    return [" ".join(NUMBER.sub("N", line).split()) for line in text.strip().splitlines()]


def test_the_example_runs_and_prints_what_the_page_shows(tmp_path, monkeypatch):
    (code,) = _blocks("python")  # the page has one runnable example
    (shown,) = _blocks("text")
    monkeypatch.chdir(tmp_path)  # the example names no path relative to the repository
    namespace: dict = {"__name__": "__docs_example__"}
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(compile(code, str(PAGE), "exec"), namespace)
    assert _shape(printed.getvalue()) == _shape(shown), printed.getvalue()
    summary, stored = namespace["summary"], namespace["stored"]
    assert len(summary) == 4 and set(summary["spacecraft"]) == {"EML2", "Lunar"}  # 2 runs x 2 spacecraft
    assert stored.equals(summary)  # the Parquet read back is the DataFrame the campaign gave
    assert [o.run for o in namespace["result"].outcomes] == [0, 1]
    assert not list(tmp_path.iterdir())  # nothing left behind in the working folder


def test_the_calls_the_page_names_exist_with_their_parameters():
    page = PAGE.read_text()
    modules = {
        "liaison_cli.campaign.engine.runner": ["run_campaign"],
        "liaison_cli.campaign.engine.results": ["summary_table", "timeseries_table", "residuals_table",
                                                "consistency_table", "bias_table", "clock_table", "summarise_campaign",
                                                "write_campaign", "stream_campaign"],
        "liaison_cli.scenario.schema": ["load_scenario", "apply_overrides"],
        "liaison_cli.scenario.shipped": ["shipped_scenario"],
        "liaison_cli.storage": ["read_metadata"],
        "liaison_cli.campaign.engine.backends": ["Backend"],
    }
    for module, names in modules.items():
        assert f"`{module}`" in page or f"from {module} import" in page, module
        for name in names:
            assert hasattr(importlib.import_module(module), name), (module, name)
    from liaison_cli.campaign.engine.runner import CampaignResult, run_campaign
    from liaison_cli.campaign.engine.worker import RunOutcome

    from liaison_cli.campaign.engine.backends import LOCAL

    shown = re.search(r"\*\*`run_campaign\((.*?)\)`\*\*", page, flags=re.S).group(1)
    documented = [part.strip().partition("=")[::2] for part in " ".join(shown.split()).split(",")]
    parameters = inspect.signature(run_campaign).parameters.values()
    assert [name for name, _ in documented] == [p.name for p in parameters]
    for (name, default), parameter in zip(documented, parameters):  # each default as the page writes it
        expected = "" if parameter.default is inspect.Parameter.empty else \
            "LOCAL" if parameter.default is LOCAL else repr(parameter.default)
        assert default == expected, (name, default, expected)
    assert {"problem", "outcomes"} <= {f.name for f in CampaignResult.__dataclass_fields__.values()}
    for field in ("run", "status", "reason", "fail_time_s", "summary", "norms", "nees"):
        assert field in RunOutcome.__dataclass_fields__ and f"`{field}`" in page, field


@pytest.mark.parametrize("arguments, fragment", [({"runs": -1}, "runs: -1"), ({"runs": 0}, "runs: 0"),
                                                 ({"runs": 2.5}, "runs: 2.5"), ({"jobs": 0}, "jobs: 0"),
                                                 ({"runs": True}, "runs: True")])
def test_run_campaign_refuses_a_count_the_cli_would_refuse(arguments, fragment):
    """The API answers as the CLI does (issue 47: runs=-1 returned an empty result): one LiaisonError naming the
    argument, its value and what is allowed, before anything runs."""
    from liaison_cli.campaign.engine.runner import run_campaign
    from liaison_cli.errors import LiaisonError
    from liaison_cli.scenario.schema import load_scenario

    scenario = load_scenario(SCENARIOS / "smoke.yaml")[0]
    with pytest.raises(LiaisonError, match="allowed: a whole number, 1 or more") as refused:
        run_campaign(scenario, progress=False, **arguments)
    assert fragment in str(refused.value)


def test_run_campaign_refuses_a_path_for_a_scenario_in_one_line():
    from liaison_cli.campaign.engine.runner import run_campaign
    from liaison_cli.errors import LiaisonError

    with pytest.raises(LiaisonError, match="scenario: str given; allowed: a Scenario"):
        run_campaign(str(SCENARIOS / "smoke.yaml"))


# --- liaison_cli.api: the stable entry point ------------------------------------------------------------------------

# The contract: these names with these parameters and defaults. A change here is a change of the major version.
API_SIGNATURES = {
    "load": "(scenario, overrides: collections.abc.Mapping | None = None)",
    "run": "(scenario, runs: int | None = None, jobs: int = 1, progress: bool = False)",
    "run_to_folder": "(scenario, output, runs: int | None = None, jobs: int = 2, overwrite: bool = False, "
                     "progress: bool = False) -> pathlib.Path",
    "write": "(result, folder, overwrite: bool = False) -> pathlib.Path",
    "summary": "(result)",
    "timeseries": "(result)",
    "read_table": "(folder, table: str = 'summary')",
    "provenance": "(folder, table: str = 'summary') -> dict",
    "sweep": "(scenarios, grid: collections.abc.Mapping, output, runs: int = 10, jobs: int = 2, name: str | None = None, "
             "overwrite: bool = False, progress: bool = False)",
    "export": "(result_folder, run: int = 0, output=None, formats: collections.abc.Sequence[str] = ('kvn',), "
              "frame: str | None = None, epoch: str | None = None, centre: str = 'earth', overwrite: bool = False) "
              "-> list[pathlib.Path]",
}


def test_the_api_keeps_its_names_and_signatures_and_the_page_lists_them():
    from liaison_cli import api

    assert sorted(api.__all__) == sorted([*API_SIGNATURES, "ArgumentError"])
    page = PAGE.read_text()
    for name, signature in API_SIGNATURES.items():
        assert str(inspect.signature(getattr(api, name))) == signature, name
        assert f"`{name}(" in page, name


@pytest.mark.parametrize("call, fragment", [
    (lambda api, s: api.run(s, runs=-1), "runs: -1 (int); allowed: a whole number, 1 or more"),
    (lambda api, s: api.run(s, runs="3"), "runs: '3' (str); allowed: a whole number"),
    (lambda api, s: api.run(s, progress=1), "progress: 1 (int); allowed: True or False"),
    (lambda api, s: api.run(42), "scenario: int given; allowed: a Scenario"),
    (lambda api, s: api.load(3.5), "scenario: 3.5 (float); allowed: a path"),
    (lambda api, s: api.load("smoke", ["noise.sigma_m"]), "overrides: ['noise.sigma_m'] (list); allowed: a mapping"),
    (lambda api, s: api.sweep(s, {"noise.sigma_m": [1]}, output="x"), "scenarios: Scenario(name='smoke'"),
    (lambda api, s: api.sweep([s], {"noise.sigma_m": 100}, output="x"), "grid: {'noise.sigma_m': 100} (dict)"),
    (lambda api, s: api.export("x", run=True), "run: True (bool); allowed: a whole number, 0 or more"),
    (lambda api, s: api.export("x", formats=("pdf",)), "formats: ('pdf',) (tuple); allowed: a list of some of kvn, xml"),
    (lambda api, s: api.export("x", epoch="tomorrow", frame="icrf"), "epoch: 'tomorrow' (str); allowed: a TDB date"),
    (lambda api, s: api.summary([]), "result: list given; allowed: what api.run returns"),
    (lambda api, s: api.export("x", formats=5), "formats: 5 (int); allowed: a list of some of kvn, xml"),
    (lambda api, s: api.export("x", epoch="2030-01-01T25:00:00", frame="icrf"), "epoch: '2030-01-01T25:00:00'"),
    (lambda api, s: api.sweep([s], {"noise.sigma_m": [1]}, output="x", name="../up"), "name: '../up' (str)"),
    (lambda api, s: api.read_table(".", "../x"), "table: '../x' (str); allowed: the stem of a Parquet file"),
])
def test_a_wrong_argument_is_one_typed_line_before_any_work(call, fragment, tmp_path, monkeypatch):
    """issue 47: the API took runs=-1 (an empty result) and answered wrong types with AttributeError. Each refusal
    is an ArgumentError (a LiaisonError, ValueError and TypeError) of one line naming the argument, the value (cut
    to 60 characters) and what is allowed; nothing is written."""
    from liaison_cli import api
    from liaison_cli.errors import LiaisonError

    monkeypatch.chdir(tmp_path)
    scenario = api.load(SCENARIOS / "smoke.yaml")
    with pytest.raises(api.ArgumentError) as refused:
        call(api, scenario)
    message = str(refused.value)
    assert fragment in message and "\n" not in message and len(message) < 300, message
    assert isinstance(refused.value, (LiaisonError, ValueError, TypeError))
    assert not list(tmp_path.iterdir())


def test_the_api_runs_sweeps_and_exports_as_the_commands_do(tmp_path):
    """run_to_folder writes the folder `liaison run` writes (the same summary as the in-memory run of the same
    scenario), sweep gives the curve the folder holds, export writes the CCSDS files of a run; the same numbers by
    any path (the runs depend on the seed and the run index alone)."""
    import pandas as pd

    from liaison_cli import api

    scenario = api.load("smoke", {"duration_days": 0.5, "monte_carlo.runs": 2})
    folder = api.run_to_folder(scenario, tmp_path / "run", jobs=1)
    in_memory = api.summary(api.run(scenario))
    on_disk = api.read_table(folder)
    pd.testing.assert_series_equal(on_disk["rms_position_m"], in_memory["rms_position_m"])
    assert api.provenance(folder)["scenario_effective"]["duration_days"] == 0.5
    curve = api.sweep([scenario], {"noise.sigma_m": [150, 300]}, tmp_path / "sweep", runs=2, jobs=1)
    assert list(curve["noise.sigma_m"].unique()) == [150, 300]
    assert curve.equals(api.read_table(tmp_path / "sweep", "curve"))
    files = api.export(folder, run=1, formats=("kvn", "xml"))
    assert {path.name for path in files} >= {"EML2_estimate.oem", "Lunar_truth.oem.xml", "measurements.tdm"}
    assert all(path.is_file() and path.parent == folder / "ccsds-run1" for path in files)
