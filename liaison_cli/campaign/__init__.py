"""Scenario schema, problem preparation, seeding, fan-out and Parquet results."""
