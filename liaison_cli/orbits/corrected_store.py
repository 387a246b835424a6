"""Orbits corrected into the dated model (orbits.ephemeris_correction), kept on disk: multiple shooting of a
reference orbit takes from seconds to over a minute and gives the same nodes every time for the same inputs, so
every scenario or study run after the first reads them (NumPy .npz, no pickles).

Cache folder: `$LIAISON_CACHE_DIR/dated-orbits` (default `~/.cache/liaison/dated-orbits`). A file's name is
a hash of everything that determines the result: the CRTBP state and period, epoch, span and node spacing, the
force model (DE421 window coefficients, bodies, GMs, C_R A/m, the terms beyond those: the lunar field), the
corrector's settings and tolerances, and the code of orbits/ and dynamics/ (core_source_hash), so a changed
corrector or force model never serves stale nodes. A correction that did not converge is kept too (it is as deterministic), so the caller's error comes
at once. Files are written atomically (storage); a damaged one is rebuilt with a note on stderr.
"""

import hashlib
from pathlib import Path

import numpy as np

from liaison_cli import core_source_hash
from liaison_cli.orbits.ephemeris_correction import (
    POSITION_TOLERANCE_KM,
    VELOCITY_TOLERANCE_KM_S,
    CorrectedOrbit,
    ForceModel,
    corrected_in_stages,
)
from liaison_cli.orbits.npz_cache import cache_folder, read_intact, write_npz

# 2: corrected in stages; 3: re-phased continuously; 4: patch points within one period, corrections in their
# Jacobian's row space (one solution)
STORE_FORMAT = 4
FIELDS = ("node_times_s", "nodes", "position_defects_km", "velocity_defects_km_s", "iterations", "converged")


def corrected_orbits_dir() -> Path:
    return cache_folder("dated-orbits")


def correction_key(state_lu, epoch_s: float, span_s: float, node_spacing_s: float, forces: ForceModel,
                   steps_per_node: int, max_iterations: int, period_tu: float | None = None) -> str:
    """sha256 (hex, 32 characters) of every input of the correction and of the code that computes it."""
    digest = hashlib.sha256()
    settings = (STORE_FORMAT, core_source_hash(("orbits", "dynamics")), float(epoch_s), float(span_s),
                float(node_spacing_s), int(steps_per_node), int(max_iterations), POSITION_TOLERANCE_KM,
                VELOCITY_TOLERANCE_KM_S, float(forces.gm_earth), float(forces.cr_am),
                None if period_tu is None else float(period_tu))
    digest.update(repr(settings).encode())
    window = forces.window
    for array in (state_lu, forces.bodies, forces.gms, window.coeffs, window.start_s, window.interval_s,
                  window.n_records, forces.terms):
        array = np.ascontiguousarray(array)
        digest.update(f"{array.dtype.str}{array.shape}".encode())
        digest.update(array.tobytes())
    return digest.hexdigest()[:32]


def corrected_orbit(state_lu, epoch_s: float, span_s: float, node_spacing_s: float, forces: ForceModel,
                    steps_per_node: int = 200, max_iterations: int = 20,
                    period_tu: float | None = None) -> tuple[CorrectedOrbit, bool]:
    """(the CRTBP orbit `state_lu` corrected into `forces` over [epoch_s, epoch_s + span_s], read_from_cache).
    Same result as corrected_in_stages with these arguments."""
    key = correction_key(state_lu, epoch_s, span_s, node_spacing_s, forces, steps_per_node, max_iterations,
                         period_tu)
    path = corrected_orbits_dir() / f"{key}.npz"
    if path.exists():
        orbit = _load_intact(path)
        if orbit is not None:
            return orbit, True
    orbit = corrected_in_stages(state_lu, epoch_s, span_s, node_spacing_s, forces, steps_per_node, max_iterations,
                                period_tu)
    _save(orbit, path)
    return orbit, False


def _save(orbit: CorrectedOrbit, path: Path) -> None:
    write_npz({name: np.asarray(getattr(orbit, name)) for name in FIELDS}, path)


def _load_intact(path: Path) -> CorrectedOrbit | None:
    """The cached orbit, or None (with a note on stderr) when the file is damaged: not a readable .npz, a
    field missing, or nodes that do not match their times. The caller corrects the orbit again."""
    return read_intact(path, _read_checked, "corrected-orbit", "correcting the orbit again")


def _read_checked(path: Path) -> tuple[CorrectedOrbit | None, str | None]:
    with np.load(path, allow_pickle=False) as data:
        fields = {name: data[name] for name in FIELDS}
    times, nodes = fields["node_times_s"], fields["nodes"]
    intact = (times.ndim == 1 and nodes.shape == (len(times), 6) and len(times) >= 2
              and np.all(np.isfinite(nodes)) and len(fields["position_defects_km"]) == int(fields["iterations"]))
    if not intact:
        return None, "malformed arrays"
    return CorrectedOrbit(times, nodes, tuple(float(d) for d in fields["position_defects_km"]),
                          tuple(float(d) for d in fields["velocity_defects_km_s"]), int(fields["iterations"]),
                          bool(fields["converged"])), None
