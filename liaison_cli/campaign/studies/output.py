"""The one place a study's result reaches the disk: its tables (Parquet with provenance), texts and figures,
through storage's atomic writers.

A study's compute function returns frames and plain data; report/ formats them (text) and draws them (a
callback); the CLI puts the three together as a `StudyOutput` and hands it to `write_folder` (a result folder
built beside and swapped in whole, storage.staged_output) or `write_files` (files into a folder as they are,
for `tables002` and `tune`, which write beside a sweep or a named table). `fill_folder` is the same staged
folder for a computation that streams its own tables into it (`liaison run`, `liaison export`).
"""

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from liaison_cli import __version__
from liaison_cli.storage import staged_output, write_parquet_atomic, write_text_atomic


@dataclass
class StudyOutput:
    """What a study writes. `tables`: {stem: DataFrame}, each written as `stem.parquet` with `meta` (plus
    `table_meta[stem]` when given) as its provenance; `texts`: {file name: text}; `draw(folder)`: draws the
    figures into `folder` and returns their paths (or None). Written in that order. `result`: what the CLI
    prints from (not written)."""

    tables: dict = field(default_factory=dict)
    meta: dict = field(default_factory=dict)
    texts: dict = field(default_factory=dict)
    draw: Callable | None = None
    table_meta: dict = field(default_factory=dict)
    result: object = None


def study_meta(loaded, runs: int) -> dict:
    """The provenance of a study over scenario files: `loaded` = [(name, scenario, text)]."""
    return {"package": "liaison", "version": __version__, "runs": runs,
            "scenarios_yaml": {name: text for name, _, text in loaded},
            "seeds": {name: scenario.monte_carlo.seed for name, scenario, _ in loaded}}


def write_files(folder, output: StudyOutput) -> list[Path]:
    """Write `output` into `folder` (created when missing), replacing each file atomically; the paths written,
    tables first, then texts, then figures."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for stem, frame in output.tables.items():
        paths.append(folder / f"{stem}.parquet")
        write_parquet_atomic(frame, paths[-1], {**output.meta, **output.table_meta.get(stem, {})})
    for name, text in output.texts.items():
        paths.append(folder / name)
        write_text_atomic(text, paths[-1])
    if output.draw is not None:
        paths += list(output.draw(folder) or [])
    return paths


def fill_folder(path, overwrite: bool, fill: Callable):
    """A result folder that `fill(stage)` writes, built beside `path` and swapped in whole when it returns
    (an earlier liaison result there is replaced only with `overwrite`); fill's return value."""
    with staged_output(path, overwrite) as stage:
        return fill(stage)


def write_folder(path, overwrite: bool, make: Callable[[], StudyOutput]) -> StudyOutput:
    """The study's result folder: `make()` (called once the folder is claimed, so a refused --output costs no
    computation) gives the StudyOutput, written into the staging folder, which then replaces `path` whole."""
    def fill(stage):
        output = make()
        write_files(stage, output)
        return output

    return fill_folder(path, overwrite, fill)
