"""Process noise as physics (issue 34 item 4): the scenario keys of the two conventions, their rules, the
default PSD, the per-spacecraft overrides, and what the shipped scenarios and templates give."""

import numpy as np
import pytest

from liaison_cli.campaign.studies.study003 import process_noise_text
from liaison_cli.dynamics.constants import M_PER_LU, M_S_PER_VU
from liaison_cli.errors import ScenarioError
from liaison_cli.estimation.process_noise import psd_process_noise, spacecraft_process_noise
from liaison_cli.scenario.default_noise import FLOOR_PSD_M2_S3
from liaison_cli.scenario.estimation_settings import PROCESS_NOISE_PSD, PROCESS_NOISE_SIGMA_A
from liaison_cli.scenario.setup import prepare_problem
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from liaison_cli.scenario.templates import TEMPLATE_DIR, TEMPLATES
from tests.conftest import SCENARIOS

SHIPPED = sorted(SCENARIOS.glob("*.yaml")) + sorted(p for p in SCENARIOS.glob("*/*.yaml") if p.parent.name != "links")
# The papers' scenarios keep their per-step sigma_a; the lunar ones (issue 46) are new, each spacecraft on a PSD.
PAPERS = [p for p in SHIPPED if p.parent.name != "lunar"]
LUNAR = [p for p in SHIPPED if p.parent.name == "lunar"]
# smoke without its per-spacecraft sigma_a: the filter's keys alone decide
BARE = {"spacecraft.0.process_noise_accel_m_s2": None, "spacecraft.1.process_noise_accel_m_s2": None}


@pytest.fixture(scope="module")
def smoke():
    return load_scenario(SCENARIOS / "smoke.yaml")[0]


def _blocks(scenario):
    """Per estimated spacecraft, its 6 x 6 Q block in SI units (m, m/s)."""
    Q = prepare_problem(scenario).filter.Q
    scale = np.array([M_PER_LU] * 3 + [M_S_PER_VU] * 3)
    return [Q[a:a + 6, a:a + 6] * np.outer(scale, scale) for a in range(0, 12, 6)]


def _psd(q, scenario):
    return psd_process_noise(q, scenario.measurement.interval_s, 1.0, 1.0)


def _sigma_a(sigma_a, scenario, model="continuous_white_acceleration"):
    return spacecraft_process_noise(sigma_a, scenario.measurement.interval_s, model, 1.0, 1.0)


def test_neither_key_gives_the_derived_default_psd_the_floor_without_model_error(smoke):
    scenario = apply_overrides(smoke, BARE)
    assert scenario.filter.process_noise_accel_m_s2 is None and scenario.filter.process_noise_psd_m2_s3 is None
    for block in _blocks(scenario):
        np.testing.assert_allclose(block, _psd(FLOOR_PSD_M2_S3, scenario), rtol=1e-12, atol=0)


def test_each_filter_key_gives_its_convention_and_velocity_only_applies_to_sigma_a_only(smoke):
    psd = apply_overrides(smoke, {**BARE, "filter.process_noise_psd_m2_s3": 4e-13,
                                  "filter.process_noise_model": "velocity_only"})
    for block in _blocks(psd):  # the PSD takes the continuous form whatever process_noise_model says
        np.testing.assert_allclose(block, _psd(4e-13, psd), rtol=1e-12, atol=0)
    per_step = apply_overrides(smoke, {**BARE, "filter.process_noise_accel_m_s2": 2e-8,
                                       "filter.process_noise_model": "velocity_only"})
    for block in _blocks(per_step):
        np.testing.assert_allclose(block, _sigma_a(2e-8, per_step, "velocity_only"), rtol=1e-12, atol=0)


def test_a_spacecraft_key_overrides_the_filter_key_of_either_convention(smoke):
    mixed = apply_overrides(smoke, {"spacecraft.0.process_noise_accel_m_s2": None,
                                    "spacecraft.0.process_noise_psd_m2_s3": 3e-10,
                                    "spacecraft.1.process_noise_accel_m_s2": None,
                                    "filter.process_noise_accel_m_s2": 1e-9,
                                    "filter.process_noise_model": "continuous_white_acceleration"})
    first, second = _blocks(mixed)  # EML2's own PSD over the filter's sigma_a; Lunar takes the filter's
    np.testing.assert_allclose(first, _psd(3e-10, mixed), rtol=1e-12, atol=0)
    np.testing.assert_allclose(second, _sigma_a(1e-9, mixed), rtol=1e-12, atol=0)
    other = apply_overrides(smoke, {"spacecraft.0.process_noise_accel_m_s2": None,
                                    "spacecraft.1.process_noise_accel_m_s2": 1e-6,
                                    "filter.process_noise_psd_m2_s3": 1e-14})
    assert [other.filter.process_noise_of(sc) for sc in other.spacecraft] == [(PROCESS_NOISE_PSD, 1e-14),
                                                                             (PROCESS_NOISE_SIGMA_A, 1e-6)]
    assert "1e-14 m^2/s^3 for EML2" in process_noise_text(other) and "1e-06 m/s^2 for Lunar" in process_noise_text(other)


@pytest.mark.parametrize("overrides, where", [
    ({"filter.process_noise_psd_m2_s3": 1e-12, "filter.process_noise_accel_m_s2": 1e-7}, "'filter'"),
    ({"spacecraft.1.process_noise_psd_m2_s3": 1e-12}, "'spacecraft[1]'"),  # beside its own sigma_a 1e-10
])
def test_at_most_one_convention_per_filter_and_per_spacecraft(smoke, overrides, where):
    with pytest.raises(ScenarioError) as refused:
        apply_overrides(smoke, overrides, "both.yaml")
    line = str(refused.value)
    assert "\n" not in line and where in line and "not both" in line
    assert "process_noise_psd_m2_s3" in line and "process_noise_accel_m_s2" in line


def test_a_psd_scenario_names_its_convention_in_the_study_header(smoke):
    assert process_noise_text(apply_overrides(smoke, {**BARE, "filter.process_noise_psd_m2_s3": 2e-13})) == (
        "SNC PSD 2e-13 m^2/s^3 (isotropic white acceleration, independent of the interval)")
    assert process_noise_text(smoke) == "SNC sigma_a 1e-10 m/s^2 (per-step convention, continuous_white_acceleration)"


@pytest.mark.parametrize("path", PAPERS, ids=[p.stem for p in PAPERS])
def test_shipped_ekf_scenarios_state_the_per_step_convention(path):
    """The reproductions keep their numbers: no estimated spacecraft of a shipped EKF scenario falls to the
    default PSD (the former default sigma_a, 1e-7 m/s^2, is written out where it was relied on)."""
    scenario = load_scenario(path)[0]
    if scenario.estimator_descriptor().process_noise:
        assert {scenario.filter.process_noise_of(sc)[0] for sc in scenario.spacecraft if sc.role == "estimated"} == {
            PROCESS_NOISE_SIGMA_A}


@pytest.mark.parametrize("path", LUNAR, ids=[p.stem for p in LUNAR])
def test_the_lunar_scenarios_give_each_spacecraft_a_psd(path):
    scenario = load_scenario(path)[0]
    assert all(sc.process_noise_psd_m2_s3 is not None for sc in scenario.spacecraft if sc.role == "estimated")
    assert "process_noise_accel_m_s2" not in path.read_text()


@pytest.mark.parametrize("kind", sorted(TEMPLATES))
def test_templates_are_new_scenarios_on_the_psd(kind):
    """A template with process noise gives it as a PSD, at the filter and wherever a spacecraft has its own, or
    names none and takes the default derived for the scenario (issue 50: lunar-relay)."""
    path = TEMPLATE_DIR / f"{kind}.yaml"
    scenario = load_scenario(path)[0]
    if scenario.estimator_descriptor().process_noise:
        text = path.read_text()
        assert "process_noise_accel_m_s2" not in text
        assert scenario.filter.process_noise_psd_m2_s3 is not None or "process_noise" not in text


def test_a_filter_key_every_spacecraft_overrides_is_refused_in_one_line(smoke):
    """Issue 47: a filter-level process-noise key that every estimated spacecraft overrides applied to none,
    silently; now refused naming the key, its value and the spacecraft. One spacecraft without its own key keeps it
    alive."""
    with pytest.raises(ScenarioError, match=r"filter.process_noise_psd_m2_s3 = 1e-15 applies to no spacecraft.*"
                                            r"\(EML2, Lunar\)"):
        apply_overrides(smoke, {"filter.process_noise_psd_m2_s3": 1e-15})
    alive = apply_overrides(smoke, {"filter.process_noise_psd_m2_s3": 1e-15,
                                    "spacecraft.0.process_noise_accel_m_s2": None})
    assert alive.filter.process_noise_of(alive.spacecraft[0]) == (PROCESS_NOISE_PSD, 1e-15)
