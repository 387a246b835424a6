"""Durability (issue 24): result swaps that never leave NAME missing, stale staging folders cleaned, the
sweep lock on the resolved path, the manifest format rule and retried errors, the vendored DOP853 tableau."""

import subprocess
import sys

import numpy as np
import pytest


# --- the DOP853 tableau -----------------------------------------------------------------------------------


def test_the_vendored_tableau_equals_scipys_exactly():
    import importlib

    try:
        scipy_tableau = importlib.import_module("scipy.integrate._ivp.dop853_coefficients")
    except ImportError:
        pytest.skip("scipy moved its private DOP853 coefficients; the vendored copy stands on its own")
    from liaison_cli.dynamics.rk8 import RK8_A, RK8_B, RK8_C

    stages = scipy_tableau.N_STAGES
    assert RK8_A.shape == (stages, stages) and RK8_B.shape == RK8_C.shape == (stages,)
    # Bit for bit, not allclose: the compiled truth and the filters must not move by a single ulp.
    assert np.array_equal(RK8_A, scipy_tableau.A[:stages, :stages])
    assert np.array_equal(RK8_B, scipy_tableau.B)
    assert np.array_equal(RK8_C, scipy_tableau.C[:stages])


def test_the_integrator_imports_without_scipy():
    code = ("import sys\nsys.modules['scipy'] = None  # any scipy import now fails\n"
            "from liaison_cli.dynamics.rk8 import RK8_A\nprint(RK8_A.shape)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip() == "(12, 12)", out.stderr


def test_the_tableau_is_covered_by_the_compiled_cache_key(monkeypatch):
    """numba's cache is keyed on core_source_hash: an edited tableau must give a new key (stale machine code
    with the old coefficients frozen in would otherwise be loaded)."""
    from pathlib import Path

    from liaison_cli import core_source_hash

    before = core_source_hash()
    real_read = Path.read_bytes
    monkeypatch.setattr(Path, "read_bytes", lambda self: real_read(self) + (b"#" if self.name == "dop853_tableau.py"
                                                                            else b""))
    assert core_source_hash() != before
