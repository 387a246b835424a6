"""Metrics, filter consistency and (later) observability analysis."""
