"""Scenario files: the validated configuration (schema, with the CCSDS file keys of exchange_specs), its
translation into arrays (setup; a truth from an OEM or OPM in orbit_files, measurements from a TDM in observed)
and the commented starting scenarios `liaison new` writes (templates.py, templates/)."""
