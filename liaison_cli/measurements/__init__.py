"""Measurement models: one small object per observable with value(states) and partials(states)."""
