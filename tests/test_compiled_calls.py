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
