"""Scenario files: the validated configuration (schema) and its translation into arrays (setup)."""
