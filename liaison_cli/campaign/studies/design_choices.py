"""A design's `--choices` file read and checked: labelled options, each setting several scenario values at once
(campaign.studies.design)."""


def read_choices(path) -> list:
    """A choices file: each top-level key a factor (a column of the table), its value a mapping of labels to
    options, each option a mapping of dotted scenario keys to the values it sets together, e.g.

        transmitter:
          dro: {spacecraft.0: {name: TX, orbit: dro, period_days: 15.91}}
          halo: {spacecraft.0: {name: TX, orbit: l2_halo_north, period_days: 14.75}}

    -> [(factor, [(label, ((key, value), ...)), ...]), ...], file order kept; one line naming the file and the
    entry on anything else."""
    from liaison_cli.errors import ScenarioError
    from liaison_cli.scenario.loading import read_scenario_text

    data, _ = read_scenario_text(path)
    shape = ("allowed: a mapping of factor names, each a mapping of labels, each a mapping of dotted scenario keys "
             "to values (e.g. transmitter: {dro: {spacecraft.0: {name: TX, orbit: dro}}})")
    if not isinstance(data, dict) or not data:
        raise ScenarioError(f"{path}: not a choices file; {shape}")
    choices = []
    for factor, options in data.items():
        if not isinstance(factor, str) or not factor or not isinstance(options, dict) or not options:
            raise ScenarioError(f"{path}: {factor!r}: {shape}")
        parsed = []
        for label, option in options.items():
            if isinstance(label, bool) or not isinstance(label, (str, int, float)):
                raise ScenarioError(f"{path}: {factor}: label {label!r}: allowed: a text or a number (quote yes, no "
                                    "and null)")
            if not isinstance(option, dict) or not option or not all(isinstance(k, str) and k for k in option):
                raise ScenarioError(f"{path}: {factor}.{label}: {shape}")
            bad = _non_text_key(option)
            if bad is not None:
                raise ScenarioError(f"{path}: {factor}.{label}: key {bad!r}: allowed: text keys (a scenario's keys "
                                    "are words)")
            parsed.append((str(label), tuple(option.items())))
        labels = [label for label, _ in parsed]
        if len(set(labels)) < len(labels):
            raise ScenarioError(f"{path}: {factor}: two labels read the same ({', '.join(labels)}); allowed: "
                                "distinct labels")
        choices.append((factor, parsed))
    return choices


def _non_text_key(value):
    """The first mapping key in `value` (at any depth) that is not text, or None."""
    stack = [value]
    while stack:
        item = stack.pop()
        if isinstance(item, dict):
            for key, inner in item.items():
                if not isinstance(key, str):
                    return key
                stack.append(inner)
        elif isinstance(item, list):
            stack.extend(item)
    return None
