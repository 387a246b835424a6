"""Whether this tree reads an OEM into a CRTBP scenario (issue 35): the reader is scenario.orbit_files.
crtbp_oem_truth_lu; the spacecraft section accepts orbit: {oem} without dynamics: ephemeris once "oem" leaves
participants.DATED_ONLY_ORBITS, and the CRTBP truth follows the file once scenario.truth calls the reader. Until
both are in, the tests that need them are expected to fail (strict: they must be unmarked by being fixed)."""

from pathlib import Path

import pytest

import liaison_cli.scenario.truth as truth
from liaison_cli.scenario.participants import DATED_ONLY_ORBITS

CRTBP_OEM_READ = "oem" not in DATED_ONLY_ORBITS and "crtbp_oem_truth_lu" in Path(truth.__file__).read_text()
CRTBP_OEM_PENDING = pytest.mark.xfail(not CRTBP_OEM_READ, strict=True,
                                      reason="a CRTBP orbit: {oem} needs the truth.py and participants.py hunks of "
                                             "issue 35 (scenario.truth's CRTBP branch calling crtbp_oem_truth_lu)")
