"""Parquet tables written atomically (storage.atomic) with liaison's provenance as JSON metadata under the
'liaison' key and each column's unit in its Arrow field metadata (storage.units), and read back; tables built
from numpy buffers (`arrow_table`) so that `liaison run` never imports pandas. pyarrow is imported only by the
functions that need it."""

import json

from liaison_cli.storage.atomic import write_atomic
from liaison_cli.storage.units import schema_with_units

METADATA_KEY = b"liaison"


def write_parquet_atomic(df, path, metadata: dict) -> None:
    """Write a DataFrame with JSON metadata under the 'liaison' key."""
    import pyarrow as pa

    _write_table_atomic(pa.Table.from_pandas(df, preserve_index=False), path, metadata)


def write_columns_atomic(columns: dict, path, metadata: dict) -> None:
    """Write columns (name -> 1-D numpy array, see arrow_table) with JSON metadata, without pandas."""
    _write_table_atomic(arrow_table(columns), path, metadata)


def _write_table_atomic(table, path, metadata: dict) -> None:
    import pyarrow.parquet as pq

    merged = dict(table.schema.metadata or {})
    merged[METADATA_KEY] = json.dumps(metadata, sort_keys=True).encode()
    table = with_units(table).replace_schema_metadata(merged)
    write_atomic(path, lambda tmp: pq.write_table(table, tmp))


def read_metadata(path) -> dict:
    import pyarrow.parquet as pq

    return json.loads(pq.read_schema(path).metadata[METADATA_KEY])


def arrow_table(columns: dict):
    """A pyarrow Table from columns (name -> 1-D numpy array: numbers, bools, or objects holding strings and
    None), built from buffers. pa.array() and pa.table() import pandas (about 0.3 s) to ask whether their
    input is a pandas object; `liaison run` writes all its tables without paying for that."""
    import pyarrow as pa

    return with_units(pa.Table.from_arrays([arrow_array(values) for values in columns.values()], names=list(columns)))


def with_units(table):
    """The table with each column's unit in its Arrow field metadata (storage.units.unit_of: b"unit")."""
    import pyarrow as pa

    return pa.Table.from_arrays(table.columns, schema=schema_with_units(table.schema))


def arrow_array(values):
    """The pyarrow array of a 1-D numpy array (see arrow_table): strings as utf8 with None as null; NaN in a
    float column stays NaN, as pa.array(values) keeps it."""
    import numpy as np
    import pyarrow as pa

    values = np.asarray(values)
    n = len(values)
    if values.dtype == object:
        return _label_array(values)
    if values.dtype == bool:
        return pa.Array.from_buffers(pa.bool_(), n, [None, pa.py_buffer(np.packbits(values, bitorder="little"))])
    values = np.ascontiguousarray(values)
    return pa.Array.from_buffers(pa.from_numpy_dtype(values.dtype), n, [None, pa.py_buffer(values)])


def _label_array(values):
    """arrow_array of an object column (labels: few distinct values, each encoded once, then expanded in C++)."""
    import numpy as np
    import pyarrow as pa

    n = len(values)
    items = values.tolist()
    labels = list(dict.fromkeys(items))
    code_of = {label: code for code, label in enumerate(labels)}
    codes = np.fromiter(map(code_of.__getitem__, items), dtype=np.int32, count=n)
    encoded = [b"" if label is None else str(label).encode("utf-8") for label in labels]
    offsets = np.zeros(len(encoded) + 1, dtype=np.int32)
    offsets[1:] = np.cumsum([len(b) for b in encoded])
    dictionary = pa.Array.from_buffers(pa.string(), len(encoded),
                                       [None, pa.py_buffer(offsets), pa.py_buffer(b"".join(encoded))])
    validity, nulls = None, 0
    if None in code_of:
        present = codes != code_of[None]
        validity, nulls = pa.py_buffer(np.packbits(present, bitorder="little")), int(n - present.sum())
    indices = pa.Array.from_buffers(pa.int32(), n, [validity, pa.py_buffer(codes)], null_count=nulls)
    return pa.DictionaryArray.from_arrays(indices, dictionary).dictionary_decode()
