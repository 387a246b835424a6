"""The estimator descriptor (estimation.estimator): the scenario's rules and its arrays ask it what an
estimator carries and supports; no module outside estimation/ compares an estimator's name."""

import ast
from pathlib import Path

import pytest

import liaison_cli
from liaison_cli.estimation.blocks import BLOCK_CLOCK, BLOCK_CONSTANT
from liaison_cli.estimation.estimators import BATCH, EKF, ESTIMATORS, estimate, get_estimator
from liaison_cli.scenario.filter_arrays import state_layout
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from tests.conftest import SCENARIOS, assert_one_line_error, edited_scenario, run_cli_in_process

PACKAGE = Path(liaison_cli.__file__).parent


def estimator_names_compared_outside_estimation(package_root: Path) -> list[str]:
    """Places outside estimation/ that compare with, or pass, an estimator's name as a literal."""
    found = []
    for path in package_root.rglob("*.py"):
        if path.relative_to(package_root).parts[0] == "estimation":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            operands = [node.left, *node.comparators] if isinstance(node, ast.Compare) else (
                node.args if isinstance(node, ast.Call) else [])
            found += [f"{path.relative_to(package_root)}:{node.lineno}" for operand in operands
                      if isinstance(operand, ast.Constant) and operand.value in ESTIMATORS]
    return sorted(found)


def test_no_estimator_name_is_compared_outside_estimation():
    assert estimator_names_compared_outside_estimation(PACKAGE) == []


@pytest.mark.parametrize("text", ["def f(s):\n    return s.estimator != 'ekf'\n",
                                  "def f(p, a):\n    return estimate('batch', a)\n"])
def test_the_name_check_catches_a_comparison(tmp_path, text):
    (tmp_path / "scenario").mkdir()
    (tmp_path / "scenario" / "rules.py").write_text(text)
    assert len(estimator_names_compared_outside_estimation(tmp_path)) == 1


def test_the_registry_runs_each_descriptor_entry_point():
    assert ESTIMATORS == {"ekf": EKF, "batch": BATCH}
    assert get_estimator("batch") is BATCH
    with pytest.raises(ValueError, match="unknown estimator 'ukf'; allowed: ekf, batch"):
        get_estimator("ukf")
    calls = []
    ESTIMATORS["probe"] = EKF.__class__(name="probe", summary="", run=lambda *args: calls.append(args) or "ran")
    try:
        assert estimate("probe", "arrays", "x0", "y", "truth") == "ran"
    finally:
        del ESTIMATORS["probe"]
    assert calls == [("arrays", "x0", "y", "truth")]


def test_the_layout_carries_what_the_descriptor_says():
    """002's anchors carry clocks: the batch (carries_clocks false) leaves them to clock_sync, the EKF
    estimates them; link biases are carried by both."""
    batch, _ = load_scenario(SCENARIOS / "nrho_gateway_anchors.yaml")
    ekf = apply_overrides(batch, {"estimator": "ekf", "batch": None})
    for scenario, estimator in ((batch, BATCH), (ekf, EKF)):
        with_bias = apply_overrides(scenario, {"filter.bias": "estimate", "filter.bias_apriori_sigma_m": 1.0})
        kinds = [block.kind for block in state_layout(with_bias).blocks]
        assert (kinds.count(BLOCK_CLOCK) == 3) == estimator.carries_clocks
        assert kinds.count(BLOCK_CLOCK) in (0, 3)
        assert kinds.count(BLOCK_CONSTANT) == 2  # one bias per link


def test_a_considered_bias_with_the_batch_is_one_line(tmp_path):
    """The batch has no consider treatment (it would estimate the bias as a state): refused."""
    assert not BATCH.consider and EKF.consider
    path = edited_scenario(tmp_path, "nrho_gateway_anchors.yaml", "filter:\n",
                           "filter:\n  bias: consider\n  bias_apriori_sigma_m: 1\n")
    assert_one_line_error(run_cli_in_process("validate", path), path,
                          ["filter.bias = 'consider' with estimator: batch", "allowed: bias estimate or ignore",
                           "estimator: ekf"])


def test_the_smoother_and_manoeuvres_follow_the_descriptor(tmp_path):
    assert not BATCH.smoother and not BATCH.carries_manoeuvres
    path = edited_scenario(tmp_path, "nrho_gateway_anchors.yaml", "filter:\n", "filter:\n  smoother: rts\n")
    assert_one_line_error(run_cli_in_process("validate", path), path,
                          ["filter.smoother = 'rts'", "estimator: batch takes no smoother",
                           "allowed with estimator: ekf"])
    path = edited_scenario(tmp_path, "nrho_gateway_anchors.yaml", "    orbit: nrho_anchor_1\n",
                           "    orbit: nrho_anchor_1\n    manoeuvre: {epoch_days: 1, delta_v_m_s: [0.1, 0, 0], "
                           "apriori_sigma_m_s: 0.1}\n")
    assert_one_line_error(run_cli_in_process("validate", path), path,
                          ["spacecraft[1].manoeuvre", "the ekf solves for manoeuvres", "estimator: batch does not"])
