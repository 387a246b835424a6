"""Issue 26 item 2: process noise chosen by a stated consistency rule (`liaison tune`, campaign/studies/tuning.py)."""

import numpy as np
import pandas as pd
import pytest

from liaison_cli.analysis.consistency import NEES_REQUIRED_SHARE as NEES_IN_BAND_MIN
from liaison_cli.campaign.studies.tuning import (
    DEFAULT_LADDER_M_S2,
    VERDICT_BELOW_MARGIN,
    VERDICT_MET,
    VERDICT_NONE,
    _climb,
    choose,
    decades,
    ladder_grid,
    parse_ladder,
    rule_failure,
    shipped_snc,
)
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from liaison_cli.scenario.setup import prepare_problem
from tests.conftest import SCENARIOS, assert_one_line_error, run_cli_in_process as cli

# smoke.yaml made consistent by construction: initial errors drawn from the filter's P0, the filter's
# measurement model the truth's (no light time), judged after 0.25 d. The truth has no process noise, so a
# small SNC leaves the filter matched and a large one makes it pessimistic (NEES below its band).
MATCHED_SMOKE = ("measurement:\n  interval_s: 187.5\n", "measurement:\n  interval_s: 187.5\n  light_time: false\n"
                 "initial_error: {draw: from_covariance}\nfilter: {settle_days: 0.25}\n")


def _stats(consistent: bool, runs_ok: int = 20, in_band: float = 0.95, above: float = 0.03) -> pd.DataFrame:
    """One rung's statistics for two spacecraft with the given verdict and NEES shares."""
    return pd.DataFrame([{"spacecraft": name, "runs": 20, "runs_ok": runs_ok, "consistent": consistent,
                          "nees_in_band_share": in_band, "nees_spacecraft_in_band_share": in_band,
                          "nees_above_band_share": above, "nees_in_band_halfwidth": 0.05} for name in ("A", "B")])


def test_the_rule_takes_the_smallest_rung_that_passes_the_verdict_and_has_no_fallback():
    assert choose([(1e-9, _stats(False)), (1e-8, _stats(False)), (1e-7, _stats(True)), (1e-6, _stats(True))]) == (
        1e-7, VERDICT_MET)
    # No rung consistent: nothing is chosen (before, a rung passing the ratio test alone was taken).
    assert choose([(1e-9, _stats(False)), (1e-8, _stats(False))]) == (None, VERDICT_NONE)
    # A rung with a diverged run fails, however good the runs that finished look.
    assert choose([(1e-9, _stats(True, runs_ok=19)), (1e-8, _stats(True))]) == (1e-8, VERDICT_MET)


def test_the_rule_asks_a_margin_over_the_verdict():
    """A rung the verdict passes at 89 % of epochs in band (it needs 85 %) is not chosen: the rule asks 90 %."""
    assert choose([(1e-10, _stats(True, in_band=0.89)), (2e-10, _stats(True, in_band=0.91))]) == (2e-10, VERDICT_MET)
    assert rule_failure({"consistency_failed": "", "nees_in_band_share": 0.899}) == (
        "the rule's margin: state NEES in band 89.9 % < 90 %")


def test_without_a_rung_at_the_margin_the_least_noise_the_runs_cannot_tell_from_the_best_is_taken():
    """No rung reaches 90 %: of the rungs the verdict passes, the smallest whose share lies within the best
    share's 95 % interval (mt_eml2_lunar_range measured 87.4 % at 1e-10 and 89.7 +- 5.8 % at 1e-9, its best:
    1e-10), never one the verdict fails (2e-9 at 92 % with a diverged run); a rung the runs do resolve as
    worse is not taken (0.80 against 0.897 +- 0.02)."""
    def stats(consistent, in_band, half_width, runs_ok=20):
        frame = _stats(consistent, runs_ok=runs_ok, in_band=in_band)
        frame["nees_in_band_halfwidth"] = half_width
        return frame

    rungs = [(1e-10, stats(True, 0.874, 0.06)), (1e-9, stats(True, 0.897, 0.058)),
             (2e-9, stats(True, 0.92, 0.05, runs_ok=19)), (5e-9, stats(False, 0.70, 0.05))]
    assert choose(rungs) == (1e-10, VERDICT_BELOW_MARGIN)
    rungs = [(1e-10, stats(True, 0.80, 0.02)), (1e-9, stats(True, 0.897, 0.02))]
    assert choose(rungs) == (1e-9, VERDICT_BELOW_MARGIN)
    assert choose([(5e-9, stats(False, 0.70, 0.05))]) == (None, VERDICT_NONE)
    assert choose([(1e-9, stats(True, float("nan"), float("nan")))]) == (None, VERDICT_NONE)  # no NEES evidence


def test_the_ladder_is_one_two_five_and_runs_a_decade_at_a_time():
    assert DEFAULT_LADDER_M_S2[:4] == (1e-10, 2e-10, 5e-10, 1e-9) and DEFAULT_LADDER_M_S2[-1] == 1e-5
    assert len(DEFAULT_LADDER_M_S2) == 16
    assert decades((1e-9, 1e-6, 5e-6, 1e-5, 2e-10)) == [(2e-10,), (1e-9,), (1e-6, 5e-6), (1e-5,)]
    runs = []

    def fake(shares, shipped_value=None):
        """run_rungs with per rung (in-band share, above-band share); the verdict passes at >= 85 %; the
        shipped scenario is the rung shipped_value."""
        def run_rungs(values):
            runs.append(values)
            rungs = [(v, _stats(shares[v][0] >= 0.85, in_band=shares[v][0], above=shares[v][1])) for v in values]
            return rungs, next((stats for v, stats in rungs if v == shipped_value), None)
        return run_rungs

    # The first decade with a passing rung ends the climb: 1e-8 and above are not run.
    shares = {v: (0.80, 0.19) for v in DEFAULT_LADDER_M_S2} | {5e-9: (0.93, 0.05)}
    evaluated, _ = _climb(fake(shares), DEFAULT_LADDER_M_S2, extend_below=True)
    assert runs == [(1e-10, 2e-10, 5e-10), (1e-9, 2e-9, 5e-9)] and choose(evaluated) == (5e-9, VERDICT_MET)
    # eph_eml1_eml2_dsn's case: the lowest rung passes the verdict but not the margin, and is pessimistic
    # (more below the band than above): the ladder extends down before it climbs, and the first decade below
    # with a passing rung ends it; the shipped scenario found there is reported.
    runs.clear()
    shares = ({v: (0.80, 0.01) for v in DEFAULT_LADDER_M_S2} | {1e-10: (0.894, 0.01)}
              | {5e-11: (0.92, 0.02), 2e-11: (0.91, 0.04), 1e-11: (0.90, 0.05)})
    evaluated, shipped = _climb(fake(shares, shipped_value=1e-11), DEFAULT_LADDER_M_S2, extend_below=True)
    assert runs == [(1e-10, 2e-10, 5e-10), (1e-11, 2e-11, 5e-11)] and shipped is not None
    assert choose(evaluated) == (1e-11, VERDICT_MET) and [v for v, _ in evaluated] == sorted(v for v, _ in evaluated)
    # The extension stops where its lowest rung is no longer pessimistic (1e-11 optimistic), then climbs.
    runs.clear()
    shares = ({v: (0.80, 0.01) for v in DEFAULT_LADDER_M_S2} | {5e-11: (0.86, 0.05), 2e-11: (0.84, 0.10),
              1e-11: (0.70, 0.29)} | {1e-8: (0.95, 0.03)})
    evaluated, _ = _climb(fake(shares), DEFAULT_LADDER_M_S2, extend_below=True)
    assert runs[:2] == [(1e-10, 2e-10, 5e-10), (1e-11, 2e-11, 5e-11)] and runs[-1] == (1e-8, 2e-8, 5e-8)
    assert choose(evaluated) == (1e-8, VERDICT_MET)
    # A given ladder is not extended.
    runs.clear()
    evaluated, _ = _climb(fake(shares), (1e-10, 1e-9), extend_below=False)
    assert runs == [(1e-10,), (1e-9,)] and choose(evaluated) == (None, VERDICT_NONE)


def test_every_rung_gives_every_spacecraft_the_rung_value():
    """The ladder's grid removes the lunar orbiter's own 1e-6 m/s^2 (eml2_lunar): at each rung both spacecraft's
    process noise in the filter is the rung's."""
    scenario, _ = load_scenario(SCENARIOS / "eml2_lunar.yaml")
    grid = ladder_grid(scenario, (1e-9, 1e-8))
    assert grid == [("filter.process_noise_accel_m_s2", [1e-9, 1e-8]),
                    ("spacecraft.1.process_noise_accel_m_s2", [None])]
    rung = apply_overrides(scenario, {"duration_days": 1, **{key: values[-1] for key, values in grid}})
    shipped = apply_overrides(scenario, {"duration_days": 1})
    ratio_q = prepare_problem(rung).filter.Q.diagonal() / prepare_problem(shipped).filter.Q.diagonal()
    assert ratio_q[:6] == pytest.approx([(1e-8 / 1e-7) ** 2] * 6)  # EML2: the filter's 1e-7 before
    assert ratio_q[6:12] == pytest.approx([(1e-8 / 1e-6) ** 2] * 6)  # Lunar: its own 1e-6 before


def test_a_filter_psd_is_removed_on_the_sigma_a_ladder():
    """smoke with its EML2 on a filter PSD and its orbiter on its own sigma_a: not every spacecraft takes a PSD,
    so the ladder is on the filter's sigma_a, and the filter PSD and the orbiter's own key are removed (each rung
    holds one convention)."""
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    scenario = apply_overrides(scenario, {"filter.process_noise_psd_m2_s3": 1e-12,
                                          "spacecraft.0.process_noise_accel_m_s2": None})
    grid = ladder_grid(scenario, (1e-9,))
    assert ("filter.process_noise_psd_m2_s3", [None]) in grid and ("spacecraft.1.process_noise_accel_m_s2", [None]) in grid
    rung = apply_overrides(scenario, {key: values[0] for key, values in grid})
    assert rung.filter.process_noise_psd_m2_s3 is None and rung.filter.process_noise_accel_m_s2 == 1e-9


def test_a_psd_scenario_is_laddered_in_its_own_key_with_the_same_q_as_sigma_a():
    """A scenario whose spacecraft take an isotropic PSD (given, or by default) is laddered on
    filter.process_noise_psd_m2_s3 with q = sigma_a^2 dt: the filter's Q at each rung is the sigma_a rung's under
    the continuous white-acceleration model, to rounding."""
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    psd = apply_overrides(scenario, {"spacecraft.0.process_noise_accel_m_s2": None,
                                     "spacecraft.1.process_noise_accel_m_s2": None, "duration_days": 1})
    assert psd.filter.process_noise_of(psd.spacecraft[0])[0] == "process_noise_psd_m2_s3"  # the default
    dt = psd.measurement.interval_s
    grid = ladder_grid(psd, (1e-9, 1e-8))
    assert grid[0][0] == "filter.process_noise_psd_m2_s3" and grid[0][1] == pytest.approx([1e-18 * dt, 1e-16 * dt])
    rung = apply_overrides(psd, {key: values[-1] for key, values in grid})
    snc = apply_overrides(psd, {"filter.process_noise_accel_m_s2": 1e-8,
                                "filter.process_noise_model": "continuous_white_acceleration"})
    q_psd, q_snc = prepare_problem(rung).filter.Q, prepare_problem(snc).filter.Q
    np.testing.assert_allclose(q_psd, q_snc, rtol=1e-12, atol=0)
    assert shipped_snc(psd)["EML2"] is None  # the default is derived per scenario at setup (scenario.default_noise)
    given = apply_overrides(psd, {"filter.process_noise_psd_m2_s3": 1e-12})
    assert shipped_snc(given)["EML2"] == pytest.approx(np.sqrt(1e-12 / dt))


def test_ric_densities_in_different_proportions_are_refused_in_one_line(tmp_path):
    """One scale does not ladder two shapes: RIC PSDs whose proportions differ between spacecraft are refused
    before anything runs, naming what is allowed."""
    text = (SCENARIOS / "smoke.yaml").read_text()
    assert text.count("process_noise_accel_m_s2: 1.0e-10") == 2
    path = tmp_path / "ric_smoke.yaml"
    path.write_text(text.replace("process_noise_accel_m_s2: 1.0e-10",
                                 "process_noise_psd_ric_m2_s3: [1.0e-12, 1.0e-12, 1.0e-12]", 1)
                    .replace("process_noise_accel_m_s2: 1.0e-10", "process_noise_psd_ric_m2_s3: [1.0e-13, 1.0e-12, 0]"))
    proc = cli("tune", path, "--runs", "1", "--work", tmp_path / "work", "--table", tmp_path / "t.md")
    assert_one_line_error(proc, "ric_smoke", ["per RIC axis", "proportions", "filter.process_noise_psd_m2_s3"])
    assert not (tmp_path / "work").exists()


def test_ric_densities_in_one_proportion_are_laddered_in_their_own_key(tmp_path):
    """Every estimated spacecraft's RIC PSD in the same proportions: each rung sets
    filter.process_noise_psd_ric_m2_s3 to q = sigma_a^2 dt times the proportions (the largest axis at q), the
    spacecraft keys removed; the text names the triple to set."""
    text = (SCENARIOS / "smoke.yaml").read_text()
    path = tmp_path / "ric_smoke.yaml"
    path.write_text(text.replace("process_noise_accel_m_s2: 1.0e-10", "process_noise_psd_ric_m2_s3: [1.0e-13, 1.0e-12, 5.0e-13]"))
    scenario = load_scenario(path)[0]
    dt = scenario.measurement.interval_s
    grid = dict(ladder_grid(scenario, (1e-9, 1e-8)))
    assert grid["filter.process_noise_psd_ric_m2_s3"] == [
        pytest.approx((1e-19 * dt, 1e-18 * dt, 5e-19 * dt)), pytest.approx((1e-17 * dt, 1e-16 * dt, 5e-17 * dt))]
    assert grid["spacecraft.0.process_noise_psd_ric_m2_s3"] == [None]
    table = tmp_path / "t.md"
    proc = cli("tune", path, "--ladder", "1e-7,1e-6", "--runs", "4", "--jobs", "1", "--work", tmp_path / "work",
               "--table", table)
    assert proc.returncode == 0, proc.stderr
    frame = pd.read_parquet(table.with_suffix(".parquet"))
    assert set(frame[frame.setting == "rung"].ladder_key) == {"filter.process_noise_psd_ric_m2_s3"}
    chosen = frame[frame.chosen].iloc[0]  # on these 4 runs 1e-6 passes (1e-7 is optimistic for the orbiter)
    q = chosen.snc_m_s2**2 * dt
    np.testing.assert_allclose(list(chosen.ric_m2_s3), [0.1 * q, q, 0.5 * q], rtol=1e-12)
    assert f"filter.process_noise_psd_ric_m2_s3: [{0.1 * q:.3g}, {q:.3g}, {0.5 * q:.3g}]" in proc.stdout


def test_a_template_with_a_psd_is_tuned_and_the_table_gives_the_psd_to_set(tmp_path):
    """`liaison new --from crosslink-pair` (its filter and its orbiter give PSDs): tune runs it on the PSD
    ladder, the Parquet carries each rung's q beside its sigma_a, and the text names the PSD to set."""
    path = tmp_path / "pair.yaml"
    assert cli("new", path, "--from", "crosslink-pair").returncode == 0
    table = tmp_path / "t.md"
    proc = cli("tune", path, "--ladder", "1e-9,1e-8", "--runs", "6", "--jobs", "1", "--work", tmp_path / "work",
               "--table", table)
    assert proc.returncode == 0, proc.stderr
    frame = pd.read_parquet(table.with_suffix(".parquet"))
    rungs = frame[frame.setting == "rung"]
    assert set(rungs.ladder_key) == {"filter.process_noise_psd_m2_s3"}
    dt = load_scenario(path)[0].measurement.interval_s
    np.testing.assert_allclose(rungs.psd_m2_s3, rungs.snc_m_s2 ** 2 * dt, rtol=1e-15)
    if frame.chosen.any():
        assert "filter.process_noise_psd_m2_s3:" in proc.stdout


def test_ladder_values_are_sorted_and_bad_ones_refused():
    assert parse_ladder("1e-7,1e-9") == (1e-9, 1e-7)
    for text, fragment in (("1e-9,abc", "'abc' is not a number"), ("1e-9,-1e-8", "not a positive finite"),
                           ("1e-9,1e-9", "repeated"), ("1e-9,inf", "not a positive finite")):
        proc = cli("tune", SCENARIOS / "smoke.yaml", "--ladder", text, "--runs", "1")
        assert_one_line_error(proc, "--ladder", [fragment])


def test_a_table_path_that_is_not_markdown_is_one_line(tmp_path):
    proc = cli("tune", SCENARIOS / "smoke.yaml", "--table", tmp_path / "out.txt", "--runs", "1")
    assert_one_line_error(proc, "--table", ["ending in .md"])


def test_tune_chooses_the_matched_rung_writes_the_table_and_reuses_its_runs(tmp_path):
    """A filter matched to its truth but for its RK4 propagation near the lunar orbiter's perilune (12 runs):
    at 1e-9 m/s^2 the orbiter's own 6-state NEES lies above its band 13.6 % of the settled epochs (optimistic),
    so the verdict fails there although the whole-state NEES is 91 % in band; at 1e-6 the verdict passes but
    the whole-state share, 87.1 %, is below the rule's 90 % margin; at 1e-5 the filter is pessimistic (NEES
    below its band): no rung reaches the margin, and 1e-6, the one the verdict passes, is chosen below it.
    With 2e-7 on the ladder (94.3 % in band) the rule is met there and the
    decade above is not run. The table and Parquet say so, with what failed; a second `tune` computes nothing
    (every run is in the sweeps' manifests) and writes the same table."""
    text = (SCENARIOS / "smoke.yaml").read_text()
    assert MATCHED_SMOKE[0] in text
    path = tmp_path / "matched_smoke.yaml"
    path.write_text(text.replace(*MATCHED_SMOKE))
    work = tmp_path / "work"

    def tune(ladder, name):
        table = tmp_path / f"{name}.md"
        args = ("tune", path, "--ladder", ladder, "--runs", "12", "--jobs", "1", "--work", work, "--table", table)
        proc = cli(*args)
        assert proc.returncode == 0, proc.stderr
        frame = pd.read_parquet(table.with_suffix(".parquet"))
        return args, proc, frame, frame[frame.setting == "rung"].set_index(["snc_m_s2", "spacecraft"]), table

    args, proc, frame, rungs, table = tune("1e-9,1e-6,1e-5", "none")
    assert rungs.loc[(1e-9, "EML2"), "nees_in_band_share"] >= NEES_IN_BAND_MIN
    assert "spacecraft NEES in band" in rungs.loc[(1e-9, "Lunar"), "consistency_failed"]
    assert "optimistic" in rungs.loc[(1e-9, "Lunar"), "consistency_failed"]
    assert not rungs.loc[(1e-6, "EML2"), "consistency_failed"]  # the verdict passes ...
    assert rungs.loc[(1e-6, "EML2"), "rule_failed"].startswith("the rule's margin: state NEES in band 87")
    assert rungs.loc[(1e-5, "EML2"), "nees_in_band_share"] < NEES_IN_BAND_MIN
    assert rungs.loc[(1e-5, "EML2"), "nees_above_band_share"] < 0.05  # below the band: pessimistic
    assert "pessimistic" in rungs.loc[(1e-5, "EML2"), "consistency_failed"]
    assert set(frame[frame.chosen].snc_m_s2) == {1e-6} and set(frame.verdict) == {VERDICT_BELOW_MARGIN}
    assert set(frame[frame.setting == "shipped"].snc_m_s2) == {1e-10}  # smoke's own per-spacecraft values
    markdown = table.read_text()
    assert "Written by `liaison tune" in markdown and f"at least {NEES_IN_BAND_MIN:g} of the" in markdown
    assert "| matched_smoke | Lunar | 1e-10 |" in markdown and "| rule met below its margin |" in markdown
    assert all(word in proc.stdout for word in ("optimistic", "the rule's margin", "pessimistic"))
    manifests = sorted(work.rglob("manifest.jsonl"))
    assert len(manifests) == 4  # one sweep per decade and the shipped settings' (not a rung)
    before = {p: p.read_bytes() for p in manifests}
    again = cli(*args)
    assert again.returncode == 0, again.stderr
    assert {p: p.read_bytes() for p in manifests} == before and table.read_text() == markdown
    _, _, frame, rungs, table = tune("1e-9,2e-7,1e-5", "met")
    assert set(frame[frame.chosen].snc_m_s2) == {2e-7} and set(frame.verdict) == {VERDICT_MET}
    assert rungs.loc[(2e-7, "EML2"), "nees_in_band_share"] >= 0.9
    assert 1e-5 not in rungs.index.get_level_values(0)  # above the first decade with a passing rung
    assert "| rule met |" in table.read_text()


def test_the_reference_table_covers_every_shipped_scenario_and_the_rule_is_applied():
    """results/reference/consistency.md (written by `liaison tune`) is the shipped files' table: one entry per
    scenario of scenarios/ and scenarios/003/ that has process noise (batch ones may be missing), its shipped process noise the file's own, and every EKF scenario
    carries the rule's choice except those kept tuned to a paper (report/data/paper_tuned.yaml), whose notes
    are in the Markdown."""
    from liaison_cli.campaign.studies.tuning import shipped_snc
    from liaison_cli.report.tuning import paper_tuned_notes
    from tests.conftest import REPO

    table = pd.read_parquet(REPO / "results" / "reference" / "consistency.parquet")
    markdown = (REPO / "results" / "reference" / "consistency.md").read_text()
    paths = sorted(SCENARIOS.glob("*.yaml")) + sorted((SCENARIOS / "003").glob("*.yaml"))
    tunable = {path.stem for path in paths if load_scenario(path)[0].estimator_descriptor().process_noise}
    # Every scenario with process noise is in the table; a batch scenario (nothing to tune: a shipped row only)
    # may be, or may have shipped after it (002's always-visible station readings).
    assert tunable <= set(table.scenario) <= {path.stem for path in paths}
    paths = [path for path in paths if path.stem in set(table.scenario)]
    kept = paper_tuned_notes()
    for path in paths:
        scenario, _ = load_scenario(path)
        rows = table[table.scenario == path.stem]
        shipped = rows[rows.setting == "shipped"].set_index("spacecraft").snc_m_s2.to_dict()
        chosen = rows[rows.chosen]
        if scenario.estimator == "batch":  # no SNC: its value is not read (the table shows '-')
            assert chosen.empty
            continue
        assert shipped == shipped_snc(scenario), path.stem
        if path.stem in kept:
            assert kept[path.stem] in markdown and set(shipped.values()) != set(chosen.snc_m_s2), path.stem
        elif chosen.empty:  # no rung passes: nothing to carry, the shipped value stays and the table says so
            assert set(rows.verdict) == {VERDICT_NONE}, path.stem
        else:
            assert set(shipped.values()) == set(chosen.snc_m_s2), path.stem


def test_tune_keeps_the_sweeps_caps(tmp_path):
    """Issue 35 fault 5: a ladder of 12,000 rungs at a million runs was planned (5.4 GB) before any check."""
    ladder = ",".join(f"{v:.6e}" for v in [1e-12 * 1.001**k for k in range(12_000)])
    proc = cli("tune", SCENARIOS / "smoke.yaml", "--ladder", ladder, "--runs", "1000000", "--work", tmp_path / "w",
               "--table", tmp_path / "t.md")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
