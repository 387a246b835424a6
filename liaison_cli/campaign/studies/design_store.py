"""A design search's finished batches of candidates kept in a work folder, so that an interrupted
`liaison design` resumes (campaign.studies.design.score_all)."""

from contextlib import contextmanager
from pathlib import Path

DESIGN_MODULES = ("design.py", "design_choices.py", "design_store.py")  # their code is in the key


class DesignStore:
    """A design's finished batches of candidates in a work folder (None: nothing kept), one JSON file each,
    `design-<key>-b<batch>.json`, written atomically. The key is a digest of everything a row depends on: the base
    scenario, the open spacecraft, the objective, the condition flag and threshold, the candidates (their orbits,
    factors and choices) and their batching, liaison's
    version and the code of every package that makes the numbers (study_cells.PACKAGE_CODE) and of the design's modules;
    so a changed design or code never reuses a stale row. A damaged file is noted and computed again."""

    def __init__(self, folder, design, chunk: int):
        import hashlib
        import json

        from liaison_cli import __version__, core_source_hash
        from liaison_cli.campaign.studies.study_cells import PACKAGE_CODE, source_digest

        self.folder = None if folder is None else Path(folder)
        self.computed = self.reused = 0
        if self.folder is None:
            return
        inputs = {"base": design.base, "open": design.open_spacecraft, "objective": design.objective,
                  "condition": design.condition, "converge_below_m": design.converge_below_m, "chunk": chunk,
                  "version": __version__, "candidates": [[c.index, c.family, c.period_days, c.phase, c.settings,
                                                          c.choices] for c in design.candidates],
                  "core": core_source_hash(PACKAGE_CODE),
                  "code": [source_digest(Path(__file__).with_name(name)) for name in DESIGN_MODULES]}
        self.key = hashlib.sha256(json.dumps(inputs, sort_keys=True, default=str).encode()).hexdigest()[:16]

    def _path(self, batch: int) -> Path:
        return self.folder / f"design-{self.key}-b{batch}.json"

    def read(self, batch: int):
        """The batch's stored rows, or None (not stored, or damaged: then said in one note)."""
        import json
        import logging

        if self.folder is None or not self._path(batch).is_file():
            return None
        try:
            rows = json.loads(self._path(batch).read_text())
            assert isinstance(rows, list) and all(isinstance(row, dict) for row in rows)
        except (OSError, ValueError, AssertionError):
            logging.getLogger("liaison").warning(f"{self._path(batch)}: damaged; its candidates are scored again")
            return None
        self.reused += 1
        return rows

    def write(self, batch: int, rows: list) -> None:
        import json

        from liaison_cli.storage import write_text_atomic

        self.computed += 1
        if self.folder is not None:
            self.folder.mkdir(parents=True, exist_ok=True)
            write_text_atomic(json.dumps(rows, default=float) + "\n", self._path(batch))

    @contextmanager
    def saving_on_interrupt(self, total: int, finished: dict):
        """Ctrl-C in the block (or numba's error made of it) ends the search in one line: how many of the `total`
        batches are saved, and how to resume."""
        from liaison_cli import interrupts
        from liaison_cli.campaign.studies.study_cells import StudyInterrupted

        try:
            yield
        except (KeyboardInterrupt, Exception) as exc:
            if not interrupts.caused_by_interrupt(exc):
                raise
            if self.folder is None:
                raise StudyInterrupted(f"interrupted after {len(finished)} of {total} candidate batches; nothing "
                                       "was written") from None
            # counted on disk: a Ctrl-C between a batch's file and `finished` must still count that batch
            saved = sum(self._path(batch).is_file() for batch in range(total))
            raise StudyInterrupted(f"interrupted: {saved} of {total} candidate batches saved in "
                                   f"{self.folder}; rerun the same command to resume") from None
