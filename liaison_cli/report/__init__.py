"""Formatting and drawing: paper tables beside ours, the text `liaison run` prints, figures of sweeps,
studies, families and geometry."""
