"""Running studies: one Monte Carlo run as a work unit (worker), the one fan-out every long command uses
(backends.map_batches: joblib's process pool or dask, a bounded window of work in flight) and its ordered layer
for a scenario's runs (runner), seeding, resumable sweeps (sweep: sweep_plan, sweep_manifest, sweep_tables;
grid; its workers' light module sweep_worker), compiling ahead (warmup), the 003 / 004 studies' finished cells for resuming (study_cells), Parquet results, the error budget, the
tuning ladder (tuning), one run of a result folder as CCSDS files (exchange_export), and the studies that
compute: the 003 / 004 studies, Turan et al.'s Table 3 (table3), the formation geometry (geometry) and a
scenario's observability (observability_study). report/ formats and draws what they return."""
