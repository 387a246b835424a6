"""Running studies: one Monte Carlo run as a work unit (worker), the fan-out (runner, backends), seeding,
resumable sweeps (sweep, grid), Parquet results, the error budget, the 003 / 004 studies, and one run of a
result folder as CCSDS files (exchange_export)."""
