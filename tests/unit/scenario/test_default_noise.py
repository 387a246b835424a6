"""The default process noise derived for the scenario (scenario.default_noise): the floor alone without model
error, each declared error's part against an independent formula, the line the run prints."""

import numpy as np
import pytest

from liaison_cli.dynamics.constants import M_PER_LU, SECONDS_PER_DAY, TU_S
from liaison_cli.scenario.default_noise import FLOOR_PSD_M2_S3, default_noise_line
from liaison_cli.scenario.loading import validate_scenario
from liaison_cli.scenario.setup import prepare_problem

GM_MOON_M3_S2 = 4.9028e12


def _scenario(model_error=None, flt=None, spacecraft_noise=None):
    lunar = {"name": "Lunar", "orbit": "lunar_keplerian",
             "elements": {"a_km": 3000, "e": 0.2, "i_deg": 60, "raan_deg": 0, "argp_deg": 0, "ta_deg": 0}}
    if spacecraft_noise:
        lunar["process_noise_psd_m2_s3"] = spacecraft_noise
    data = {"name": "noise", "duration_days": 1.5, "spacecraft": [{"name": "EML2", "orbit": "eml2_halo"}, lunar],
            "links": [{"receiver": "EML2", "transponder": "Lunar"}], "measurement": {"interval_s": 300},
            "noise": {"sigma_m": 10}, "monte_carlo": {"runs": 1, "seed": 1}}
    if model_error:
        data["model_error"] = model_error
    if flt:
        data["filter"] = flt
    return validate_scenario(data, "noise")


def test_without_model_error_the_default_is_the_floor_and_a_key_overrides_it():
    problem = prepare_problem(_scenario(spacecraft_noise=4e-15))
    assert set(problem.default_noises) == {"EML2"}  # Lunar names its own
    assert problem.default_noises["EML2"].psd_m2_s3 == FLOOR_PSD_M2_S3
    assert "EML2 3e-18" in default_noise_line(problem.default_noises)


def test_a_random_truth_force_adds_its_low_frequency_density_unless_the_filter_carries_it():
    sigma, tau = 1e-9, 3600.0
    error = {"truth_acceleration_sigma_m_s2": sigma, "truth_acceleration_time_constant_s": tau}
    noise = prepare_problem(_scenario(error)).default_noises["Lunar"]
    assert noise.psd_m2_s3 == pytest.approx(FLOOR_PSD_M2_S3 + 2 * sigma**2 * tau, rel=1e-12)
    matched = _scenario(error, {"empirical_acceleration": {"sigma_m_s2": sigma, "time_constant_s": tau}})
    assert prepare_problem(matched).default_noises["Lunar"].psd_m2_s3 == FLOOR_PSD_M2_S3


def test_a_constant_truth_acceleration_adds_twice_its_square_times_the_settle_time():
    a = np.array([3e-10, -4e-10, 0.0])
    noise = prepare_problem(_scenario({"truth_acceleration_m_s2": a.tolist()})).default_noises["EML2"]
    settle_s = 0.75 * SECONDS_PER_DAY  # half of a scenario shorter than 2 d
    assert noise.parts["unmodelled forces"] == pytest.approx(2 * (a @ a) * settle_s, rel=1e-9)


def _gravity_lu(r, mu):
    """The two primaries' attraction in the rotating frame (LU/TU^2), Earth at -mu and Moon at 1 - mu on x: the
    only terms of the CRTBP that depend on mu besides the frame's (which do not)."""
    earth, moon = np.array([-mu, 0.0, 0.0]), np.array([1.0 - mu, 0.0, 0.0])
    d_e, d_m = r - earth, r - moon
    return (-(1 - mu) * d_e / np.linalg.norm(d_e, axis=1, keepdims=True) ** 3
            - mu * d_m / np.linalg.norm(d_m, axis=1, keepdims=True) ** 3)


def test_a_lunar_gm_error_adds_the_rms_of_the_field_it_changes():
    """moon_gm_bias 1e-3 on a 3,000 km orbiter: in the CRTBP the mass ratio moves too, so the filter's Moon sits
    mu f LU (4.7 km) from the truth's; the part against the two primaries' attraction written out here."""
    f = 1e-3
    problem = prepare_problem(_scenario({"moon_gm_bias": f}))
    mu = float(problem.dynamics.params[0])
    mu_filter = mu * (1 + f) / (1 + mu * f)
    r = problem.truth[:, 6:9]
    difference = (_gravity_lu(r, mu) - _gravity_lu(r, mu_filter)) * M_PER_LU / TU_S**2
    rms = np.sqrt(np.mean(np.sum(difference**2, axis=1)))
    assert rms > 2 * f * GM_MOON_M3_S2 / (3000e3) ** 2  # the shifted Moon outweighs the GM itself
    expected = 2 * rms**2 * problem.scenario.settle_days() * SECONDS_PER_DAY  # 0.75 d: half of a 1.5 d arc
    assert problem.default_noises["Lunar"].parts["unmodelled forces"] == pytest.approx(expected, rel=0.02)


def test_the_dated_filters_omitted_bodies_add_their_tidal_acceleration_against_skyfield():
    """eph_eml1_eml2_dsn with the filter keeping only the Moon and the Sun (003's filter) and no process-noise key:
    the part equals 2 a_rms^2 T_settle with a_rms the planets' tidal acceleration on the spacecraft, computed
    here from skyfield's positions on the same DE421 file (system barycentres, as the model's bodies)."""
    skyfield = pytest.importorskip("skyfield.api")
    from liaison_cli.dynamics.constants import LU_KM
    from liaison_cli.dynamics.ephemeris import GM_KM3_S2, J2000_JD, de421_path
    from liaison_cli.scenario.default_noise import _samples
    from liaison_cli.scenario.loading import apply_overrides, load_scenario
    from tests.conftest import SCENARIOS

    scenario, _ = load_scenario(SCENARIOS / "eph_eml1_eml2_dsn.yaml")
    scenario = apply_overrides(scenario, {"ephemeris.filter_bodies": ["moon", "sun"],
                                          "filter.process_noise_accel_m_s2": None})
    problem = prepare_problem(scenario)
    ts, eph = skyfield.load.timescale(builtin=True), skyfield.load_file(de421_path())
    k = _samples(problem.n_steps)
    t = ts.tdb_jd(J2000_JD + (problem.dynamics.epoch_tdb_s + problem.times_s[k]) / 86400.0)
    earth = eph[399].at(t).position.km.T
    for index, name in enumerate(problem.spacecraft):
        r = problem.truth[k, 6 * index : 6 * index + 3] * LU_KM
        a = np.zeros_like(r)
        for body in (1, 2, 4, 5, 6, 7, 8, 9):  # the planets' systems, which the filter leaves out
            rb = eph[body].at(t).position.km.T - earth
            d = rb - r
            a += GM_KM3_S2[body] * (d / np.linalg.norm(d, axis=1, keepdims=True) ** 3
                                    - rb / np.linalg.norm(rb, axis=1, keepdims=True) ** 3)
        rms_m_s2 = np.sqrt(np.mean(np.sum(a**2, axis=1))) * 1e3
        assert 1e-10 < rms_m_s2 < 1e-8  # Venus's tide dominates at cislunar distances
        expected = 2 * rms_m_s2**2 * scenario.settle_days() * SECONDS_PER_DAY
        assert problem.default_noises[name].parts["unmodelled forces"] == pytest.approx(expected, rel=0.01)


def test_the_correlation_time_of_known_signals():
    from liaison_cli.scenario.default_noise import correlation_time_s

    rng = np.random.default_rng(5)
    assert correlation_time_s(np.ones((500, 3)), 60.0, 86400.0) == 499.5 * 60.0  # a constant: every lag it has
    assert correlation_time_s(np.ones((5000, 3)), 60.0, 86400.0) == 86400.0  # ... up to the settle time
    assert correlation_time_s(rng.normal(size=(5000, 3)), 60.0, 86400.0) == 60.0  # white: one interval
    tau_s, dt_s = 1800.0, 60.0
    phi = np.exp(-dt_s / tau_s)
    x = np.zeros((20000, 3))
    for k in range(1, len(x)):  # a first-order Gauss-Markov sequence: its integral time is tau (to its first zero)
        x[k] = phi * x[k - 1] + np.sqrt(1 - phi**2) * rng.normal(size=3)
    assert correlation_time_s(x, dt_s, 86400.0) == pytest.approx(tau_s, rel=0.25)


def test_a_truncated_lunar_field_adds_its_own_part_and_a_matched_one_none():
    def lunar_scenario(filter_degree):
        data = {"name": "field", "duration_days": 1.0,
                "spacecraft": [{"name": "DRO", "orbit": "dro", "period_days": 14.0},
                               {"name": "LLO", "orbit": "lunar_keplerian",
                                "elements": {"a_km": 1837.4, "e": 0.0, "i_deg": 90, "raan_deg": 0, "argp_deg": 0,
                                             "ta_deg": 0}}],
                "links": [{"receiver": "DRO", "transponder": "LLO"}], "measurement": {"interval_s": 120},
                "noise": {"sigma_m": 5}, "moon_gravity": {"degree": 10, "filter_degree": filter_degree},
                "monte_carlo": {"runs": 1, "seed": 1}}
        return prepare_problem(validate_scenario(data, "field")).default_noises

    truncated = lunar_scenario(2)["LLO"]  # the DRO's own omitted field is below the floor: it passes nothing on
    part = truncated.parts["lunar field beyond degree 2"]
    assert set(truncated.parts) == {"floor", "lunar field beyond degree 2"}  # no GM-type residue beside it
    # the 100 km orbit's omitted field is ~1e-4 m/s^2: between one interval's and the settle time's density
    assert 2 * 1e-5**2 * 120.0 < part < 2 * 1e-3**2 * 0.5 * SECONDS_PER_DAY
    assert lunar_scenario(10)["LLO"].psd_m2_s3 == FLOOR_PSD_M2_S3


@pytest.mark.parametrize("filter_degree", [2, 10])
@pytest.mark.parametrize("interval_s", [600, 3600])
def test_the_field_part_is_the_orbits_not_the_data_rates(filter_degree, interval_s):
    """The omitted field's correlation time belongs to the orbit: a 50 km orbit's part at 600 s and at 3600 s is
    within 15 % of its part at 60 s (measured: 1 % and 13 %); field_truncation_psd measures it again on a 10 s
    grid where the epochs resolve it poorly, interpolated at 600 s, flown again at 3600 s. Measured on the epochs
    alone, the 600 s part was 7.0 times (filter degree 10) and 2.5 times (2) the 60 s one; interpolated at 3600 s
    (the cubic across 3.3 rad of orbit), 0.33 and 0.14 times."""
    def field_part(interval_s):
        data = {"name": "field", "duration_days": 1.0,
                "spacecraft": [{"name": "DRO", "orbit": "dro", "period_days": 14.0},
                               {"name": "LLO", "orbit": "lunar_keplerian",
                                "elements": {"altitude_km": 50.0, "e": 0.0, "i_deg": 60, "raan_deg": 0}}],
                "links": [{"receiver": "DRO", "transponder": "LLO"}], "measurement": {"interval_s": interval_s},
                "noise": {"sigma_m": 5}, "moon_gravity": {"degree": 30, "filter_degree": filter_degree},
                "monte_carlo": {"runs": 1, "seed": 1}}
        return prepare_problem(validate_scenario(data, "field")).default_noises["LLO"].parts[
            f"lunar field beyond degree {filter_degree}"]

    assert field_part(interval_s) / field_part(60) == pytest.approx(1.0, abs=0.15)


def test_hermite_resampling_follows_a_circular_orbit():
    """A 100 km lunar orbit sampled every 300 s, resampled every 10 s: within 25 m and 0.3 m/s of the circle (the
    cubic's error, r (w h)^4 / 384, is 24 m; the velocity sets only the radial / in-track / cross-track axes, here
    within 0.01 deg), and equal to the samples at the samples."""
    from liaison_cli.scenario.default_noise import hermite_resample

    w, r = 2 * np.pi / 7070.0, 1837.4
    def circle(t):
        return np.stack([r * np.cos(w * t), r * np.sin(w * t), 0 * t, -r * w * np.sin(w * t), r * w * np.cos(w * t),
                         0 * t], axis=1)

    times = np.arange(0.0, 7070.0, 300.0)
    fine, fine_times = hermite_resample(circle(times), times, 30)
    assert len(fine) == 30 * (len(times) - 1) + 1 and np.allclose(np.diff(fine_times), 10.0)
    error = fine - circle(fine_times)
    assert np.max(np.linalg.norm(error[:, :3], axis=1)) < 0.025
    assert np.max(np.linalg.norm(error[:, 3:], axis=1)) < 3e-4
    assert np.allclose(fine[::30], circle(times), rtol=0.0, atol=1e-9)


def test_a_linked_spacecraft_takes_a_share_of_the_field_error_it_sees_through_the_link():
    """The DRO has no field error of its own worth a part, but the 100 km orbiter it ranges to has: the DRO's
    default takes COUPLING_SHARE of the orbiter's 2 a^2 tau (its field part is FIELD_PART_FACTOR of that), also
    when the orbiter names its own process noise; a spacecraft it has no link with passes it nothing."""
    from liaison_cli.scenario.default_noise import COUPLING_SHARE, FIELD_PART_FACTOR

    def defaults(llo_psd=None, linked=True):
        llo = {"name": "LLO", "orbit": "lunar_keplerian", "elements": {"altitude_km": 100.0, "e": 0.0, "i_deg": 90}}
        if llo_psd is not None:
            llo["process_noise_psd_m2_s3"] = llo_psd
        data = {"name": "field", "duration_days": 1.0,
                "spacecraft": [{"name": "DRO", "orbit": "dro", "period_days": 14.0}, llo,
                               {"name": "Halo", "orbit": "eml2_halo"}],
                "links": [{"receiver": "DRO", "transponder": "LLO" if linked else "Halo"},
                          {"receiver": "Halo", "transponder": "DRO"}],
                "measurement": {"interval_s": 120}, "noise": {"sigma_m": 5},
                "moon_gravity": {"degree": 10, "filter_degree": 2}, "monte_carlo": {"runs": 1, "seed": 1}}
        return prepare_problem(validate_scenario(data, "field")).default_noises

    both = defaults()
    field_part = both["LLO"].parts["lunar field beyond degree 2"]
    assert both["DRO"].parts["lunar field via LLO"] == pytest.approx(COUPLING_SHARE * field_part / FIELD_PART_FACTOR)
    assert "lunar field via LLO" not in both["Halo"].parts  # no link to the orbiter
    assert defaults(llo_psd=1e-9)["DRO"].parts["lunar field via LLO"] == both["DRO"].parts["lunar field via LLO"]
    assert not any(what.startswith("lunar field via") for what in defaults(linked=False)["DRO"].parts)
