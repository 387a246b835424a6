"""The studies, one template each: a compute function here returns pandas frames and plain data (no printing, no
files of the result); report/ formats them as text and draws their figures; the CLI puts the parts together as an
`output.StudyOutput` and `output` writes it through storage's atomic writers (a staged result folder, or files
beside a sweep or a named table).

- study003, study004: 003's and 004's Monte Carlo studies (004 takes its LinCov σ from error_budget), with
  study_cells: their finished cells kept in a work folder, so an interrupted study resumes;
- table3: Turan et al. (2022) Table 3 beside ours; compare: scenarios side by side (001 Tables 6-7);
- tables002: 002's tables from a sweep (DRMS and clock p90, consistency, the histograms' cell);
- geometry: the formation-geometry grids; observability_study: a scenario's information matrix;
- tuning: the process-noise ladder and its rule (`liaison tune`; its rungs are resumable sweeps in --work);
- design: `liaison design`, candidates scored by LinCov, ranked and the best verified by Monte Carlo, with
  design_choices (its --choices file read and checked) and design_store (finished batches kept, so a search
  resumes);
- error_budget: the EKF's error split by source, with its Monte Carlo check (lincov_budget: its LinCov half,
  which the engine's default-noise check reads too); budget_tables: its tables;
- output: StudyOutput and the writers (write_folder, write_files, fill_folder), the one place results are
  written from.
"""
