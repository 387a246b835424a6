"""A CRTBP export read back (issue 35): `liaison export` writes a CRTBP run's OEMs in liaison's Earth-Moon rotating
frame with MET tags (the frame's definition and t0 in COMMENT lines); scenario.orbit_files.crtbp_oem_truth_lu
reads such a file into a CRTBP truth, interpolated as the file says, and refuses any other frame, centre or time
system in one line naming the file, the key, its value and what is allowed."""

import json

import numpy as np
import pytest
import yaml

from liaison_cli.campaign.exchange.export import export_run
from liaison_cli.campaign.engine.results import stream_campaign
from liaison_cli.dynamics.constants import M_PER_LU, VU_KM_S
from liaison_cli.errors import ExchangeFileError
from liaison_cli.exchange.oem import read_oem
from liaison_cli.scenario.orbit_files import crtbp_oem_truth_lu
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from liaison_cli.scenario.setup import prepare_problem
from tests.cli.crtbp_oem_hook import CRTBP_OEM_PENDING
from tests.conftest import SCENARIOS, assert_one_line_error, run_cli_in_process

SHORT = {"duration_days": 0.5}  # smoke: EML2 halo + lunar orbiter (a 9,000 km, e 0.4), 187.5 s epochs
HALF = {"duration_days": 0.5, "measurement": {"interval_s": 93.75}}  # an epoch between every two OEM lines


def _spacecraft_with(oem, name="Lunar"):
    from types import SimpleNamespace

    return SimpleNamespace(name=name, orbit_file=SimpleNamespace(oem=str(oem), object_name=None))


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """smoke (0.5 d) run 0 of 1, exported in KVN: (scenario, export folder)."""
    scenario, text = load_scenario(SCENARIOS / "smoke.yaml")
    scenario = apply_overrides(scenario, SHORT)
    result = tmp_path_factory.mktemp("crtbp")
    stream_campaign(scenario, result, text, runs=1, jobs=1, progress=False)
    folder = result / "ccsds"
    folder.mkdir()
    export_run(result, 0, ("kvn",), folder)
    return scenario, folder


def test_a_crtbp_export_reads_back_to_the_interpolations_accuracy(exported):
    """On the OEM's lines the truth is the file's, to the km <-> LU conversions' rounding (measured: 4.3e-8 m,
    lunar orbiter; 2.7e-9 m, EML2 halo); halfway between lines (LAGRANGE 7 through 187.5 s lines; the orbiter's
    period is 3.4 h) it is the CRTBP truth propagated to those epochs to the interpolation's accuracy (measured:
    3.2e-5 m and 3.0e-8 m/s, orbiter; 2.7e-6 m and 2e-12 m/s, halo)."""
    scenario, folder = exported
    original = prepare_problem(scenario)
    halfway = prepare_problem(apply_overrides(scenario, HALF))
    scale = np.array([M_PER_LU] * 3 + [VU_KM_S * 1e3] * 3)
    for i, name in enumerate(original.spacecraft):
        sc = _spacecraft_with(folder / f"{name}_truth.oem", name)
        block = slice(6 * i, 6 * i + 6)
        on_lines = (crtbp_oem_truth_lu(sc, original.times_s) - original.truth[:, block]) * scale
        between = (crtbp_oem_truth_lu(sc, halfway.times_s) - halfway.truth[:, block]) * scale
        assert np.max(np.abs(on_lines[:, :3])) < 1e-6 and np.max(np.abs(on_lines[:, 3:])) < 1e-9
        assert np.max(np.linalg.norm(between[:, :3], axis=1)) < 1e-4
        assert np.max(np.linalg.norm(between[:, 3:], axis=1)) < 1e-6


@pytest.mark.parametrize("key, value", [("REF_FRAME", "ICRF"), ("CENTER_NAME", "EARTH"), ("TIME_SYSTEM", "UTC")])
def test_a_crtbp_oem_in_another_frame_is_one_line(exported, tmp_path, key, value):
    _, folder = exported
    text = (folder / "Lunar_truth.oem").read_text()
    old = next(line for line in text.splitlines() if line.startswith(key))
    path = tmp_path / "other.oem"
    path.write_text(text.replace(old, f"{key:<25}= {value}"))
    if key == "TIME_SYSTEM":  # a dated time system needs dated tags (read before the frame is checked)
        path.write_text(path.read_text().replace("0000-0", "2025-0"))
    with pytest.raises(ExchangeFileError) as refused:
        crtbp_oem_truth_lu(_spacecraft_with(path), np.array([0.0, 187.5]))
    message = str(refused.value)
    assert message.startswith(f"{path}: {key} = {value}: ") and "allowed:" in message and "\n" not in message


@CRTBP_OEM_PENDING
def test_a_crtbp_scenario_runs_on_its_own_export(exported, tmp_path):
    """The whole path: a CRTBP scenario whose orbiter is the exported truth OEM validates, runs, exports, and its
    truth OEM is the original's; the same scenario given a dated OEM is refused at set-up in one line, exit 2."""
    scenario, folder = exported
    data = scenario.model_dump(mode="json", exclude={"topology"})
    lunar = next(sc for sc in data["spacecraft"] if sc["name"] == "Lunar")
    for key in ("elements", "orbit_file"):
        lunar.pop(key, None)
    lunar["orbit"] = {"oem": str(folder / "Lunar_truth.oem")}
    path = tmp_path / "again.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    assert run_cli_in_process("validate", path).returncode == 0
    ran = run_cli_in_process("run", path, "--runs", "1", "--jobs", "1", "--quiet", "--json", "--output",
                             tmp_path / "again")
    assert ran.returncode == 0 and json.loads(ran.stdout)["runs_ok"] == 1, ran.stderr
    assert run_cli_in_process("export", tmp_path / "again", "--format", "kvn").returncode == 0
    (before,) = read_oem(folder / "Lunar_truth.oem")
    (after,) = read_oem(tmp_path / "again" / "ccsds-run0" / "Lunar_truth.oem")
    assert after.tags == before.tags and np.array_equal(after.states_km, before.states_km)
    dated = tmp_path / "dated.oem"
    dated.write_text((folder / "Lunar_truth.oem").read_text().replace("EARTH_MOON_ROTATING", "EME2000"))
    lunar["orbit"] = {"oem": str(dated)}
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    refused = run_cli_in_process("run", path, "--runs", "1", "--quiet", "--output", tmp_path / "refused")
    assert_one_line_error(refused, dated, ["REF_FRAME = EME2000", "allowed: EARTH_MOON_ROTATING"])


def test_the_tdm_states_its_range_convention_and_reads_back(exported):
    """TDM leaves a RANGE in km open to a one-way or a round-trip distance: the header and each RANGE segment say
    liaison's two-way range is the one-way equivalent; our reader still reads the file (comments included)."""
    from liaison_cli.exchange.tdm import RANGE_ONE_WAY_COMMENT, RANGE_TWO_WAY_COMMENT, range_convention, read_tdm

    _, folder = exported
    text = (folder / "measurements.tdm").read_text()
    header, _, segments = text.partition("META_START")
    assert f"COMMENT {RANGE_TWO_WAY_COMMENT}" in header and f"COMMENT {RANGE_TWO_WAY_COMMENT}" in segments
    assert "one-way equivalent" in RANGE_TWO_WAY_COMMENT and "half the round-trip" in RANGE_TWO_WAY_COMMENT
    (track,) = read_tdm(folder / "measurements.tdm")
    assert track.keyword == "RANGE" and track.paths == (("EML2", "Lunar", "EML2"),)
    assert RANGE_TWO_WAY_COMMENT in track.comments and len(track.values) > 100
    assert range_convention("RANGE", (("B", "A"),)) == (RANGE_ONE_WAY_COMMENT,)  # a pseudorange's one-way path
    assert range_convention("DOPPLER_INSTANTANEOUS", (("A", "B", "A"),)) == ()
