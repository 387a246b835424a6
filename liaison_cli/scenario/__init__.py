"""Scenario files: the validated configuration and its translation into arrays.

The configuration is split by concern: participants, links, radio_settings (noise and link budgets),
estimation_settings (filter, batch, clock sync, initial error, Monte Carlo), model_error (the filter's dynamics
off from the truth's on purpose, and the truth's unmodelled forces), scenario_model (the whole `Scenario`; the
rules between sections grouped by owner: link_rules, estimation_rules, dynamics_rules, the rest in
scenario_model), loading (read, validate, override), on spec_base, with the CCSDS file keys in exchange_specs;
schema is the documented entry point for Python (load_scenario, apply_overrides); schema_rules (each in-section
rule declared once) and json_schema give the editor's JSON Schema. truth (the participants' trajectories,
visibility and noise-free measurements; a run's own under a drawn force; single spacecraft's truths kept on disk
by truth_store), setup, dated and reference_states turn
a scenario into the truth and the filter's arrays (a truth from an OEM or OPM in orbit_files, measurements from
a TDM in observed), with what the tool chooses where the keys leave it open: each spacecraft's integrator step
(integration_steps) and the default process noise (default_noise); templates.py and templates/ hold the commented starting scenarios `liaison new` writes."""
