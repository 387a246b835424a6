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
