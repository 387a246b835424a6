"""`liaison design` (issue 48): candidates scored by LinCov through the fan-out, ranked, the best verified by
Monte Carlo; the same table on one core and two; bad options refused in one line."""

import pandas as pd
import pytest
import yaml

from liaison_cli.campaign.studies.design import Design, Candidate, candidate_mapping, parse_periods
from liaison_cli.errors import LiaisonError
from tests.conftest import run_cli_in_process

BASE = {"name": "relay_design", "duration_days": 2.0,
        "spacecraft": [{"name": "Relay", "orbit": "dro", "period_days": 12.0, "apriori_sigma_position_m": 800.0},
                       {"name": "User", "orbit": "lunar_keplerian",
                        "elements": {"a_km": 3000, "e": 0.1, "i_deg": 60, "raan_deg": 0, "argp_deg": 0, "ta_deg": 0}}],
        "links": [{"receiver": "Relay", "transponder": "User", "observables": ["range"]}],
        "measurement": {"interval_s": 600}, "noise": {"sigma_m": 10.0}, "monte_carlo": {"runs": 4, "seed": 3}}


@pytest.fixture
def base(tmp_path):
    path = tmp_path / "base.yaml"
    path.write_text(yaml.safe_dump(BASE, sort_keys=False))
    return path


def _design(base, out, jobs, *extra):
    return run_cli_in_process("design", base, "--open", "Relay", "--family", "dro", "--periods", "5:11:3",
                              "--phases", "2", "--objective", "User", "--jobs", jobs, "--output", out, *extra)


def test_design_ranks_every_candidate_verifies_the_best_and_is_the_same_on_two_cores(base, tmp_path):
    one = _design(base, tmp_path / "one", 1, "--verify", "3", "--runs", "4", "--condition")
    assert one.returncode == 0, one.stderr
    table = pd.read_parquet(tmp_path / "one" / "candidates.parquet")
    assert len(table) == 6 and (table.error == "").all()
    assert list(table["rank"]) == list(range(1, 7)) and table.score_m.is_monotonic_increasing
    assert set(table.phase) == {0.0, 0.5} and set(table.period_days) == {5.0, 8.0, 11.0}
    verified = table[table.mc_score_m.notna()]
    assert list(verified["rank"]) == [1, 2, 3]  # the best three, by Monte Carlo
    assert ((verified.mc_over_lincov > 0.3) & (verified.mc_over_lincov < 3.0)).all()  # 4 runs: a loose check
    assert (tmp_path / "one" / "design.png").stat().st_size > 0
    ranking = (tmp_path / "one" / "ranking.md").read_text()
    assert "Spearman rank correlation" in ranking and "range condition number against LinCov" in ranking
    # Each candidate's condition number is `liaison observability`'s on that candidate's scenario.
    from liaison_cli.campaign.studies.observability_study import observability_study
    from liaison_cli.scenario.loading import validate_scenario

    design = Design(BASE, "Relay", "User", (Candidate(0, "dro", 5.0, 0.0), Candidate(1, "dro", 11.0, 0.5)))
    for candidate in design.candidates:
        study = observability_study(validate_scenario(candidate_mapping(design, candidate), "c"), taylor=False)
        row = table[(table.period_days == candidate.period_days) & (table.phase == candidate.phase)].iloc[0]
        assert row.range_condition_number == pytest.approx(
            study.summary["observables"]["range"]["condition_number"], rel=1e-6)
    # The Pareto front of score and condition number, checked by brute force; drawn and listed.
    for row in table.itertuples():
        beaten = table[(table.score_m <= row.score_m) & (table.range_condition_number <= row.range_condition_number)
                       & ((table.score_m < row.score_m) | (table.range_condition_number < row.range_condition_number))]
        assert row.pareto == beaten.empty, row
    assert table.pareto.any() and (tmp_path / "one" / "pareto.png").stat().st_size > 0
    assert f"Pareto front of the LinCov User RMS and the range condition number ({table.pareto.sum()} of 6" in ranking
    two = _design(base, tmp_path / "two", 2, "--verify", "0")  # no --condition: no condition numbers
    assert two.returncode == 0, two.stderr
    again = pd.read_parquet(tmp_path / "two" / "candidates.parquet")
    pd.testing.assert_series_equal(table.score_m, again.score_m)  # jobs and batches do not move a number
    pd.testing.assert_series_equal(table.candidate, again.candidate)
    assert again.range_condition_number.isna().all() and "range condition number against" not in \
        (tmp_path / "two" / "ranking.md").read_text()
    assert not again.pareto.any() and not (tmp_path / "two" / "pareto.png").exists()


def test_the_condition_number_as_the_objective_ranks_by_it(base, tmp_path):
    """--objective condition: ranked by the range condition number, smallest first, with the worst spacecraft's
    LinCov error as the score beside it; the condition numbers are computed without --condition."""
    proc = run_cli_in_process("design", base, "--open", "Relay", "--family", "dro", "--periods", "5:11:3",
                              "--objective", "condition", "--verify", "0", "--jobs", "1", "--output", tmp_path / "c")
    assert proc.returncode == 0, proc.stderr
    table = pd.read_parquet(tmp_path / "c" / "candidates.parquet")
    assert list(table["rank"]) == [1, 2, 3] and table.range_condition_number.is_monotonic_increasing
    worst = table[["Relay_rms_position_m", "User_rms_position_m"]].max(axis=1)
    pd.testing.assert_series_equal(table.score_m, worst, check_names=False)
    assert "ranked by the range information condition number" in proc.stdout and "LinCov worst RMS m" in proc.stdout


@pytest.mark.parametrize("option, value, fragment", [
    ("--open", "Nobody", "--open 'Nobody': not a spacecraft"),
    ("--family", "moon_hole", "--family 'moon_hole': allowed: dro"),
    ("--periods", "8-14", "--periods '8-14': allowed LOW:HIGH:COUNT"),
    ("--objective", "Nobody", "--objective 'Nobody': allowed: Relay, User, worst, mean, condition"),
])
def test_bad_design_options_are_one_line(base, tmp_path, option, value, fragment):
    args = {"--open": "Relay", "--family": "dro", "--periods": "5:11:3", "--objective": "User", option: value}
    proc = run_cli_in_process("design", base, *[x for pair in args.items() for x in pair], "--output",
                              tmp_path / "out")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr
    assert fragment in proc.stderr and len([l for l in proc.stderr.splitlines() if l.strip()]) == 1, proc.stderr


def test_a_candidate_keeps_what_the_spacecraft_says_besides_its_orbit():
    design = Design(BASE, "Relay", "User", ())
    mapping = candidate_mapping(design, Candidate(4, "l2_lyapunov", 20.0, 0.25))
    relay = mapping["spacecraft"][0]
    assert relay == {"name": "Relay", "apriori_sigma_position_m": 800.0, "orbit": "l2_lyapunov", "period_days": 20.0,
                     "phase": 0.25}
    assert BASE["spacecraft"][0]["orbit"] == "dro"  # the base is not touched
    assert parse_periods("6.2:8:10") == (6.2, 8.0, 10)
    for text in ("8:6:3", "6:8:0", "6:6:3", "6:8"):
        with pytest.raises(LiaisonError):
            parse_periods(text)


def test_an_interrupted_search_resumes_its_missing_candidates_and_writes_the_same_table(base, tmp_path, monkeypatch,
                                                                                      sigint_kept):
    """Six candidates in six batches on one core, Ctrl-C after the second: exit 130 naming the work folder; the same
    command again scores only the four missing, and its table equals an uninterrupted search's (the stored rows read
    back with their types); a damaged batch file is noted and scored again."""
    from liaison_cli.campaign.studies import design

    whole = _design(base, tmp_path / "whole", 1, "--verify", "0")
    assert whole.returncode == 0, whole.stderr
    original, scored = design.score_batch, []

    def interrupted_after_two(plan, tasks):
        if len(scored) == 2:
            raise KeyboardInterrupt
        scored.append(tasks)
        return original(plan, tasks)

    monkeypatch.setattr(design, "score_batch", interrupted_after_two)
    cut = _design(base, tmp_path / "cut", 1, "--verify", "0")
    assert cut.returncode == 130 and f"2 of 6 candidate batches saved in {tmp_path / 'cut.work'}" in cut.stderr
    assert not (tmp_path / "cut").exists()
    saved = sorted((tmp_path / "cut.work").glob("design-*.json"))
    assert len(saved) == 2
    saved[0].write_text("{not json")  # damaged: scored again, with a note

    def counted(plan, tasks):
        scored.append(tasks)
        return original(plan, tasks)

    scored.clear()
    monkeypatch.setattr(design, "score_batch", counted)
    again = _design(base, tmp_path / "cut", 1, "--verify", "0")
    assert again.returncode == 0, again.stderr
    assert len(scored) == 5 and "damaged; its candidates are scored again" in again.stderr
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "cut" / "candidates.parquet"),
                                  pd.read_parquet(tmp_path / "whole" / "candidates.parquet"))


def test_other_factors_vary_alone_or_with_the_family(base, tmp_path):
    """--vary: any scenario value by dotted path is a factor of the candidates (a lunar orbit's altitude and
    inclination, a link's noise), full factorial, alone or times the family's members; each candidate's values are
    columns and the scenario it scores has them (its LinCov error moves with them); a key the scenario lacks, or no
    factor at all, is one line."""
    lunar = ("--vary", "spacecraft.1.elements.a_km=2500,4000", "--vary", "spacecraft.1.elements.i_deg=30,90")
    alone = run_cli_in_process("design", base, *lunar, "--objective", "User", "--verify", "0", "--jobs", "1",
                               "--condition", "--output", tmp_path / "alone")
    assert alone.returncode == 0, alone.stderr
    table = pd.read_parquet(tmp_path / "alone" / "candidates.parquet")
    assert len(table) == 4 and (table.error == "").all() and (table.family == "").all()
    assert sorted(zip(table["spacecraft.1.elements.a_km"], table["spacecraft.1.elements.i_deg"])) == [
        (2500, 30), (2500, 90), (4000, 30), (4000, 90)]
    assert table.score_m.nunique() == 4  # every candidate scored its own orbit
    assert table.range_condition_number.notna().all()  # --condition holds without a family too
    assert "spacecraft.1.elements.a_km | spacecraft.1.elements.i_deg |" in alone.stdout
    both = _design(base, tmp_path / "both", 1, "--verify", "0", "--vary", "noise.sigma_m=5,20")
    assert both.returncode == 0, both.stderr
    grid = pd.read_parquet(tmp_path / "both" / "candidates.parquet")
    assert len(grid) == 12 and set(grid["noise.sigma_m"]) == {5, 20}
    for _, pair in grid.groupby(["period_days", "phase"]):  # more noise, more error, member by member
        noisy = pair.set_index("noise.sigma_m").score_m
        assert noisy[20] > noisy[5]
    for args, fragment in ((["--vary", "noise.nothing.here=1,2"], "--vary noise.nothing.here: the scenario has no "
                                                                  "'noise.nothing'"),
                           ([], "design: nothing varies")):
        refused = run_cli_in_process("design", base, *args, "--output", tmp_path / "refused")
        assert refused.returncode == 2 and fragment in refused.stderr, refused.stderr
        assert len([line for line in refused.stderr.splitlines() if line.strip()]) == 1


CHOICES = {"user": {"near": {"spacecraft.1.elements": {"a_km": 2500, "e": 0.1, "i_deg": 60, "raan_deg": 0,
                                                       "argp_deg": 0, "ta_deg": 0}},
                    "far": {"spacecraft.1": {"name": "User", "orbit": "lunar_keplerian",
                                             "elements": {"a_km": 4000, "e": 0.1, "i_deg": 90, "raan_deg": 0,
                                                          "argp_deg": 0, "ta_deg": 0}}}},
           "link": {"range": {"links": [{"receiver": "Relay", "transponder": "User", "observables": ["range"]}]},
                    "range_rate": {"links": [{"receiver": "Relay", "transponder": "User",
                                              "observables": ["range_rate"]}],
                                   "noise.range_rate_sigma_m_s": 0.001}}}


def test_choices_set_several_values_at_once_and_score_as_the_same_scenario_would(base, tmp_path):
    """--choices: each option sets several values together (a whole spacecraft, a link list and its noise); the
    options' labels are columns, every combination is a candidate, and each candidate's score equals the score of
    the same scenario reached another way (--vary); the mean objective is the mean of the spacecraft's RMS."""
    choices = tmp_path / "choices.yaml"
    choices.write_text(yaml.safe_dump(CHOICES, sort_keys=False))
    picked = run_cli_in_process("design", base, "--choices", choices, "--objective", "mean", "--verify", "1",
                                "--runs", "3", "--jobs", "1", "--output", tmp_path / "picked")
    assert picked.returncode == 0, picked.stderr
    table = pd.read_parquet(tmp_path / "picked" / "candidates.parquet")
    assert len(table) == 4 and (table.error == "").all(), table.error
    assert sorted(zip(table.user, table.link)) == [("far", "range"), ("far", "range_rate"), ("near", "range"),
                                                   ("near", "range_rate")]
    assert "| user | link |" in picked.stdout
    assert list(table.score_m) == pytest.approx(list((table.Relay_rms_position_m + table.User_rms_position_m) / 2),
                                                rel=1e-12)
    verified = table[table.mc_score_m.notna()].iloc[0]
    assert verified.mc_score_m == pytest.approx((verified.mc_Relay_rms_position_m + verified.mc_User_rms_position_m)
                                                / 2, rel=1e-12)
    same = run_cli_in_process("design", base, "--vary", "spacecraft.1.elements.a_km=4000", "--vary",
                              "spacecraft.1.elements.i_deg=90", "--objective", "mean", "--verify", "0", "--jobs", "1",
                              "--output", tmp_path / "same")
    assert same.returncode == 0, same.stderr
    far_range = table[(table.user == "far") & (table.link == "range")].score_m.iloc[0]
    assert pd.read_parquet(tmp_path / "same" / "candidates.parquet").score_m.iloc[0] == far_range
    assert table[table.link == "range_rate"].score_m.min() != table[table.link == "range"].score_m.min()


@pytest.mark.parametrize("content, fragment", [
    ("[1, 2]", "not a choices file; allowed: a mapping of factor names"),
    ("user: {near: 5}", "user.near: allowed: a mapping"),
    ("user: {near: {noise.nothing.here: 1}}", "choice user.near: noise.nothing.here: the scenario has no "
                                               "'noise.nothing'"),
    ("score_m: {a: {noise.sigma_m: 1}}", "design factor 'score_m': a column of the table already has that name"),
])
def test_a_bad_choices_file_is_one_line(base, tmp_path, content, fragment):
    choices = tmp_path / "choices.yaml"
    choices.write_text(content)
    proc = run_cli_in_process("design", base, "--choices", choices, "--output", tmp_path / "out")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr
    assert fragment in proc.stderr and len([l for l in proc.stderr.splitlines() if l.strip()]) == 1, proc.stderr
    missing = run_cli_in_process("design", base, "--choices", tmp_path / "none.yaml", "--output", tmp_path / "out")
    assert missing.returncode != 0 and "none.yaml" in missing.stderr and "Traceback" not in missing.stderr


def test_ranked_by_the_day_the_error_falls_below_a_threshold(base, tmp_path):
    """--converge-below M: the day from which the objective's LinCov position error stays below M, ranked by it
    (the RMS breaking ties), never = inf and last; the day is where the per-epoch error last crosses M."""
    import math

    import numpy as np

    from liaison_cli.campaign.studies.design import converge_day

    times = np.arange(5) * 86400.0
    assert converge_day(times, np.array([9, 4, 9, 1, 1.0]), 2.5) == 3.0
    assert converge_day(times, np.array([1, 1, 1, 1, 1.0]), 2.5) == 0.0
    assert converge_day(times, np.array([1, 1, 1, 1, 9.0]), 2.5) == math.inf
    proc = _design(base, tmp_path / "day", 1, "--verify", "0", "--converge-below", "2000")
    assert proc.returncode == 0, proc.stderr
    table = pd.read_parquet(tmp_path / "day" / "candidates.parquet")
    days = table.converge_days.to_numpy()
    assert (np.diff(days[np.isfinite(days)]) >= 0).all() and np.isfinite(days[0])
    assert "below 2000 m from (d)" in proc.stdout
    refused = _design(base, tmp_path / "no", 1, "--converge-below", "-3")
    assert refused.returncode == 2 and "--converge-below -3.0: allowed" in refused.stderr, refused.stderr


def test_a_changed_factor_never_reuses_stored_rows():
    """The work folder's key covers each candidate's --vary values and choices, not only its orbit."""
    from liaison_cli.campaign.studies.design import DesignStore, make_design

    keys = {DesignStore("w", make_design(BASE, None, "User", None, None, 1, factors=[("noise.sigma_m", values)]),
                        1).key for values in ([5, 20], [6, 20])}
    keys |= {DesignStore("w", make_design(BASE, None, "User", None, None, 1, choices=[("f", [("a", (key,))])]),
                         1).key for key in (("noise.sigma_m", 5), ("noise.sigma_m", 6))}
    assert len(keys) == 4


def test_a_candidate_row_has_each_direction_and_each_links_visibility():
    """Per spacecraft, the LinCov error and the filter sigma RMS per axis (their squares sum to the position's);
    per link, the share of epochs it measures (a crosslink occulted by the Moon part of the time)."""
    from liaison_cli.campaign.studies.design import make_design, score_candidate

    design = make_design(BASE, None, "User", None, None, 1, factors=[("noise.sigma_m", [10.0])])
    row = score_candidate(design, design.candidates[0])
    assert row["error"] == ""
    for name in ("Relay", "User"):
        for kind in ("rms", "sigma"):
            axes = [row[f"{name}_{kind}_{axis}_m"] for axis in "xyz"]
            assert sum(a * a for a in axes) == pytest.approx(row[f"{name}_{kind}_position_m"] ** 2, rel=1e-9)
            assert min(axes) > 0
    assert 0.0 < row["visible Relay->User"] <= 1.0


def test_a_choice_that_renames_a_spacecraft_is_checked_against_the_open_one_and_the_objective(tmp_path):
    """The names --open and --objective take are the ones every candidate has: a choice renaming the open
    spacecraft is refused in one line (never a family silently not applied), and a name every option gives is
    allowed; a label or key the file cannot mean is one line too."""
    from liaison_cli.campaign.studies.design import candidate_mapping, make_design, read_choices

    renamed = [("relay", [("big", (("spacecraft.0", {"name": "TX", "orbit": "dro", "period_days": 15.0}),)),
                          ("small", (("spacecraft.0", {"name": "TX", "orbit": "dro", "period_days": 9.0}),))])]
    with pytest.raises(LiaisonError, match="--open 'Relay': not a spacecraft of the scenario .of every candidate."):
        make_design(BASE, "Relay", "User", "dro", "5:11:3", 1, choices=renamed)
    design = make_design(BASE, "TX", "TX", "dro", "5:11:3", 1, choices=renamed)  # every candidate has TX
    mapping = candidate_mapping(design, design.candidates[0])
    assert mapping["spacecraft"][0]["period_days"] == design.candidates[0].period_days == 5.0
    one_renames = [("user", [("same", (("spacecraft.1.elements.a_km", 2500),)),
                             ("renamed", (("spacecraft.1.name", "U2"),))])]
    with pytest.raises(LiaisonError, match="--objective 'User': allowed: Relay, worst, mean, condition"):
        make_design(BASE, None, "User", None, None, 1, choices=one_renames)
    for text, fragment in (("f: {1: {noise.sigma_m: 5}, '1': {noise.sigma_m: 6}}", "two labels read the same"),
                           ("f: {yes: {noise.sigma_m: 5}}", "label True: allowed: a text or a number"),
                           ("f: {a: {noise: {1: 2, sigma_m: 3}}}", "f.a: key 1: allowed: text keys")):
        path = tmp_path / "c.yaml"
        path.write_text(text)
        with pytest.raises(LiaisonError, match=fragment):
            read_choices(path)


def test_a_second_spacecraft_on_a_family_is_opened_by_its_period_and_phase():
    """docs/design.md: besides --family, another spacecraft on a family is opened with --vary on its period_days
    and phase (a key the base leaves out may be added); each candidate flies its own member at its own phase."""
    from liaison_cli.campaign.studies.design import make_design, score_candidate

    design = make_design(BASE, None, "worst", None, None, 1,
                         factors=[("spacecraft.0.period_days", [10.0, 12.0]), ("spacecraft.0.phase", [0.0, 0.5])])
    rows = [score_candidate(design, candidate) for candidate in design.candidates]
    assert all(row["error"] == "" for row in rows), [row["error"] for row in rows]
    assert sorted((row["spacecraft.0.period_days"], row["spacecraft.0.phase"]) for row in rows) == [
        (10.0, 0.0), (10.0, 0.5), (12.0, 0.0), (12.0, 0.5)]
    assert len({round(row["score_m"], 6) for row in rows}) == 4
