"""The Monte Carlo engine: what runs a scenario's runs, wherever they run.

- worker: one run as a work unit (draws, estimator, metrics); it never raises, a failure is an outcome;
- clock_record: a run's clock record (the estimated clocks, or clock_sync's fitted clocks) and its clocks' names;
- seeding: a run's random generators (its draws, and a drawn truth force's own stream), from the scenario seed
  and the run index only;
- backends: the one fan-out (map_batches: joblib's process pool, forked workers, or dask), with a bounded
  window of work in flight;
- runner: its ordered layer (run_tasks_in_order): a small job in this process, else its first task here and the
  rest through the fan-out in task order; a scenario's runs (iter_outcomes, run_campaign) and the error
  budget's check runs go through it;
- noise_check: a scenario's problem as every command sets it up (prepare_checked_problem): the derived default
  process noise checked by LinCov, a lunar-field part it finds optimistic raised;
- results: a scenario's campaign streamed to Parquet with provenance, and its tables as DataFrames;
- warmup: compiling every kernel specialisation the shipped scenarios need, ahead of the first run (a helper
  process compiles the calls by address while it reads the scenarios);
- ahead: while `liaison run` compiles, a helper process compiling on the idle core what `liaison errors` and
  `liaison observability` need for the same scenario;
- helper_process: the second process both start to compile ahead (silent, lower priority, the run's own code,
  ending with the process that started it).
"""
