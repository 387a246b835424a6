"""Running studies: one Monte Carlo run as a work unit (worker), the fan-out (runner, backends), seeding,
resumable sweeps (sweep, grid), Parquet results, the error budget and the 003 / 004 studies."""
