"""Orbit catalog and initial-state builders (pure numeric)."""
