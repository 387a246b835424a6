"""Running studies: one Monte Carlo run as a work unit (worker), the one fan-out every long command uses
(backends.map_batches: joblib's process pool, workers forked after the first task for sweeps on Linux, or
dask; a bounded window of work in flight) and its ordered layer
for a scenario's runs (runner), seeding, a scenario's campaign as Parquet results (results), resumable sweeps
(sweep: sweep_plan, sweep_manifest, sweep_tables; grid; its workers' light module sweep_worker) and compiling
ahead (warmup).

Sub-packages:
- studies: every study's computation (003, 004, Table 3, compare, 002's tables, geometry, observability, the
  tuning ladder, the error budget), each returning frames and plain data, and `studies.output`, the one place a
  study's tables, texts and figures are written from;
- exchange: one run of a result folder recomputed and written as CCSDS files (`liaison export`).
report/ formats and draws what the studies return; the CLI puts the parts together.
"""
