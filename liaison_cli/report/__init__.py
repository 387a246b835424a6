"""Formatting and drawing, never computing a study nor writing its tables: each study's text (Table 3 beside the
paper: table3; compare; 002's tables: nrho002; study003, study004; the tune table: tuning; the error budget:
error_budget) and figures (study003, study004, nrho002's histograms, geometry's heat maps,
observability_report's effectiveness, error_budget's stacked areas, fig15), drawn from the frames
campaign.studies returns, into the folder campaign.studies.output hands them; the text `liaison run` prints
(run_text) and the `--json` summaries (json_summary); figures of a run result (read back by run_result.py; its
consistency figures in consistency_plots) and of orbit families (orbit_plots); the link budget read off a sweep
(budget). report/ imports nothing from campaign/ or estimation/ (but the estimator descriptors' registry, to
choose what a run's figures draw); tests/test_architecture.py checks it."""
