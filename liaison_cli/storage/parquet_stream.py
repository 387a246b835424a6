"""ParquetStream: one Parquet table written as its rows arrive (row group by row group) under a temporary
name, and renamed onto its path only when complete, so a campaign of any size holds only a buffer."""

import json
import os
from pathlib import Path

from liaison_cli.storage.atomic import fsync_folder, naming, temp_beside
from liaison_cli.storage.parquet import METADATA_KEY, arrow_table, write_columns_atomic


class ParquetStream:
    """One Parquet table written as its rows arrive, so a campaign of any size holds only a buffer.

    `append` takes columns (name -> 1-D array, the same names and dtypes each time); up to `flush_rows`
    rows are buffered and written as one row group (`dictionary_columns`: those whose values repeat). The
    file is built under a temporary name beside `path`, fsynced and renamed onto it by `close()` (`abort()`
    drops it). With no rows at all it writes an empty table.
    """

    def __init__(self, path, metadata: dict, flush_rows: int = 200_000, dictionary_columns=()):
        self._dictionary_columns = set(dictionary_columns)
        self.path = Path(path)
        self._metadata = metadata
        self._flush_rows = flush_rows
        self._buffer: list[dict] = []
        self._buffered_rows = 0
        self._tmp: str | None = None
        self._writer = None

    def append(self, columns: dict) -> None:
        rows = len(next(iter(columns.values()))) if columns else 0
        if rows:
            self._buffer.append(columns)
            self._buffered_rows += rows
        if self._buffered_rows >= self._flush_rows:
            with naming(self.path):
                self._flush()

    def _flush(self) -> None:
        import numpy as np
        import pyarrow.parquet as pq

        if not self._buffer:
            return
        names = list(self._buffer[0])
        table = arrow_table({name: np.concatenate([part[name] for part in self._buffer]) for name in names})
        self._buffer, self._buffered_rows = [], 0
        if self._writer is None:
            table = table.replace_schema_metadata(
                {METADATA_KEY: json.dumps(self._metadata, sort_keys=True).encode()})
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._tmp = temp_beside(self.path)
            # Dictionary encoding only where values repeat (labels, run, epoch): on the float columns it
            # costs more time than it saves space; zstd is both faster and smaller than the default here.
            self._writer = pq.ParquetWriter(self._tmp, table.schema, compression="zstd",
                                            use_dictionary=[n for n in names if n in self._dictionary_columns])
        else:
            table = table.cast(self._writer.schema)
        self._writer.write_table(table)

    def close(self) -> None:
        try:
            with naming(self.path):
                self._close()
        except BaseException:
            self.abort()
            raise

    def _close(self) -> None:
        self._flush()
        if self._writer is None:
            write_columns_atomic({}, self.path, self._metadata)
            return
        self._writer.close()
        with open(self._tmp, "rb") as handle:
            os.fsync(handle.fileno())
        os.replace(self._tmp, self.path)
        self._tmp = None
        fsync_folder(self.path.parent)

    def abort(self) -> None:
        if self._writer is not None:
            try:
                self._writer.close()
            except Exception:  # noqa: BLE001 - the file is dropped anyway
                pass
        if self._tmp is not None:
            Path(self._tmp).unlink(missing_ok=True)
        self._writer, self._tmp, self._buffer = None, None, []
