"""Scenario files: the validated configuration (schema), its translation into arrays (setup), and the
commented starting scenarios `liaison new` writes (templates.py, templates/)."""
