"""A study's finished cells on disk, so that an interrupted study resumes where it stopped (study003, study004).

A study's work is cells (003: grid point x mission x case; 004: grid point x transmitter x receiver pair), each
one Monte Carlo campaign through the fan-out (runner) reduced to a few tables. Each finished cell's tables are
written atomically (storage) into the study's work folder as `<cell>-<key>.<part>.parquet`, then
`<cell>-<key>.done` last: a cell counts as finished only once its `.done` is there. The key is a digest of
everything the cell's numbers depend on: the study, the cell's effective scenario (sweep.plan.scenario_hash, as
a sweep's manifest records it), the run count, liaison's version, the code of every package that makes a cell's
numbers (PACKAGE_CODE: from the dynamics to the campaign, comments and docstrings aside) and the source of the
study module that reduces the runs, so a changed scenario, run count or code never reuses a stale cell (an
edited checkout keeps its version number, so the version alone would not do). The cells are kept after the study is written (running it again, e.g. with --overwrite, reuses
them); liaison deletes nothing there.
"""

import hashlib
import json
import sys
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import pandas as pd
from pyarrow import ArrowException

from liaison_cli import __version__, core_source_hash, interrupts
from liaison_cli.campaign.sweep.plan import scenario_hash
from liaison_cli.errors import LiaisonError
from liaison_cli.provenance import arithmetic_provenance
from liaison_cli.scenario.scenario_model import Scenario
from liaison_cli.storage import write_parquet_atomic, write_text_atomic

# The packages whose code makes a cell's numbers (the setup, the engine, the metrics, the runner).
PACKAGE_CODE = ("dynamics", "radio", "orbits", "measurements", "estimation", "analysis", "exchange", "scenario",
                "campaign", "campaign/engine", "campaign/sweep", "campaign/studies", "campaign/exchange")
CELL_FORMAT = 1  # the files' layout; part of the key, so a new layout never reads an old cell


class StudyInterrupted(LiaisonError):
    """Ctrl-C: the finished cells are in the work folder; the same command resumes."""

    exit_code = 130


def source_digest(module_file: str) -> str:
    return hashlib.sha256(Path(module_file).read_bytes()).hexdigest()[:16]


@dataclass
class CellStore:
    """`folder`: the work folder (None: nothing stored, every cell computed); `study`: its name; `code`: the
    digest of the study module's source (source_digest)."""

    folder: Path | None
    study: str
    code: str
    computed: int = 0
    reused: int = 0
    package_code: str = field(init=False)  # core_source_hash(PACKAGE_CODE), hashed once per study, not per cell
    asked: set = field(init=False, default_factory=set)  # every cell's `.done` path asked for so far

    def __post_init__(self):
        self.package_code = core_source_hash(PACKAGE_CODE)

    def _key(self, scenario: Scenario, runs: int) -> str:
        inputs = {"format": CELL_FORMAT, "study": self.study, "scenario": scenario_hash(scenario), "runs": runs,
                  "version": __version__, "core": self.package_code, "code": self.code}
        return hashlib.sha256(json.dumps(inputs, sort_keys=True).encode()).hexdigest()[:16]

    def cell(self, label: str, scenario: Scenario, runs: int, compute: Callable[[], dict]) -> dict:
        """The cell's tables ({part: DataFrame}): read back when a finished copy is stored, else computed by
        `compute()` and stored before they are returned."""
        if self.folder is None:
            self.computed += 1
            return compute()
        stem = self.folder / f"{label}-{self._key(scenario, runs)}"
        done = stem.with_suffix(".done")
        self.asked.add(done)
        if done.exists():
            stored = _read_cell(stem, done)
            if stored is not None:
                self.reused += 1
                return stored
        parts = compute()
        self.folder.mkdir(parents=True, exist_ok=True)
        # The arithmetic is recorded, not keyed (_key): a cell computed on another machine is still reused.
        meta = {"package": "liaison", "version": __version__, "arithmetic": arithmetic_provenance(),
                "study": self.study, "cell": label, "runs": runs}
        for part, frame in parts.items():
            write_parquet_atomic(frame, f"{stem}.{part}.parquet", meta)
        write_text_atomic(json.dumps({**meta, "parts": list(parts)}, sort_keys=True) + "\n", done)
        self.computed += 1
        return parts

    @contextmanager
    def saving_on_interrupt(self, total: int):
        """Ctrl-C inside the block (or the SystemError numba makes of it in compiled code) ends the study with
        one line saying how many of its `total` cells are saved and how to resume."""
        try:
            yield
        except (KeyboardInterrupt, Exception) as exc:  # an Exception only when a Ctrl-C caused it: numba's
            # SystemError from compiled code, its RuntimeError when one lands while it compiles
            if not interrupts.caused_by_interrupt(exc):
                raise
            raise self._interrupted(total) from None

    def _interrupted(self, total: int) -> StudyInterrupted:
        finished = self.computed + self.reused
        if self.folder is not None:  # counted on disk: a Ctrl-C between a cell's `.done` and its count counts it
            finished = sum(done.exists() for done in self.asked)
        if self.folder is None:
            return StudyInterrupted(f"interrupted after {finished} of {total} cells; nothing was written")
        return StudyInterrupted(f"interrupted: {finished} of {total} cells saved in {self.folder}; rerun the same "
                                "command to resume")


def _read_cell(stem: Path, done: Path) -> dict | None:
    """The stored tables of a finished cell, or None with a note on stderr when its `.done` or a table is
    damaged (unreadable JSON, a missing or truncated Parquet): the cell is then computed again, instead of every
    rerun failing until the file is deleted by hand."""
    try:
        return {part: pd.read_parquet(f"{stem}.{part}.parquet") for part in json.loads(done.read_text())["parts"]}
    except (OSError, ValueError, KeyError, TypeError, ArrowException) as exc:
        print(f"note: {done.parent}: cell {stem.name} is damaged ({type(exc).__name__}); computing it again",
              file=sys.stderr)
        return None


def grid_points(grid: list[tuple[str, list]] | None) -> list[dict]:
    """A study's grid (--grid axes) as its points (dicts of overrides), full factorial; no grid: one point
    without overrides."""
    import itertools

    axes = grid or []
    return [dict(zip([key for key, _ in axes], values)) for values in itertools.product(*[v for _, v in axes])]


def first_grid_point(frame: pd.DataFrame, grid: list[tuple[str, list]] | None) -> pd.DataFrame:
    """The rows of a study's table at the grid's first point (the figures show it; the tables hold every point);
    no grid: every row."""
    for key, values in grid or []:
        frame = frame[frame[key] == values[0]]
    return frame
