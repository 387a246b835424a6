"""Running studies, in four sub-packages:
- engine: a scenario's Monte Carlo runs: one run as a work unit (worker), seeding, the one fan-out every long
  command uses (backends.map_batches: joblib's process pool, workers forked after the first task for sweeps on
  Linux, or dask; a bounded window of work in flight), its ordered layer for a scenario's runs and the error
  budget's check runs (runner), a scenario's problem with its default noise checked by LinCov (noise_check), a
  scenario's campaign as Parquet results (results) and compiling ahead (warmup);
- sweep: resumable sweeps over a grid of overrides (run, plan, manifest, tables, grid, and worker, the light
  module its workers import);
- studies: every study's computation (003, 004, Table 3, compare, 002's tables, geometry, observability, the
  tuning ladder, the error budget), each returning frames and plain data, and `studies.output`, the one place a
  study's tables, texts and figures are written from;
- exchange: one run of a result folder recomputed and written as CCSDS files (`liaison export`).
report/ formats and draws what the studies return; the CLI puts the parts together.
"""
