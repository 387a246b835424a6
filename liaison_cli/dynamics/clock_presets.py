"""Named oscillator presets for the two-state clock model (dynamics.clock), as data with their sources.

Conversions: from the power-law coefficients h_0 (white FM) and h_-2 (random-walk FM) of the fractional
frequency spectrum, sigma1^2 = h_0 / 2 and sigma2^2 = 2 pi^2 h_-2; from Allan deviation points, through
sigma_y(tau)^2 = sigma1^2 / tau + sigma2^2 tau / 3. mu2 is the deterministic aging (1/s); mu1, a
deterministic frequency offset, is left to the scenario (0 in every preset). Flicker FM (h_-1) is not in
the two-state model and is dropped.
"""

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class ClockPreset:
    sigma1_s_per_sqrt_s: float
    sigma2_per_sqrt_s: float
    mu2_per_s: float
    source: str


def _from_h(h0: float, h_minus2: float) -> tuple[float, float]:
    return math.sqrt(h0 / 2.0), math.sqrt(2.0 * math.pi**2 * h_minus2)


_BROWN_HWANG = "Brown & Hwang, Introduction to Random Signals and Applied Kalman Filtering, 4th ed. (2012), §9.3"

CLOCK_PRESETS: dict[str, ClockPreset] = {
    # Temperature-compensated crystal: h0 = 2e-19, h-2 = 2e-20.
    "tcxo": ClockPreset(*_from_h(2e-19, 2e-20), 0.0, f"{_BROWN_HWANG}: TCXO h0 2e-19, h-2 2e-20"),
    # Oven-controlled crystal: h0 = 2e-25, h-2 = 6e-25.
    "ocxo": ClockPreset(*_from_h(2e-25, 6e-25), 0.0, f"{_BROWN_HWANG}: OCXO h0 2e-25, h-2 6e-25"),
    # Rubidium: h0 = 2e-22, h-2 = 1e-30.
    "rubidium": ClockPreset(*_from_h(2e-22, 1e-30), 0.0, f"{_BROWN_HWANG}: rubidium h0 2e-22, h-2 1e-30"),
    # Ultra-stable quartz oscillator: sigma_y = 1e-13 at 1 s and at 100 s (GRAIL in-flight USO Allan
    # deviations below 1e-13 for 1-100 s; NASA Tech Briefs, Feb. 2013, 'Measurements of USO Allan
    # deviations in space'). sigma1 = 1e-13; sigma2 from the 100 s point.
    "uso": ClockPreset(1e-13, math.sqrt(3.0 * (1e-26 - 1e-26 / 100.0) / 100.0), 0.0,
                       "GRAIL USO in flight: Allan deviation 1e-13 at 1 s and 100 s (NASA Tech Briefs, Feb. 2013)"),
    # Chip-scale atomic clock (Microsemi SA.45s datasheet): ADEV 3e-10 at 1 s (1e-11 at 1000 s, the same
    # white FM), aging 9e-10 per month (30 d). No random-walk FM is specified.
    "csac": ClockPreset(3e-10, 0.0, 9e-10 / (30 * 86400.0),
                        "Microsemi SA.45s CSAC datasheet: ADEV 3e-10 at 1 s, aging 9e-10 / month"),
}


def clock_preset_names() -> list[str]:
    return list(CLOCK_PRESETS)
