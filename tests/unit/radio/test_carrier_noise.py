"""Tone ranging, two-way Doppler and interferometric LOS noise models (001 Eq. 5, 9, 62-65) against a
sample-level simulation of the phase-locked loops they describe, and against the Table 2 link."""

import math

import numpy as np
import pytest

from liaison_cli.radio.carrier import (
    C_M_S,
    TURNAROUND_S_BAND,
    doppler_range_rate_sigma_m_s,
    interferometer_path_sigma_m,
    loop_phase_sigma_rad,
    range_to_range_rate_ratio_s,
    tone_ranging_sigma_m,
    two_way_doppler_phase_sigma_rad,
    two_way_doppler_sigma_m_s,
)
from liaison_cli.radio.ranging import carrier_sigmas_from_link_budget, sigma_from_link_budget
from tests.unit.radio.test_ranging_budget import TABLE2_DOWN, TABLE2_UP


class FirstOrderPll:
    """M independent complex-baseband first-order PLLs (unit-power signal, noise density 1/(C/N0)).

    Gain K per sample from the one-sided noise bandwidth: B_L = K fs / (2 (2 - K)).
    """

    def __init__(self, c_over_n0_hz, loop_bandwidth_hz, fs_hz, m, rng, phase0=None):
        self.gain = 4.0 * loop_bandwidth_hz / (fs_hz + 2.0 * loop_bandwidth_hz)
        self.noise_std = math.sqrt(fs_hz / c_over_n0_hz / 2.0)  # per real/imaginary component
        self.phase = np.zeros(m) if phase0 is None else np.array(phase0, dtype=float)
        self.rng = rng

    def step(self, signal_phase):
        m = self.phase.size
        y = np.exp(1j * signal_phase) + self.noise_std * (self.rng.standard_normal(m) + 1j * self.rng.standard_normal(m))
        self.phase = self.phase + self.gain * np.imag(y * np.exp(-1j * self.phase))
        return self.phase


def test_loop_jitter_and_tone_range_match_a_simulated_pll():
    """Eq. 62-63: a tone at 30 dB-Hz in a 1 Hz loop -> sigma_phi = sqrt(B_L/(P/N0)); range = c phi / (4 pi f)."""
    rng = np.random.default_rng(62)
    fs, c_n0, b_l, tone_hz, m = 100.0, 1000.0, 1.0, 1.0e5, 2000
    true_range_m = 350.0  # inside the 1,499 m unambiguous range of a 100 kHz two-way tone
    true_phase = 4.0 * math.pi * tone_hz * true_range_m / C_M_S
    pll = FirstOrderPll(c_n0, b_l, fs, m, rng, phase0=np.full(m, true_phase))
    for _ in range(300):  # 3 s, twelve loop time constants
        phase = pll.step(true_phase)
    estimated_range = C_M_S * phase / (4.0 * math.pi * tone_hz)
    predicted_phase = loop_phase_sigma_rad(b_l, c_n0)
    assert np.std(phase - true_phase) == pytest.approx(predicted_phase, rel=0.06)
    assert np.std(estimated_range) == pytest.approx(tone_ranging_sigma_m(tone_hz, predicted_phase), rel=0.06)
    assert abs(np.mean(estimated_range) - true_range_m) < 4 * np.std(estimated_range) / math.sqrt(m)


def _two_way_coherent_doppler(range_rate_m_s, f_up_hz, turnaround, count_s, fs, up, down, m, rng):
    """Transponder PLL locks to the uplink, retransmits G x its phase; the receiver (two antennas)
    tracks the downlink and counts phase over `count_s`. Returns (range-rate estimates, path differences)."""
    f_dn_hz = turnaround * f_up_hz
    transponder = FirstOrderPll(up[0], up[1], fs, m, rng)
    antenna_a = FirstOrderPll(down[0], down[1], fs, m, rng)
    antenna_b = FirstOrderPll(down[0], down[1], fs, m, rng)
    settle, n_count = int(fs), int(round(count_s * fs))
    start = None
    for k in range(settle + n_count + 1):
        t = k / fs
        uplink_phase = -2.0 * math.pi * f_up_hz * range_rate_m_s * t / C_M_S
        downlink_phase = turnaround * transponder.step(uplink_phase) - 2.0 * math.pi * f_dn_hz * range_rate_m_s * t / C_M_S
        phase_a, phase_b = antenna_a.step(downlink_phase), antenna_b.step(downlink_phase)
        if k == settle:
            start = phase_a.copy()
    counted = phase_a - start
    range_rate = -C_M_S * counted / (2.0 * math.pi * 2.0 * f_dn_hz * count_s)
    path_difference = (C_M_S / f_dn_hz) * (phase_a - phase_b) / (2.0 * math.pi)
    return range_rate, path_difference


def test_two_way_doppler_and_interferometer_match_simulated_loops():
    """Eq. 5 / 64 and Eq. 9: the Doppler count carries the receiver's own jitter plus G x the transponder's;
    the two-antenna phase difference carries only the antennas' own (the transponded noise cancels).
    Baseband carrier scaled to 100 Hz so that the simulated Doppler shift stays inside the loops."""
    rng = np.random.default_rng(64)
    f_up, count_s, fs, m = 100.0, 1.0, 2000.0, 2000
    up, down = (100.0, 1.0), (2000.0, 50.0)  # (C/N0 Hz, B_L Hz): loop SNRs 100 and 40
    true_rate = 3.0e4  # m/s at the scaled carrier: a 0.02 Hz two-way shift
    rate, path = _two_way_coherent_doppler(true_rate, f_up, TURNAROUND_S_BAND, count_s, fs, up, down, m, rng)
    f_dn = TURNAROUND_S_BAND * f_up
    rho_up, rho_down = up[0] / up[1], down[0] / down[1]
    predicted = two_way_doppler_sigma_m_s(f_dn, count_s, rho_down, rho_up, TURNAROUND_S_BAND)
    # The receiver loop (50 Hz) passes ~98 % of the transponder's 1 Hz jitter, as the formula assumes.
    assert np.std(rate) == pytest.approx(predicted, rel=0.06)
    assert abs(np.mean(rate) - true_rate) < 4 * np.std(rate) / math.sqrt(m)
    downlink_only = two_way_doppler_sigma_m_s(f_dn, count_s, rho_down, 1e30, TURNAROUND_S_BAND)
    assert np.std(rate) > 1.15 * downlink_only  # the uplink term is there and is not negligible
    assert np.std(path) == pytest.approx(interferometer_path_sigma_m(f_dn, 1.0 / math.sqrt(rho_down)), rel=0.06)


def test_eq64_and_eq5_agree_and_scale():
    phase = two_way_doppler_phase_sigma_rad(400.0, 150.0, TURNAROUND_S_BAND)
    eq64 = doppler_range_rate_sigma_m_s(phase, 2.0e9, TURNAROUND_S_BAND, 10.0)
    eq5 = two_way_doppler_sigma_m_s(TURNAROUND_S_BAND * 2.0e9, 10.0, 400.0, 150.0, TURNAROUND_S_BAND)
    assert eq64 == pytest.approx(eq5, rel=1e-12)
    assert doppler_range_rate_sigma_m_s(phase, 2.0e9, TURNAROUND_S_BAND, 20.0) == pytest.approx(eq64 / 2)
    # Eq. 65 is Eq. 63 over Eq. 64 for one unit: same phase error on the tone and the carrier.
    for tone_hz, count_s in ((1e5, 1.0), (5e5, 60.0)):
        ratio = tone_ranging_sigma_m(tone_hz, 0.05) / doppler_range_rate_sigma_m_s(0.05, 2.2e9, 1.0, count_s)
        assert range_to_range_rate_ratio_s(tone_hz, 2.2e9, count_s) == pytest.approx(ratio, rel=1e-12)
    # S-band, 100 kHz major tone, 1 s count: 1 m of range error goes with ~64 um/s of range-rate error.
    assert range_to_range_rate_ratio_s(1e5, 2.2e9, 1.0) == pytest.approx(15_556, rel=1e-3)


def test_table2_link_tone_ranging_doppler_and_los():
    """The 000 Table 2 link (C/N0 38.7 / 42.7 dB-Hz, 3 dB margin held back) with our stated radio
    assumptions: 100 kHz major tone at -6 dB in a 1 Hz loop; residual carrier at -3 dB in 10 Hz loops."""
    tone = sigma_from_link_budget("tone", TABLE2_UP, TABLE2_DOWN, 0.3, 1e5, 1.0, -6.0)
    # P_R/N0 = 38.74 - 3 - 6 = 29.74 dB-Hz: sigma_phi = 0.0326 rad, c sigma_phi / (4 pi 100 kHz) = 7.77 m
    assert tone == pytest.approx(7.77, abs=0.01)
    carrier = carrier_sigmas_from_link_budget(TABLE2_UP, TABLE2_DOWN, -3.0, 10.0, 1.0, TURNAROUND_S_BAND)
    assert carrier["uplink_loop_snr"] == pytest.approx(10 ** (3.274) / 10, rel=1e-3)
    assert carrier["downlink_loop_snr"] == pytest.approx(10 ** (3.674) / 10, rel=1e-3)
    assert carrier["range_rate_sigma_m_s"] == pytest.approx(1.405e-3, rel=2e-3)
    assert carrier["los_path_sigma_m"] == pytest.approx(1.41e-3, rel=5e-3)
    # A longer count and a finer tone trade against each other exactly as Eq. 65 says.
    ten_s = carrier_sigmas_from_link_budget(TABLE2_UP, TABLE2_DOWN, -3.0, 10.0, 10.0, TURNAROUND_S_BAND)
    assert ten_s["range_rate_sigma_m_s"] == pytest.approx(carrier["range_rate_sigma_m_s"] / 10)


def test_sigma_sweep_over_a_tone_scenario_keeps_the_carrier_sigmas():
    """`--sigma` replaces the tone ranging but the link budget stays for the Doppler / LOS sigmas."""
    from liaison_cli.scenario.loading import load_scenario
    from liaison_cli.campaign.sweep.plan import plan_sweep
    from tests.conftest import SCENARIOS

    path = SCENARIOS / "mt_eml2_lunar_range_rate_los.yaml"
    scenario, text = load_scenario(path)
    assert scenario.noise.resolved_sigma_m() == pytest.approx(7.77, abs=0.01)
    plan = plan_sweep([(scenario, text, str(path))], [("noise.sigma_m", [50, 300])], 1, "tone")
    for point, sigma in zip(plan.points, (50, 300)):
        assert point.sigma_m == sigma and point.scenario.noise.ranging_method is None
        assert point.scenario.noise.resolved_range_rate_sigma_m_s() == pytest.approx(1.405e-3, rel=2e-3)
        assert point.scenario.noise.resolved_los_path_sigma_m() == pytest.approx(1.41e-3, rel=5e-3)


def test_budget_command_prints_tone_doppler_los_and_the_eq65_ratio(tmp_path):
    from tests.conftest import SCENARIOS, assert_one_line_error, run_cli_in_process

    proc = run_cli_in_process("budget", SCENARIOS / "links" / "table2_tone_doppler.yaml")
    assert proc.returncode == 0, proc.stderr
    rows = [line.split() for line in proc.stdout.splitlines()]
    assert ["tone", "(001", "Eq.", "62-63)", "7.8", "m"] in rows and ["(Eq.", "4)", "171.8", "m"] == rows[3][1:]
    assert ["tone", "(001", "Eq.", "62-63)", "5533", "s"] in rows  # Eq. 65 ratio, tone
    assert "1.4050 mm/s" in proc.stdout and "1.412 mm" in proc.stdout and "122276 s" in proc.stdout
    bad = tmp_path / "bad_link.yaml"
    bad.write_text((SCENARIOS / "links" / "table2_tone_doppler.yaml").read_text()
                   .replace("  doppler_count_s: 1\n", "  doppler_count_s: 0\n"))
    assert_one_line_error(run_cli_in_process("budget", bad), bad, ["carrier.doppler_count_s", "0", "greater than 0"])
