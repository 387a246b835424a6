"""Range-rate and LOS observables: partials, filter consistency, 001 §6.1 trends, bad links."""

import numpy as np
import pandas as pd
import pytest

from liaison_cli.campaign.engine.results import summary_table
from liaison_cli.campaign.engine.runner import run_campaign
from liaison_cli.scenario.loading import load_scenario
from liaison_cli.measurements.los import azimuth_elevation, azimuth_elevation_gradients, los_sigma_rad
from liaison_cli.orbits.catalog import CATALOG
from liaison_cli.campaign.studies.compare import compare_rows
from tests.conftest import SCENARIOS, assert_one_line_error, edited_scenario, run_cli_in_process


def test_los_partials_match_central_differences():
    a = CATALOG["eml2_halo"].state()[:3]
    b = CATALOG["eml1_halo"].state()[:3] + np.array([0.0, 0.03, 0.02])
    g_az, g_el = azimuth_elevation_gradients(a, b)
    for j in range(3):
        h = 1e-7
        e = np.zeros(3)
        e[j] = h
        plus, minus = azimuth_elevation(a + e, b), azimuth_elevation(a - e, b)
        assert (plus[0] - minus[0]) / (2 * h) == pytest.approx(g_az[j], rel=1e-6, abs=1e-9)
        assert (plus[1] - minus[1]) / (2 * h) == pytest.approx(g_el[j], rel=1e-6, abs=1e-9)
        plus, minus = azimuth_elevation(a, b + e), azimuth_elevation(a, b - e)
        assert (plus[0] - minus[0]) / (2 * h) == pytest.approx(-g_az[j], rel=1e-6, abs=1e-9)


def test_los_sigma_from_baseline():
    assert los_sigma_rad(0.001, 1.0) == pytest.approx(1e-3)
    assert los_sigma_rad(0.001, 1.0, 60.0) == pytest.approx(2e-3)


def test_every_channel_is_consistent_with_its_predicted_std(tmp_path):
    proc = run_cli_in_process("run", SCENARIOS / "mt_eml2_lunar_range_rate_los.yaml", "--runs", "2", "--output", tmp_path / "o",
                   "--jobs", "1")
    assert proc.returncode == 0, proc.stderr
    res = pd.read_parquet(tmp_path / "o" / "residuals.parquet")
    assert set(res.observable) == {"range", "range_rate", "azimuth", "elevation"}
    z = (res.innovation / res.innovation_std).groupby(res.observable).agg(lambda v: np.sqrt(np.mean(v**2)))
    assert ((z > 0.9) & (z < 1.1)).all(), z
    assert set(res[res.observable == "range_rate"].unit) == {"m/s"} and set(res[res.observable == "azimuth"].unit) == {"rad"}


def test_measurement_type_trends():
    """001 §6.1 with noise from the error models (7.8 m tone ranging, 1.4 mm/s Doppler, 1.4 mrad): range-only
    beats range-rate-only,
    range + range-rate beats range-only, and LOS angles add at most a modest gain."""
    rows = {}
    for formation in ("eml2_lunar", "eml1_eml2"):
        for kind in ("range", "range_rate", "range_and_rate", "range_rate_los"):
            scenario, _ = load_scenario(SCENARIOS / f"mt_{formation}_{kind}.yaml")
            result = run_campaign(scenario, runs=20, jobs=2, progress=False)
            rows[(formation, kind)] = compare_rows(scenario, summary_table(result))["rms_position_m"]
    for formation in ("eml2_lunar", "eml1_eml2"):
        r = {kind: rows[(formation, kind)] for kind in ("range", "range_rate", "range_and_rate", "range_rate_los")}
        assert r["range"] < r["range_rate"], (formation, r)
        assert r["range_and_rate"] < r["range"], (formation, r)
        assert r["range_rate_los"] < 1.05 * r["range_and_rate"], (formation, r)
    # "changes little" where the formation is already observable
    lunar = rows[("eml2_lunar", "range_rate_los")] / rows[("eml2_lunar", "range_and_rate")]
    assert 0.85 < lunar < 1.05


CARRIER_BLOCK = ("  carrier:                         # Eq. 5: 1.41 mm/s Doppler; Eq. 9: 1.41 mm interferometer path error\n"
                 "    power_fraction_db: -3\n    loop_bandwidth_hz: 10\n    doppler_count_s: 1\n")

_TEXT = (SCENARIOS / "mt_eml2_lunar_range_rate_los.yaml").read_text()
TONE_AND_BUDGET = _TEXT[_TEXT.index("  ranging_method: tone"):_TEXT.index("  ranging_clock_hz")]

BAD_LINKS = {
    "los_without_antenna": ("    antenna_baseline_m: 1.0          # assumed LOS interferometer baseline\n", "",
                            ["cannot measure 'los'", "'EML2'", "antenna_baseline_m"]),
    "unknown_observable": ("observables: [range, range_rate, los]", "observables: [range, doppler]",
                           ["'doppler'", "range_rate", "los"]),
    "range_rate_without_sigma": (CARRIER_BLOCK, "", ["range_rate", "range_rate_sigma_m_s", "noise.carrier"]),
    "carrier_and_direct_sigma": (CARRIER_BLOCK, CARRIER_BLOCK + "  range_rate_sigma_m_s: 0.001\n",
                                 ["noise", "'range_rate_sigma_m_s'", "'carrier'", "not both"]),
    "carrier_without_link_budget": (TONE_AND_BUDGET, "  sigma_m: 7.8\n", ["noise", "'carrier'", "'link_budget'"]),
    "tone_without_tone_frequency": ("  ranging_clock_hz: 1.0e5\n", "", ["'tone'", "ranging_clock_hz"]),
    "positive_carrier_fraction": ("    power_fraction_db: -3\n", "    power_fraction_db: 2\n",
                                  ["noise.carrier.power_fraction_db", "2", "less than or equal to 0"]),
}


@pytest.mark.parametrize("case", sorted(BAD_LINKS))
def test_observable_the_link_cannot_make_is_one_line_exit_2(tmp_path, case):
    old, new, expected = BAD_LINKS[case]
    path = edited_scenario(tmp_path, "mt_eml2_lunar_range_rate_los.yaml", old, new)
    assert_one_line_error(run_cli_in_process("run", path, "--output", tmp_path / "o"), path, expected)
