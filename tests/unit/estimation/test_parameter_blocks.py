"""Dynamics-parameter states (estimation.blocks.BLOCK_PARAMETER): the coupled covariance prediction against
the dense product, the layout's coupling map, and the scenario rules that ask the dynamics descriptor."""

import numpy as np
import pytest

from liaison_cli.estimation.blocks import (BLOCK_CLOCK, BLOCK_CONSTANT, BLOCK_PARAMETER, BLOCK_SPACECRAFT,
                                          FORMATION, StateBlock, StateLayout, owner_name)
from liaison_cli.estimation.ekf import predict_covariance_blocks


def _layout():
    return StateLayout((StateBlock(BLOCK_SPACECRAFT, 6, "A"), StateBlock(BLOCK_SPACECRAFT, 6, "B"),
                        StateBlock(BLOCK_CLOCK, 2, "A"), StateBlock(BLOCK_PARAMETER, 1, owner_name("cr", FORMATION)),
                        StateBlock(BLOCK_CONSTANT, 1, owner_name("bias", 0))))


def test_layout_maps_every_spacecraft_to_the_formation_parameter():
    kind, start, size, parameter = _layout().arrays()
    assert list(parameter) == [14, 14, -1, -1, -1]
    one = StateLayout((StateBlock(BLOCK_SPACECRAFT, 6, "A"), StateBlock(BLOCK_SPACECRAFT, 6, "B"),
                       StateBlock(BLOCK_PARAMETER, 1, owner_name("cr", "B"))))
    assert list(one.arrays()[3]) == [-1, 12, -1]


def test_coupled_prediction_is_the_dense_product():
    """Phi = block-diagonal + the parameter's columns gamma under both spacecraft: Phi P Phi^T + Q from the block
    products and the rank-one couplings equals numpy's dense product to 1e-14 relative (no process noise on
    the parameter, as filter_arrays builds Q)."""
    rng = np.random.default_rng(7)
    layout = _layout()
    kind, start, size, _ = layout.arrays()
    n = layout.n
    A = rng.standard_normal((n, n))
    P = A @ A.T + n * np.eye(n)
    Phi = np.zeros((n, n))
    Phi[0:6, 0:6] = rng.standard_normal((6, 6))
    Phi[6:12, 6:12] = rng.standard_normal((6, 6))
    Phi[12:14, 12:14] = [[1.0, 0.3], [0.0, 1.0]]
    Phi[14, 14] = Phi[15, 15] = 1.0
    Phi[0:6, 14] = rng.standard_normal(6)
    Phi[6:12, 14] = rng.standard_normal(6)
    Q = np.zeros((n, n))
    Q[0:6, 0:6] = np.diag(rng.uniform(0.1, 1, 6))
    Q[6:12, 6:12] = np.diag(rng.uniform(0.1, 1, 6))
    Q[12:14, 12:14] = np.diag([0.2, 0.1])
    out = predict_covariance_blocks(P, Phi, Q, np.empty((n, n)), kind, start, size)
    dense = Phi @ P @ Phi.T + Q
    assert np.max(np.abs(out - dense)) < 1e-14 * np.max(np.abs(dense))
    without = Phi.copy()
    without[0:12, 14] = 0.0  # the coupling matters: leaving it out is far off
    assert np.max(np.abs(predict_covariance_blocks(P, without, Q, np.empty((n, n)), kind, start, size) - dense)) > 0.1


@pytest.mark.parametrize("edits, fragment", [
    ({"filter": {"estimated_parameters": {"cr": 0.05}}}, "dynamics: crtbp has no such parameter; allowed: none"),
], ids=["crtbp"])
def test_a_parameter_the_model_lacks_is_one_line(edits, fragment):
    from liaison_cli.errors import ScenarioError
    from liaison_cli.scenario.loading import read_scenario_text
    from liaison_cli.scenario.loading import validate_scenario
    from tests.conftest import SCENARIOS

    data = read_scenario_text(SCENARIOS / "smoke.yaml")[0]
    data.setdefault("filter", {}).update(edits["filter"])
    with pytest.raises(ScenarioError) as refused:
        validate_scenario(data, "s.yaml")
    assert fragment in str(refused.value) and "\n" not in str(refused.value)


@pytest.mark.parametrize("edits, fragment", [
    ({"ephemeris.area_to_mass_m2_kg": 0.0}, "no solar radiation pressure, so no data can reach C_R"),
], ids=["no-srp"])
def test_dated_parameter_rules(edits, fragment):
    from liaison_cli.errors import ScenarioError
    from liaison_cli.scenario.loading import read_scenario_text
    from liaison_cli.scenario.loading import validate_scenario
    from tests.conftest import SCENARIOS

    data = read_scenario_text(SCENARIOS / "eph_eml1_eml2_dsn.yaml")[0]
    data["filter"]["estimated_parameters"] = {"cr": 0.05}
    validate_scenario(data, "s.yaml")  # the EKF estimates it
    for dotted, value in edits.items():
        section, key = dotted.split(".")
        data[section][key] = value
    with pytest.raises(ScenarioError) as refused:
        validate_scenario(data, "s.yaml")
    assert fragment in str(refused.value)
