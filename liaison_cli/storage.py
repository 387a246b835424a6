"""Atomic file I/O, the one place that writes files: Parquet tables with provenance, text, bytes.

Every write goes to a temporary file in the destination folder, is fsynced, then renamed over the
target, so a reader sees the old file or the new one, never a torn one. pyarrow is imported only by the
functions that need it, so the numeric core can use the byte / text writers without loading it.
"""

import json
import os
import shutil
import tempfile
from pathlib import Path

from liaison_cli.errors import OutputExistsError

METADATA_KEY = b"liaison"


def _temp_beside(path: Path) -> str:
    """A temp file in the destination folder (so the rename is atomic) with normal permissions."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    return tmp


def _write_atomic(path, write) -> None:
    """Call write(temp_path), fsync, rename onto `path`; the temp file never survives a failure."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = _temp_beside(path)
    try:
        write(tmp)
        with open(tmp, "rb") as handle:
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_bytes_atomic(data: bytes, path) -> None:
    _write_atomic(path, lambda tmp: Path(tmp).write_bytes(data))


def write_text_atomic(text: str, path) -> None:
    _write_atomic(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))


def write_parquet_atomic(df, path, metadata: dict) -> None:
    """Write a DataFrame with JSON metadata under the 'liaison' key."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(df, preserve_index=False)
    merged = dict(table.schema.metadata or {})
    merged[METADATA_KEY] = json.dumps(metadata, sort_keys=True).encode()
    table = table.replace_schema_metadata(merged)
    _write_atomic(path, lambda tmp: pq.write_table(table, tmp))


def read_metadata(path) -> dict:
    import pyarrow.parquet as pq

    return json.loads(pq.read_schema(path).metadata[METADATA_KEY])


def prepare_output_dir(path, overwrite: bool) -> Path:
    path = Path(path)
    if path.exists() and (not path.is_dir() or any(path.iterdir())):
        if not overwrite:
            raise OutputExistsError(
                f"{path}: output directory already exists and is not empty; pass --overwrite to replace it "
                "or --output to choose another"
            )
        if path.is_dir():
            shutil.rmtree(path)
        else:
            path.unlink()
    path.mkdir(parents=True, exist_ok=True)
    return path
