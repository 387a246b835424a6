"""Scenario files: the validated configuration (schema, with the CCSDS file keys of exchange_specs) and its
translation into arrays (setup; a truth from an OEM or OPM in orbit_files, measurements from a TDM in observed)."""
