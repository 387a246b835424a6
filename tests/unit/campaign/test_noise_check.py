"""The derived default noise's LinCov check (campaign.engine.noise_check): a truncated lunar field leaves the rule's
default optimistic on some formations and not on others; LinCov says which, the check raises the field's part
until LinCov's err/sigma is the check's target, and the Monte Carlo agrees. An EML2 halo + 80 km, 75 deg orbiter, truth degree 60,
filter 15, range + range-rate every 120 s, 2 d: with the node at 90 deg the rule's default is optimistic (LinCov
err/sigma 2.30, the Monte Carlo's 2.33 +- 0.04 at 60 s); at 30 deg it is pessimistic (0.64) and stays as it is.
The check raises to campaign.engine.noise_check.TARGET_RATIO (1.25)."""

import numpy as np
import pandas as pd
import pytest

from liaison_cli.analysis.consistency import campaign_verdict
from liaison_cli.campaign.engine.noise_check import (CLOSE_ENOUGH, RAISE_PART, TARGET_RATIO, checked_problem,
                                                     lincov_error_to_sigma, prepare_checked_problem)
from liaison_cli.campaign.engine.runner import run_campaign
from liaison_cli.scenario.loading import validate_scenario
from liaison_cli.scenario.setup import prepare_problem


def formation(raan_deg: float, **extra) -> dict:
    return {"name": f"halo_80km_node_{raan_deg:g}", "duration_days": 2.0,
            "spacecraft": [{"name": "EML2", "orbit": "eml2_halo"},
                           {"name": "Lunar", "orbit": "lunar_keplerian",
                            "elements": {"altitude_km": 80, "e": 0.0, "i_deg": 75, "raan_deg": raan_deg}, **extra}],
            "links": [{"receiver": "EML2", "transponder": "Lunar", "observables": ["range", "range_rate"]}],
            "measurement": {"interval_s": 120}, "noise": {"sigma_m": 3.0, "range_rate_sigma_m_s": 0.005},
            "moon_gravity": {"degree": 60, "filter_degree": 15}, "monte_carlo": {"runs": 8, "seed": 1}}


@pytest.fixture(scope="module")
def optimistic():
    return prepare_problem(validate_scenario(formation(90.0), "optimistic"))


def test_an_optimistic_default_is_raised_until_lincov_says_the_target(optimistic):
    before = lincov_error_to_sigma(optimistic)
    assert before["Lunar"] > 2.0 and before["EML2"] < 1.0
    checked = checked_problem(optimistic)
    after = lincov_error_to_sigma(checked)
    assert TARGET_RATIO - 0.03 < after["Lunar"] <= TARGET_RATIO * CLOSE_ENOUGH and after["EML2"] < 1.0
    assert checked_problem(checked) is checked  # checked once: a second check adds nothing
    lunar = checked.default_noises["Lunar"]
    raises = [what for what in lunar.parts if what.startswith(RAISE_PART)]
    assert raises == [f"{RAISE_PART} {before['Lunar']:.2f} -> {after['Lunar']:.2f}"]
    assert lunar.psd_m2_s3 == pytest.approx(sum(lunar.parts.values()), rel=1e-12)
    assert checked.default_noises["EML2"] == optimistic.default_noises["EML2"]  # not optimistic: left alone
    # Q carries it: the orbiter's block scales with its density, the other's does not move
    block = slice(6, 12)
    nonzero = optimistic.Q[block, block] != 0.0
    ratio = checked.Q[block, block][nonzero] / optimistic.Q[block, block][nonzero]
    expected = lunar.psd_m2_s3 / optimistic.default_noises["Lunar"].psd_m2_s3
    assert np.allclose(ratio, expected, rtol=1e-12) and np.all(checked.Q[block, block][~nonzero] == 0.0)
    assert np.array_equal(checked.Q[0:6, 0:6], optimistic.Q[0:6, 0:6])


def test_the_monte_carlo_agrees_with_the_checked_default():
    """Eight runs: the orbiter's err/sigma after the settle time near LinCov's target, inside the verdict's band
    and below the rule's 2.3."""
    result = run_campaign(validate_scenario(formation(90.0), "checked"), jobs=1, progress=False)
    rows = pd.DataFrame([row for outcome in result.outcomes for row in outcome.summary])
    verdict = campaign_verdict(rows[rows.spacecraft == "Lunar"])
    assert 1.0 < verdict["position_error_to_sigma_settled"] < 1.45, verdict
    assert any(what.startswith(RAISE_PART) for what in result.problem.default_noises["Lunar"].parts)


def test_a_pessimistic_default_and_a_users_key_are_left_as_they_are():
    pessimistic = prepare_problem(validate_scenario(formation(30.0), "pessimistic"))
    assert max(lincov_error_to_sigma(pessimistic).values()) < 1.0
    assert checked_problem(pessimistic) is pessimistic
    # The orbiter's own key: no default of its own to raise (the halo's share of its field may be raised)
    spec = validate_scenario(formation(90.0, process_noise_psd_m2_s3=1e-9), "keyed")
    keyed, unchecked = prepare_checked_problem(spec), prepare_problem(spec)
    assert "Lunar" not in keyed.default_noises
    assert np.array_equal(keyed.Q[6:12, 6:12], unchecked.Q[6:12, 6:12])


def test_run_and_errors_say_what_the_check_raised(tmp_path):
    """`liaison errors` (as `run`) prints the default's parts, the raise among them, and the result's provenance
    keeps them."""
    import re

    import yaml

    from liaison_cli.api import provenance
    from tests.conftest import run_cli_in_process

    path = tmp_path / "optimistic.yaml"
    path.write_text(yaml.safe_dump(formation(90.0), sort_keys=False))
    errors = run_cli_in_process("errors", path, "--output", tmp_path / "budget")
    assert errors.returncode == 0, errors.stderr
    line = next(row for row in errors.stdout.splitlines() if row.startswith("process noise: default PSD"))
    assert re.search(rf"{RAISE_PART} 2\.3\d -> 1\.2[56] ", line), line  # from the rule's 2.3 to the target
    run = run_cli_in_process("run", path, "--runs", "2", "--output", tmp_path / "run")
    assert run.returncode == 0, run.stderr
    assert RAISE_PART in run.stdout
    parts = provenance(tmp_path / "run")["chosen_settings"]["default_process_noise"]["Lunar"]["parts_m2_s3"]
    assert any(what.startswith(RAISE_PART) for what in parts)
