"""Atomic file I/O, the one place that writes files: Parquet tables with provenance, text, bytes, and whole
result folders.

- atomic: one file written to a temporary name beside it, fsynced, renamed over the target, the folder
  fsynced: a reader sees the old file or the new one, never a torn one;
- parquet, parquet_stream: Parquet tables with liaison's provenance metadata, whole or streamed by row
  group (pyarrow is imported only by the functions that need it, so the numeric core can use the byte /
  text writers without loading it); units: each column's unit, from its name, into the Arrow field
  metadata of every table written;
- result_folders: result folders built in a hidden sibling `.NAME.partial-PID-*` (holding a flock on it
  and carrying our marker from the start) and swapped in whole (swap), resumable sweep folders;
- ownership: which folders are ours (the marker) and may be replaced; locks: flocks, live pids and each result
  folder's one-writer lock (`.NAME.lock`: a sweep's, and a replacement's while it swaps); leftovers: how the
  next command writing NAME settles what a kill at any moment left beside it (a stale lock file too).
Import from `liaison_cli.storage`; the modules are its parts.
"""

from liaison_cli.storage.atomic import fsync_folder, naming, write_bytes_atomic, write_text_atomic
from liaison_cli.storage.leftovers import recover_output
from liaison_cli.storage.ownership import RESULT_MARKER
from liaison_cli.storage.parquet import (
    METADATA_KEY,
    arrow_array,
    arrow_table,
    read_metadata,
    write_columns_atomic,
    write_parquet_atomic,
)
from liaison_cli.storage.parquet_stream import ParquetStream
from liaison_cli.storage.result_folders import prepare_output_dir, resumable_output, staged_output
from liaison_cli.storage.units import unit_of, units_of_file

__all__ = [
    "METADATA_KEY", "RESULT_MARKER", "ParquetStream", "arrow_array", "arrow_table", "fsync_folder", "naming",
    "prepare_output_dir", "read_metadata", "recover_output", "resumable_output", "staged_output",
    "unit_of", "units_of_file", "write_bytes_atomic", "write_columns_atomic", "write_parquet_atomic",
    "write_text_atomic",
]
