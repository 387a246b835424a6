"""compiled_calls: a compiled function handed to compiled code by address carries no copy of it, raises through
it, and is found again for arguments of the same types."""

import numpy as np
import pytest
from numba import njit, types

from liaison_cli.compiled_calls import SharedCall, shared_call


@njit
def _scaled_sum(x, factor):
    if x.shape[0] == 0:
        raise ValueError("an empty vector has no sum here")
    total = 0.0
    for value in x:
        total += factor * value
    return total


@njit
def _twice(f, x):
    return f(x, 1.0) + f(x, 1.0)


def test_the_caller_calls_it_by_address_and_holds_no_copy():
    """The caller's final LLVM module (numba's CodeLibrary._final_module: its own code and everything linked into
    it) names the callee nowhere; a caller that calls the dispatcher itself has it linked in (LLVM inlined it
    there, its name left in the inlining metadata)."""

    @njit
    def linked(f, x):
        return _scaled_sum(x, 1.0)

    call = shared_call(_scaled_sum, types.float64, np.ones(3), 1.0)
    assert _twice(call, np.arange(4.0)) == 12.0 and linked(call, np.arange(4.0)) == 6.0
    (by_address,), (with_copy,) = _twice.overloads.values(), linked.overloads.values()
    assert "_scaled_sum" not in str(by_address.library._final_module)
    assert "_scaled_sum" in str(with_copy.library._final_module)


def test_an_exception_in_it_reaches_the_caller():
    call = shared_call(_scaled_sum, types.float64, np.ones(3), 1.0)
    with pytest.raises(ValueError, match="no sum"):
        _twice(call, np.empty(0))


def test_the_same_types_find_the_same_call_and_others_another():
    first = shared_call(_scaled_sum, types.float64, np.ones(3), 1.0)
    assert shared_call(_scaled_sum, types.float64, np.zeros(7), 2.5) is first
    read_only = np.ones(3)
    read_only.setflags(write=False)
    other = shared_call(_scaled_sum, types.float64, read_only, 1.0)
    assert isinstance(other, SharedCall) and other is not first
    assert other.signature().args[0] != first.signature().args[0]


def test_a_wrong_return_type_is_refused():
    with pytest.raises(TypeError, match="returns float64"):
        shared_call(_scaled_sum, types.int64, np.ones(3).astype(np.float32), 1.0)


def test_an_unknown_model_code_raises_through_the_shared_time_update():
    """The EKF calls the time update by address: the propagator's refusal of an unknown model code still
    reaches Python as the error it is (never a silent NaN)."""
    from liaison_cli.campaign.engine.worker import draw_run_inputs
    from liaison_cli.estimation.estimators import estimate
    from liaison_cli.scenario.loading import load_scenario
    from liaison_cli.scenario.setup import prepare_problem
    from tests.conftest import SCENARIOS

    problem = prepare_problem(load_scenario(SCENARIOS / "smoke.yaml")[0])
    inputs = draw_run_inputs(problem, 0)
    broken = problem.filter.__class__.__new__(problem.filter.__class__)
    broken.__dict__.update(problem.filter.__dict__)
    object.__setattr__(broken, "model", 99)
    with pytest.raises(ValueError, match="unknown dynamics model code"):
        estimate(problem.scenario.estimator, broken, inputs.x0_hat, inputs.y_obs, inputs.truth)


def test_read_only_inputs_reach_the_shared_calls_as_they_are_typed():
    """Read-only known states and process noise (a caller's own arrays) are taken as writable copies where the
    shared calls are typed for writable arrays: the EKF and LinCov run, with the numbers of writable inputs."""
    from liaison_cli.campaign.engine.worker import draw_run_inputs
    from liaison_cli.campaign.studies.lincov_budget import error_budget
    from liaison_cli.estimation.estimators import estimate
    from liaison_cli.scenario.loading import load_scenario
    from liaison_cli.scenario.setup import prepare_problem
    from tests.conftest import SCENARIOS

    problem = prepare_problem(load_scenario(SCENARIOS / "smoke.yaml")[0])
    inputs = draw_run_inputs(problem, 0)
    writable = estimate(problem.scenario.estimator, problem.filter, inputs.x0_hat, inputs.y_obs, inputs.truth)
    writable_budget = error_budget(problem).total
    for array in (problem.filter.known_states, problem.filter.Q):
        array.setflags(write=False)
    read_only = estimate(problem.scenario.estimator, problem.filter, inputs.x0_hat, inputs.y_obs, inputs.truth)
    np.testing.assert_array_equal(read_only.err, writable.err)
    np.testing.assert_array_equal(error_budget(problem).total, writable_budget)


def test_without_the_compiler_the_plain_functions_are_passed():
    """NUMBA_DISABLE_JIT=1 (numba's debugging switch): the shared calls are the Python functions themselves."""
    import os
    import subprocess
    import sys

    script = ("from liaison_cli.estimation.filter_loop import shared_calls, time_update, measurement_row\n"
              "from liaison_cli.estimation.kernel_args import channels_of, dynamics_of, BlockLayout\n"
              "import numpy as np\n"
              "i = np.zeros(1, dtype=np.int64)\n"
              "calls = shared_calls(channels_of(i, np.zeros((1, 6)), i, np.zeros((1, 1)), np.zeros((1, 1)), "
              "np.ones(1)), BlockLayout(i, i, i, i), dynamics_of([0.01], 0.1, [4]))\n"
              "print(calls.time_update is time_update, calls.measurement_row is measurement_row)\n")
    out = subprocess.run([sys.executable, "-c", script], env={**os.environ, "NUMBA_DISABLE_JIT": "1"},
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.split() == ["True", "True"], out.stderr


def test_the_estimator_bodies_call_the_shared_functions_only_by_address():
    """No estimator body calls the time update, the measurement row or the covariance prediction by name (which
    would link a copy of its code into the body again): only through its SharedCalls argument."""
    import ast
    import inspect

    from liaison_cli.estimation import batch, filter_loop, initial_batch, lincov

    shared = {"time_update", "measurement_row", "predict_covariance_into", "predict_covariance_blocks"}
    bodies = (filter_loop.run_ekf, lincov.lincov_along_truth, lincov._propagate_parts, lincov._update_along_truth,
              initial_batch.reference_and_normal_equations, batch._row, batch.accumulate_normal_equations,
              batch.postfit_residuals)
    for body in bodies:
        tree = ast.parse(inspect.getsource(getattr(body, "py_func", body)).lstrip())
        parameters = {arg.arg for arg in tree.body[0].args.args}  # a SharedCall passed on under its own name
        by_name = {node.func.id for node in ast.walk(tree)
                   if isinstance(node, ast.Call) and isinstance(node.func, ast.Name)} & (shared - parameters)
        assert not by_name, (body.__name__, by_name)


def test_the_warm_up_compiles_ahead_the_calls_a_scenario_uses():
    """warm-up's compile_shared_calls types the measurement row and the covariance prediction for the named
    groups' fixed types: a scenario's estimator finds the very same SharedCalls (nothing compiled for nothing)."""
    from liaison_cli.campaign.engine.warmup import compile_shared_calls
    from liaison_cli.compiled_calls import _shared
    from liaison_cli.estimation.filter_loop import shared_covariance_prediction, shared_measurement_row
    from liaison_cli.scenario.loading import load_scenario
    from liaison_cli.scenario.setup import prepare_problem
    from tests.conftest import SCENARIOS

    _shared.clear()
    compile_shared_calls()
    ahead = set(map(id, _shared.values()))
    assert len(ahead) == 2
    for name in ("smoke.yaml", "eph_eml1_eml2_dsn.yaml", "bias_eml2_lunar.yaml"):
        arrays = prepare_problem(load_scenario(SCENARIOS / name)[0]).filter
        used = {id(shared_measurement_row(arrays.channels())), id(shared_covariance_prediction(arrays.block_layout()))}
        assert used == ahead, name
