"""Running studies: one Monte Carlo run as a work unit (worker), the fan-out (runner, backends), seeding,
resumable sweeps (sweep, grid), Parquet results, the error budget, the tuning ladder (tuning), one run of a
result folder as CCSDS files (exchange_export), and the studies that compute: the 003 / 004 studies, Turan et
al.'s Table 3 (table3), the formation geometry (geometry) and a scenario's observability
(observability_study). report/ formats and draws what they return."""
