"""Single spacecraft's CRTBP truths kept on disk between processes and sessions (`$LIAISON_CACHE_DIR/truths`),
so a scenario run again, a sweep's workers, the test suite's many processes and every scenario that flies the
same orbit (the NRHO scenarios share the Gateway's) propagate it once per machine.

An entry is the truth (m, 6) exactly as computed (float64, so every number downstream is bit-identical), under
the sha256 of what fixes it: the spacecraft's orbit fields, its initial state, the epochs, the model's
parameters and truth acceleration (scenario.truth._spacecraft_truth_key), and the code of the packages that
compute it (core_source_hash of dynamics, orbits and scenario: an edited integrator or step rule is a new key).
The key is stored in the file and checked on reading. A damaged entry is noted on stderr and computed again
(orbits.npz_cache); a cache that cannot be written is skipped (the truth is derived data). At most MAX_ENTRIES
files: the oldest go first. `LIAISON_TRUTH_CACHE=off` turns it off.
"""

import hashlib
import os
from functools import lru_cache

import numpy as np

from liaison_cli.orbits.npz_cache import cache_folder, read_intact, write_npz

FOLDER = "truths"
MAX_ENTRIES = 256


def enabled() -> bool:
    return os.environ.get("LIAISON_TRUTH_CACHE", "on").lower() not in ("off", "0", "no", "false")


@lru_cache(maxsize=1)
def _code_key() -> str:
    from liaison_cli import core_source_hash

    return core_source_hash(("dynamics", "orbits", "scenario"))


def _path(key: str):
    return cache_folder(FOLDER) / f"{hashlib.sha256((key + _code_key()).encode()).hexdigest()[:40]}.npz"


def load_truth(key: str, epochs: int):
    """The stored truth (epochs, 6) under `key`, or None (none stored, another key, or a damaged file)."""
    if not enabled():
        return None
    path = _path(key)
    if not path.is_file():
        return None

    def read(p):
        with np.load(p, allow_pickle=False) as data:
            states, stored = data["states"], str(data["key"])
        if stored != key or states.shape != (epochs, 6) or states.dtype != np.float64:
            return None, "another truth under its name"
        return states, None

    states = read_intact(path, read, "truth", "computing it again")
    if states is not None:
        states.setflags(write=False)
    return states


def store_truth(key: str, states) -> None:
    """Keep `states` under `key` (nothing when off or when the cache folder cannot be written)."""
    if not enabled():
        return
    try:
        write_npz({"states": np.ascontiguousarray(states, dtype=np.float64), "key": np.array(key)}, _path(key))
        _evict()
    except OSError:
        pass  # derived data: the run has its truth either way


def _evict() -> None:
    entries = sorted(cache_folder(FOLDER).glob("*.npz"), key=lambda p: p.stat().st_mtime)
    for old in entries[: max(0, len(entries) - MAX_ENTRIES)]:
        try:
            old.unlink()
        except OSError:
            pass
