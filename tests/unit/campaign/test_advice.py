"""Advice in the verdict (campaign.advice): each pattern the tool can tell apart names its cause and the scenario
key that changes it; end to end, the headline scenario's paper range model is named by its run text."""

from liaison_cli.campaign.advice import campaign_advice
from liaison_cli.report.run_text import CONSISTENCY_COLUMNS
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from tests.conftest import SCENARIOS, run_cli_in_process


def _rows(in_band, above, ratio=1.0, shift=1.0, total=12.0, status="ok", runs=4):
    """Summary rows of `runs` runs for the two spacecraft of eml2_lunar, every run alike."""
    rows = []
    for run in range(runs):
        for name in ("EML2", "Lunar"):
            rows.append({"run": run, "spacecraft": name, "status": status,
                         "rms_position_settled_m": ratio * (100.0 + run), "sigma_position_settled_m": 100.0 + run,
                         "rms_velocity_settled_m_s": ratio * 1e-3, "sigma_velocity_settled_m_s": 1e-3,
                         "frac_nees_in_band_settled": in_band, "frac_nees_above_band_settled": above,
                         "frac_nees_spacecraft_in_band_settled": in_band,
                         "frac_nees_spacecraft_above_band_settled": above,
                         "time_shift_nees_settled": shift, "mean_nees_settled": total})
    return rows


def _scenario(**overrides):
    scenario = load_scenario(SCENARIOS / "eml2_lunar.yaml")[0]
    return apply_overrides(scenario, overrides) if overrides else scenario


def _advice(scenario, rows):
    return campaign_advice(scenario, rows, ["EML2", "Lunar"], CONSISTENCY_COLUMNS)


def test_a_consistent_campaign_gets_no_advice():
    assert _advice(_scenario(), _rows(0.95, 0.03)) == []


def test_pessimistic_names_the_process_noise_in_force_and_tune():
    scenario = _scenario()
    key, value = scenario.filter.process_noise_of(scenario.spacecraft[0])  # the scenario's own key and value
    (advice,) = _advice(scenario, _rows(0.40, 0.01, ratio=0.5))
    assert advice.cause == "pessimistic"
    assert f"lower filter.{key} (now {value:g})" in advice.text and "liaison tune" in advice.text


def test_optimistic_along_the_time_shift_names_the_light_time_range_model():
    scenario = _scenario(**{"filter.range_model": "geometric"})
    (advice,) = _advice(scenario, _rows(0.30, 0.70, ratio=1.2, shift=45.0, total=50.0))
    assert advice.cause == "time_shift" and "filter.range_model: light_time" in advice.text


def test_optimistic_elsewhere_names_more_process_noise():
    scenario = _scenario(**{"filter.range_model": "light_time"})  # the time shift cannot be the range model's
    (advice,) = _advice(scenario, _rows(0.30, 0.70, ratio=1.8, shift=45.0, total=50.0))
    assert advice.cause == "optimistic" and "raise filter." in advice.text


def test_runs_diverged_under_a_declared_force_name_it_and_the_empirical_acceleration():
    scenario = _scenario(**{"model_error.truth_acceleration_m_s2": [1e-8, 0.0, 0.0]})
    rows = _rows(0.95, 0.03) + [{**row, "run": 9, "status": "diverged"} for row in _rows(0.95, 0.03, runs=1)]
    (advice,) = _advice(scenario, rows)
    assert advice.cause == "diverged_unmodelled_force"
    assert "model_error.truth_acceleration_m_s2" in advice.text and "filter.empirical_acceleration" in advice.text
    assert advice.text.startswith("1 run(s) diverged")


def test_a_batch_is_not_told_about_process_noise_it_does_not_have():
    scenario = load_scenario(SCENARIOS / "nrho_earth_station.yaml")[0]
    names = [sc.name for sc in scenario.spacecraft if sc.role == "estimated"]
    rows = [{**row, "spacecraft": names[0]} for row in _rows(0.40, 0.01, ratio=0.3) if row["spacecraft"] == "EML2"]
    assert campaign_advice(scenario, rows, names[:1], CONSISTENCY_COLUMNS) == []


def test_the_headline_scenario_is_told_to_fly_the_light_time_range_model(tmp_path):
    """eml2_lunar keeps Turan et al.'s geometric range model against a light-time truth: its run text says the
    estimate lags the truth along the common time shift, and its advice names the key that removes the lag."""
    proc = run_cli_in_process("run", SCENARIOS / "eml2_lunar.yaml", "--runs", "2", "--jobs", "1", "--output",
                              tmp_path / "out")
    assert proc.returncode == 0, proc.stderr
    lines = [line for line in proc.stdout.splitlines() if line.startswith("advice: ")]
    assert any("filter.range_model: light_time" in line for line in lines), proc.stdout


def test_a_fixed_step_short_of_the_tolerance_is_named_before_more_process_noise(tmp_path):
    """A 100 km lunar orbit at 600 s with the former fixed 4 substeps: every run diverges, and the advice names
    filter.rk4_substeps with the count the tolerance asks (not the process noise); without the key the same
    formation is consistent."""
    text = "\n".join([
        "name: fixed_step", "duration_days: 6",
        "spacecraft:", "  - {name: DRO, orbit: dro, period_days: 14.0}",
        "  - name: LLO", "    orbit: lunar_keplerian",
        "    elements: {a_km: 1837.4, e: 0.0, i_deg: 90, raan_deg: 30, argp_deg: 0, ta_deg: 0}",
        "links:", "  - {receiver: DRO, transponder: LLO, observables: [range, range_rate]}",
        "measurement: {interval_s: 600}", "noise: {sigma_m: 5.0, range_rate_sigma_m_s: 0.001}",
        "monte_carlo: {runs: 4, seed: 11}", ""])
    fixed = tmp_path / "fixed_step.yaml"
    fixed.write_text(text + "filter: {rk4_substeps: 4}\n")
    proc = run_cli_in_process("run", fixed, "--jobs", "1", "--output", tmp_path / "fixed")
    advice = [line for line in proc.stdout.splitlines() if line.startswith("advice: ")]
    assert "0/4 runs ok" in proc.stdout
    assert len(advice) == 1 and "integration step is too long for LLO (needs" in advice[0]
    assert "remove filter.rk4_substeps" in advice[0]
    chosen = tmp_path / "chosen.yaml"
    chosen.write_text(text)
    proc = run_cli_in_process("run", chosen, "--jobs", "1", "--output", tmp_path / "chosen")
    assert proc.returncode == 0 and "4/4 runs ok" in proc.stdout and "advice: " not in proc.stdout
