"""Formatting and drawing: paper tables beside ours, the text `liaison run` prints and the `--json` summaries,
figures of a run result (read back by run_result.py; its consistency figures in consistency_plots), of sweeps, studies, families and geometry."""
