"""Three-spacecraft networks: star / mesh expansion, bad topologies, and the 001 §6.6 trends."""

import pandas as pd
import pytest

from liaison_cli.campaign.engine.results import summary_table
from liaison_cli.campaign.engine.runner import run_campaign
from liaison_cli.scenario.loading import load_scenario
from liaison_cli.campaign.studies.compare import compare_rows
from tests.conftest import SCENARIOS, assert_one_line_error, edited_scenario, run_cli_in_process


def _links(name):
    scenario, _ = load_scenario(SCENARIOS / f"{name}.yaml")
    return [(link.receiver, link.transponder) for link in scenario.links]


def test_star_and_mesh_expand_to_links():
    assert _links("c1_star_eml2_hub") == [("EML2", "EML1"), ("EML2", "Lunar")]
    assert _links("c3_star_lunar_hub") == [("Lunar", "EML2"), ("Lunar", "EML1")]
    assert _links("m1_mesh_eml2_eml1_lunar") == [("EML2", "EML1"), ("EML2", "Lunar"), ("EML1", "Lunar")]
    for name in ("c4_star_eml2_noncoplanar", "c5_star_eml2_nrho", "c6_star_eml2_lyapunov"):
        assert len(_links(name)) == 2
    for name in ("m2_mesh_eml2_noncoplanar", "m3_mesh_eml2_nrho", "m4_mesh_eml2_lyapunov"):
        assert len(_links(name)) == 3


BAD = {
    "star_without_hub": ("topology: {kind: star, hub: Lunar}", "topology: {kind: star}",
                         ["star needs a 'hub'", "EML2, EML1, Lunar"]),
    "unknown_hub": ("topology: {kind: star, hub: Lunar}", "topology: {kind: star, hub: Gateway}",
                    ["'Gateway' is not a spacecraft", "EML2, EML1, Lunar"]),
    "unknown_kind": ("topology: {kind: star, hub: Lunar}", "topology: {kind: ring}", ["'ring'", "star, mesh"]),
    "link_to_unknown": ("topology: {kind: star, hub: Lunar}",
                        "links:\n  - {receiver: Lunar, transponder: Gateway}", ["transponder", "'Gateway'"]),
    "links_and_topology": ("topology: {kind: star, hub: Lunar}",
                           "topology: {kind: star, hub: Lunar}\nlinks:\n  - {receiver: EML2, transponder: EML1}",
                           ["either 'links' or 'topology'"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_topology_is_one_line_exit_2(tmp_path, case):
    old, new, expected = BAD[case]
    path = edited_scenario(tmp_path, "c3_star_lunar_hub.yaml", old, new)
    assert_one_line_error(run_cli_in_process("run", path, "--output", tmp_path / "o"), path, expected)


def test_lunar_hub_beats_halo_hubs_and_mesh_beats_every_star():
    """001 §6.6: C3 (lunar orbiter as hub) beats C1/C2; the mesh M1 beats C1-C3 (3-spacecraft average)."""
    rows = {}
    for name in ("c1_star_eml2_hub", "c2_star_eml1_hub", "c3_star_lunar_hub", "m1_mesh_eml2_eml1_lunar"):
        scenario, _ = load_scenario(SCENARIOS / f"{name}.yaml")
        rows[name[:2]] = compare_rows(scenario, summary_table(run_campaign(scenario, runs=6, jobs=2, progress=False)))
    table = pd.DataFrame(rows).T
    assert (table.runs_ok == 6).all()
    pos = table.rms_position_m
    assert pos["c3"] < min(pos["c1"], pos["c2"]), pos
    assert pos["m1"] < min(pos["c1"], pos["c2"], pos["c3"]), pos
    assert table.rms_position_after_day1_m["m1"] < table.rms_position_after_day1_m[["c1", "c2", "c3"]].min()
