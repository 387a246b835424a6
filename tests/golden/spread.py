"""Measure how far each golden quantity moves across BLAS kernels, and write the tolerances test_golden uses.

`python tests/golden/spread.py HOST.json.gz OTHER.json.gz ...`: records made by tests/golden/record.py (with
LIAISON_GOLDEN_OUT set) of the same code, each under another OpenBLAS kernel (the host's, and
OPENBLAS_CORETYPE=Haswell, Sandybridge, Nehalem), each with its own empty LIAISON_CACHE_DIR: the dated
scenarios' corrected orbits are cached on disk, and a record reusing another kernel's orbits measures no spread
from them (so it was once: Nehalem then failed eph_eml1_eml2_dsn's NEES shares by 1.6e-3). For every scenario, table and numeric column, the spread is
the largest difference from the first record, relative to the column's scale (the sum of absolute values for
the column sum; the largest |value| for the sampled values). The tolerance is SAFETY times the spread, and at
least FLOOR: an ill-conditioned statistic (a NEES dominated by a few epochs, a per-epoch error late in a
divergent arc) gets a loose bound, a well-conditioned one (a summary RMS) a tight one. Writes
tests/golden/tolerances.json with the spreads, the tolerances, the kernels and the rule.

`python tests/golden/spread.py --scenario NAME.yaml [--scenario ...] HOST.json.gz OTHER.json.gz ...`: after
re-recording only those scenarios (record.py NAME.yaml under each kernel), replace only their spreads and
tolerances; the other scenarios keep theirs (their records in these files are copies of the golden record, so
they would measure no spread). The kernels must be the ones of tolerances.json, in its order.
"""

import argparse
import gzip
import json
import sys
from pathlib import Path

import numpy as np

TOLERANCES = Path(__file__).with_name("tolerances.json")
SAFETY = 10.0  # four kernels sample the rounding; a fifth CPU may round further out
FLOOR = 1e-9  # two runs on one machine agree bit for bit; 1e-9 leaves room for a library's summation order
# A share of epochs (frac_*: NEES in band, inside 2 sigma, ...) moves in steps of one epoch: a NEES a hair from
# its band edge crosses it under another kernel (eph_eml1_eml2_dsn under Nehalem: 1.3e-3 and 1.6e-3 of the
# column sums, from corrected orbits 1e-10 km apart). A few such epochs per run are allowed whatever the
# sampled spread says.
SHARE_FLOOR = 1e-2


def _values(entry: dict) -> tuple[np.ndarray, float, np.ndarray, float]:
    sample = np.array([np.nan if v is None else v for v in entry["sample"]], dtype=float)
    scale = float(np.nanmax(np.abs(sample))) if np.isfinite(sample).any() else 0.0
    return np.array([entry["sum"]]), float(entry["abs"]), sample, scale


def column_spread(entries: list[dict]) -> float:
    """The largest relative difference of a column's sum or samples between the first record and the others."""
    base_sum, base_abs, base_sample, base_scale = _values(entries[0])
    worst = 0.0
    for entry in entries[1:]:
        other_sum, _, other_sample, _ = _values(entry)
        if base_abs:
            worst = max(worst, float(np.abs(other_sum - base_sum)[0]) / base_abs)
        if base_scale and other_sample.shape == base_sample.shape:
            worst = max(worst, float(np.nanmax(np.abs(other_sample - base_sample), initial=0.0)) / base_scale)
        elif other_sample.shape != base_sample.shape:
            worst = float("inf")
    return worst


def spreads(records: list[dict]) -> dict:
    out = {}
    for scenario, first in records[0].items():
        columns = {}
        for table, recorded in first["tables"].items():
            for column, values in recorded["columns"].items():
                if "sum" in values:
                    entries = [r[scenario]["tables"][table]["columns"][column] for r in records]
                    columns[f"{table}.{column}"] = column_spread(entries)
        out[scenario] = columns
    return out


def _floor(name: str) -> float:
    """The least tolerance of a column "table.column": SHARE_FLOOR for a share of epochs, else FLOOR."""
    return SHARE_FLOOR if name.split(".", 1)[1].startswith("frac_") else FLOOR


def main(paths: list[str], only: list[str]) -> None:
    records = []
    for path in paths:
        with gzip.open(path, "rt", encoding="utf-8") as handle:
            records.append(json.load(handle))
    measured = spreads(records)
    tolerances = {scenario: {name: max(_floor(name), SAFETY * spread) for name, spread in columns.items()}
                  for scenario, columns in measured.items()}
    kernels = [Path(p).name.split(".")[0] for p in paths]
    if only:
        kept = json.loads(TOLERANCES.read_text(encoding="utf-8"))
        if [k.split("_")[-1] for k in kept["kernels"]] != [k.split("_")[-1] for k in kernels]:
            raise SystemExit(f"kernels {kernels} are not those of {TOLERANCES.name}: {kept['kernels']}")
        for scenario in only:
            kept["spread"][scenario], kept["rtol"][scenario] = measured[scenario], tolerances[scenario]
        measured, tolerances, kernels = kept["spread"], kept["rtol"], kept["kernels"]
    TOLERANCES.write_text(json.dumps({"kernels": kernels, "safety": SAFETY, "floor": FLOOR,
                                      "share_floor": SHARE_FLOOR, "spread": measured,
                                      "rtol": tolerances}, indent=1, sort_keys=True) + "\n")
    print(f"wrote {TOLERANCES}: {len(measured)} scenarios; kernels {', '.join(kernels)}", file=sys.stderr)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description="Write tests/golden/tolerances.json from per-kernel records.")
    parser.add_argument("records", nargs="+", help="record.py's output under each kernel, the host's first")
    parser.add_argument("--scenario", action="append", default=[], help="replace only this scenario's entries")
    arguments = parser.parse_args()
    main(arguments.records, arguments.scenario)
