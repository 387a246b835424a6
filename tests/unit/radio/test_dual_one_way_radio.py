"""002 Eq. 8-12: the dual one-way receiver's error models, checked against simulated estimators."""

import math

import numpy as np
import pytest

from tests.conftest import SCENARIOS, run_cli_in_process
from liaison_cli.radio.dual_one_way import (
    DLL_NARROW,
    DLL_VERY_NARROW,
    DLL_WIDE,
    DualOneWayReceiver,
    dll_regime,
    dll_sigma_chips,
    effective_duration_rect_s,
    foa_crb_hz,
    gabor_bandwidth_bpsk_rad_s,
    toa_crb_s,
)

# 002 §2's Ka-band example; PLL integration 1 s (the paper: "less than five seconds").
KA_EXAMPLE = DualOneWayReceiver(26e9, 35.0, 0.2, 1.0, 8e6, 2.046e6, 0.488e-6, 1.0, 1.0)


def test_toa_bound_is_reached_by_a_simulated_ml_delay_estimator():
    """A band-limited BPSK code in complex white noise (E/N0 = 30 dB); the ML delay (Newton on the
    cross-correlation) has the spread of 002 Eq. 8 with the code's own Gabor bandwidth, within 8 %."""
    rng = np.random.default_rng(2)
    chip_rate, band, fs, n = 1.0e6, 4.0e6, 8.0e6, 4096
    dt = 1.0 / fs
    f = np.fft.fftfreq(n, dt)
    chips = rng.choice([-1.0, 1.0], size=int(n * dt * chip_rate) + 1)
    s = chips[(np.arange(n) * dt * chip_rate).astype(int)].astype(complex)
    S = np.fft.fft(s)
    S[np.abs(f) >= band / 2] = 0.0
    s = np.fft.ifft(S)
    e_over_n0 = 1000.0
    sigma2 = np.sum(np.abs(s) ** 2) / e_over_n0  # per complex sample: N0 / dt with N0 = E / (E/N0)
    beta = math.sqrt(np.sum((2 * np.pi * f) ** 2 * np.abs(S) ** 2) / np.sum(np.abs(S) ** 2))
    estimates = []
    for _ in range(1500):
        r = np.fft.fft(s + math.sqrt(sigma2 / 2) * (rng.standard_normal(n) + 1j * rng.standard_normal(n)))
        tau = 0.0
        for _ in range(4):
            c = r * np.conj(S) * np.exp(2j * np.pi * f * tau)
            w = 2j * np.pi * f
            tau -= np.real(np.sum(c * w)) / np.real(np.sum(c * w * w))
        estimates.append(tau)
    assert np.std(estimates) == pytest.approx(1.0 / (beta * math.sqrt(2 * e_over_n0)), rel=0.08)
    # The ideal sinc^2 spectrum's Gabor bandwidth is that of a random code to a few per cent.
    assert gabor_bandwidth_bpsk_rad_s(chip_rate, band) == pytest.approx(beta, rel=0.06)


def test_foa_bound_is_reached_by_a_simulated_ml_frequency_estimator():
    """A tone of unknown phase over T = 1 s at E/N0 = 33 dB: the periodogram-peak frequency has the spread
    of 002 Eq. 10 (in Hz, with alpha the RMS of 2 pi t), within 8 %."""
    rng = np.random.default_rng(1)
    n, duration, e_over_n0, f0 = 128, 1.0, 2000.0, 3.3
    t = (np.arange(n) - n / 2) * duration / n
    sigma2 = n / e_over_n0

    trials = 1500
    signals = np.empty((trials, n), dtype=complex)
    for k in range(trials):  # the draws in the order of one trial after another
        signals[k] = np.exp(1j * (2 * np.pi * f0 * t + rng.uniform(0, 2 * np.pi)))
        signals[k] += math.sqrt(sigma2 / 2) * (rng.standard_normal(n) + 1j * rng.standard_normal(n))

    def power(freqs):  # (trials,) frequencies -> each trial's periodogram at its own frequency
        return np.abs(np.sum(signals * np.exp(-2j * np.pi * freqs[:, None] * t), axis=1)) ** 2

    grid = np.linspace(2.5, 4.1, 200)
    freqs = grid[np.argmax(np.abs(signals @ np.exp(-2j * np.pi * np.outer(grid, t)).T), axis=1)]
    for _ in range(4):  # Newton steps on the periodogram's peak
        h = 1e-4
        p0, p1, p2 = power(freqs - h), power(freqs), power(freqs + h)
        freqs = freqs - (p2 - p0) / (2 * h) / ((p2 - 2 * p1 + p0) / h**2)
    estimates = freqs
    bound = foa_crb_hz(effective_duration_rect_s(duration), 10 * math.log10(e_over_n0), 1.0)
    assert np.std(estimates) == pytest.approx(bound, rel=0.08)


def test_gabor_bandwidth_of_a_flat_band_is_b_over_sqrt_twelve():
    """A code much faster than the front end fills the band flat: beta = 2 pi B_fe / sqrt(12)."""
    band = 1.0e6
    assert gabor_bandwidth_bpsk_rad_s(1.0e9, band) == pytest.approx(2 * math.pi * band / math.sqrt(12), rel=1e-4)
    assert toa_crb_s(2 * math.pi * 1e6, 40.0, 1.0) == pytest.approx(1 / (2 * math.pi * 1e6 * math.sqrt(2e4)))


def test_dll_regimes_meet_continuously():
    """The wide and narrow forms agree at D = pi Rc/B_fe; narrow and very narrow differ only in the squaring
    loss term at D = Rc/B_fe."""
    chip, band, cn0, bn, t = 2.046e6, 8e6, 35.0, 0.2, 1.0
    wide_edge = math.pi * chip / band
    assert dll_regime(wide_edge * 1.0001, chip, band) == DLL_WIDE
    assert dll_regime(wide_edge * 0.9999, chip, band) == DLL_NARROW
    assert dll_regime(0.9999 * chip / band, chip, band) == DLL_VERY_NARROW
    above = dll_sigma_chips(cn0, bn, t, chip, band, wide_edge * (1 + 1e-9))
    below = dll_sigma_chips(cn0, bn, t, chip, band, wide_edge * (1 - 1e-9))
    assert above == pytest.approx(below, rel=1e-6)
    narrow_edge = chip / band
    assert dll_sigma_chips(cn0, bn, t, chip, band, narrow_edge * (1 + 1e-9)) == pytest.approx(
        dll_sigma_chips(cn0, bn, t, chip, band, narrow_edge * (1 - 1e-9)), rel=1e-3)
    # Narrowing the correlator lowers the noise.
    assert dll_sigma_chips(cn0, bn, t, chip, band, 0.1) < dll_sigma_chips(cn0, bn, t, chip, band, 1.0)


def test_ka_band_example_lands_near_the_papers_figures():
    """002 quotes about 1 m of range and below 0.06 mm/s of range-rate for its Ka-band example."""
    sig = KA_EXAMPLE.sigmas()
    assert sig["dll_regime"] == DLL_WIDE
    assert sig["dll_range_m"] == pytest.approx(0.824, abs=0.001)
    assert 0.5 < sig["toa_crb_range_m"] < sig["dll_range_m"]  # a real loop does no better than the bound
    assert sig["pll_range_rate_m_s"] == pytest.approx(3.26e-5, rel=0.01)
    assert sig["pll_range_rate_m_s"] < 6e-5


def test_budget_prints_the_dual_one_way_models():
    proc = run_cli_in_process("budget", SCENARIOS / "links" / "sirbu2023_ka_dual_one_way.yaml")
    assert proc.returncode == 0, proc.stderr
    assert "DLL code tracking (Eq. 11), range" in proc.stdout and "0.824 m" in proc.stdout
    assert "PLL Doppler (Eq. 12), range-rate" in proc.stdout and "0.0326 mm/s" in proc.stdout
