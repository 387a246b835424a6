"""The unit of a table column, read from its name, for the Arrow field metadata of every Parquet file liaison
writes (key b"unit"): a reader gets the unit from the schema instead of parsing names.

liaison names its columns with the unit last (`rms_position_settled_m`, `t_s`, `psd_m2_s3`), sometimes followed
by a statistic over runs or a qualifier (`rms_position_m_p90`, `clock_rms_window_ns_mean`, `..._lag_s_settled`). A name with no unit token (counts,
ratios, labels, NEES) gets no unit entry: it is dimensionless or text.
"""

import re

UNIT_KEY = b"unit"
_THRESHOLD = re.compile(r"\d+(?:cm|mm|m|km|s|ms|ns|deg)")

# Longest first: the last tokens of a name, joined by "_", against these.
_UNIT_TOKENS = (
    ("m2_s3", "m^2/s^3"),
    ("m_s2", "m/s^2"),
    ("km_s", "km/s"),
    ("mm_s", "mm/s"),
    ("cm_s", "cm/s"),
    ("m_s", "m/s"),
    ("km", "km"),
    ("m", "m"),
    ("mm", "mm"),
    ("ns", "ns"),
    ("us", "us"),
    ("ms", "ms"),
    ("s", "s"),
    ("h", "h"),
    ("min", "min"),
    ("days", "d"),
    ("deg", "deg"),
    ("rad", "rad"),
    ("lu", "LU (Earth-Moon distance)"),
    ("tu", "TU (Earth-Moon time unit)"),
    ("db", "dB"),
    ("dbhz", "dB-Hz"),
    ("hz", "Hz"),
)
# Qualifiers that may follow the unit (`time_shift_lag_s_settled`, `rms_position_m_p90`).
_STATISTICS = {"mean", "median", "std", "max", "p10", "p50", "p90", "p95", "p99", "halfwidth", "settled"}
# Names whose tail reads as a unit it is not (study004's days until the velocity error stays below 1 cm/s).
_NAMED = {"days_below_1cm_s": "d"}


def unit_of(name: str) -> str | None:
    """The unit the column `name` is in, from its last tokens (see the module docstring), or None."""
    if name in _NAMED:
        return _NAMED[name]
    tokens = name.lower().replace(".", "_").split("_")
    if any(_THRESHOLD.fullmatch(token) for token in tokens):  # a threshold (1cm): its unit, not the column's
        return None
    while len(tokens) > 1 and tokens[-1] in _STATISTICS:
        tokens = tokens[:-1]
    if len(tokens) < 2 or "per" in tokens:  # a bare word ("case", "runs"); a rate such as mu2_per_s or
        return None                          # chi2_per_measurement is not in the unit its last token names
    for suffix, unit in _UNIT_TOKENS:
        width = suffix.count("_") + 1
        if len(tokens) > width and "_".join(tokens[-width:]) == suffix:
            return unit
    return None


def schema_with_units(schema):
    """The Arrow schema with each field's unit (unit_of) in its metadata; other field metadata kept."""
    import pyarrow as pa

    fields = []
    for field in schema:
        unit = unit_of(field.name)
        if unit is not None:
            metadata = dict(field.metadata or {})
            metadata[UNIT_KEY] = unit.encode()
            field = field.with_metadata(metadata)
        fields.append(field)
    return pa.schema(fields, metadata=schema.metadata)


def units_of_file(path) -> dict:
    """{column: unit} of a Parquet file liaison wrote (columns without a unit left out)."""
    import pyarrow.parquet as pq

    schema = pq.read_schema(path)
    return {f.name: f.metadata[UNIT_KEY].decode() for f in schema if f.metadata and UNIT_KEY in f.metadata}
