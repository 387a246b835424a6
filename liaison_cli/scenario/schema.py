"""The documented entry point for reading scenarios from Python (docs/python-api.md):
`from liaison_cli.scenario.schema import load_scenario, apply_overrides`.

Both are defined in scenario.loading; liaison's own code and tests import every scenario name from the module
that defines it:

- scenario.spec_base: the strict base model every section derives from;
- scenario.participants: spacecraft, ground stations, the dated (ephemeris) dynamics;
- scenario.links: links, topology, a link's noise, the measurement epochs;
- scenario.radio_settings: the noise section, link budgets, the `liaison budget` link file;
- scenario.estimation_settings: filter, batch, clock synchronisation, initial error, Monte Carlo;
- scenario.scenario_model: `Scenario`, its sections and the rules between them;
- scenario.loading: reading, validating, overriding.
"""

from liaison_cli.scenario.loading import apply_overrides, load_scenario

__all__ = ["apply_overrides", "load_scenario"]
