"""Resumable sweeps: scenarios x a full-factorial grid of overrides x Monte Carlo runs, through the engine's one
fan-out on joblib or dask.

- plan: grid points, tasks and their stable ids, the manifest header;
- manifest: the manifest (what is done: resume), its format rule, and the folder lock;
- run: running the tasks not yet in the manifest, then the tables (run_sweep);
- tables: the runs and curve tables, rebuilt from the manifest;
- worker: the workers' side, a light module of its own (a pool worker imports the module of its function);
- grid: the grids given on the command line (`--sigma`, `--grid`) and their size caps.
"""
