"""Single spacecraft's CRTBP truths kept on disk between processes and sessions (`$LIAISON_CACHE_DIR/truths`),
so a scenario run again, a sweep's workers, the test suite's many processes and every scenario that flies the
same orbit (the NRHO scenarios share the Gateway's) propagate it once per machine.

An entry is the truth (m, 6) exactly as computed (float64, so every number downstream is bit-identical), under
the sha256 of what fixes it: the spacecraft's orbit fields, its initial state, the epochs, the model's
parameters and truth acceleration (scenario.truth._spacecraft_truth_key), and the code of the packages that
compute it (core_source_hash of dynamics, orbits and scenario: an edited integrator or step rule is a new key).
The key is stored in the file and checked on reading. A damaged entry is noted on stderr and computed again
(orbits.npz_cache); a cache that cannot be written is skipped (the truth is derived data). The folder is bounded by
bytes, not by entries (a design search of thousands of candidates keeps every candidate's truth: a 10-day truth
every 187.5 s is 221 kB): `LIAISON_TRUTH_CACHE_MB` (default MAX_MEGABYTES), the oldest files going first,
checked every EVICT_EVERY stores of a process (so a store does not list the folder each time; a folder may
overshoot by that many entries per process). `LIAISON_TRUTH_CACHE=off` turns it off.
"""

import hashlib
import math
import os
from functools import lru_cache

import numpy as np

from liaison_cli.orbits.npz_cache import cache_folder, read_intact, write_npz

FOLDER = "truths"
MAX_MEGABYTES = 1024
EVICT_EVERY = 16
_stores = 0  # this process's stores since its last eviction check


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
        global _stores
        if _stores % EVICT_EVERY == 0:
            _evict(budget_bytes())
        _stores += 1
    except OSError:
        pass  # derived data: the run has its truth either way


def budget_bytes() -> int:
    """The folder's bound: LIAISON_TRUTH_CACHE_MB megabytes (a positive finite number), else MAX_MEGABYTES."""
    try:
        megabytes = float(os.environ.get("LIAISON_TRUTH_CACHE_MB", MAX_MEGABYTES))
    except ValueError:
        megabytes = MAX_MEGABYTES
    return int((megabytes if math.isfinite(megabytes) and megabytes > 0 else MAX_MEGABYTES) * 1e6)


def _evict(budget: int) -> None:
    """Delete the oldest entries until the folder's files total at most `budget` bytes."""
    entries = []
    for path in cache_folder(FOLDER).glob("*.npz"):
        try:
            stat = path.stat()
        except OSError:
            continue  # another process evicted it meanwhile
        entries.append((stat.st_mtime, stat.st_size, path))
    total = sum(size for _, size, _ in entries)
    for _, size, old in sorted(entries, key=lambda entry: entry[0]):
        if total <= budget:
            break
        try:
            old.unlink()
        except FileNotFoundError:
            pass  # another process evicted it: gone all the same
        except OSError:
            continue
        total -= size
