"""The rules between sections that the links own: a second receiver's ends and observables, repeated links,
the station priority list against the ground stations, and each observable against its receiver and the noise
section (what it needs: an antenna baseline, a clock, its sigma). Scenario._consistent calls them; each raises
ValueError with a one-line message naming the link by its index."""

from liaison_cli.measurements.registry import OBSERVABLES


def check_second_receiver(scenario, i, link, known):
    """Three-end channels (TDoA, FDoA) and the links that carry them."""
    differences = [o for o in link.observables if OBSERVABLES[o].needs_second_receiver]
    if differences and link.second_receiver is None:
        raise ValueError(f"links[{i}] measures {differences[0]!r}, a difference between two receivers, with one "
                         f"receiver ({link.receiver!r}): give 'second_receiver'")
    if link.second_receiver is None:
        return
    others = [o for o in link.observables if not OBSERVABLES[o].needs_second_receiver]
    if others:
        raise ValueError(f"links[{i}] has a second_receiver, but {others[0]!r} is a two-end observable; "
                         "a link with a second receiver carries tdoa / fdoa only")
    if link.second_receiver == link.transponder:
        raise ValueError(f"links[{i}]: {link.transponder!r} is the transmitter and also a receiver")
    if link.second_receiver == link.receiver:
        raise ValueError(f"links[{i}] names {link.receiver!r} as both receivers")
    if {link.receiver, link.transponder, link.second_receiver} <= known:
        raise ValueError(f"links[{i}] joins three known participants: it carries no information on any "
                         "estimated state")


def check_repeated_links(scenario):
    """The same measurement listed twice would be counted twice (as if its noise were halved). A link is
    its ends in their roles; a difference of arrival is the same with its two receivers swapped (the
    negated value). The reverse direction (B receiving from A beside A from B) is another link."""
    seen = {}
    for i, link in enumerate(scenario.links):
        if link.second_receiver is None:
            ends = (link.receiver, link.transponder)
        else:
            ends = (link.transponder, frozenset((link.receiver, link.second_receiver)))
        if ends in seen:
            j = seen[ends]
            second = f", second_receiver {link.second_receiver}" if link.second_receiver else ""
            raise ValueError(f"links[{i}] repeats links[{j}] (receiver {link.receiver}, transponder "
                             f"{link.transponder}{second}): it would count the same measurement twice; "
                             f"allowed: one link per set of ends, with all its observables in links[{j}]")
        seen[ends] = i


def check_station_priority(scenario):
    if scenario.station_priority is None:
        return
    stations = [st.name for st in scenario.ground_stations]
    for i, name in enumerate(scenario.station_priority):
        if name not in stations:
            raise ValueError(f"station_priority[{i}] = {name!r} is not a ground station; defined: "
                             f"{', '.join(stations) or 'none'}")
    if len(set(scenario.station_priority)) != len(scenario.station_priority):
        raise ValueError(f"station_priority lists a station twice: {scenario.station_priority}")


def check_observable(scenario, i, link, observable, receiver):
    spec = OBSERVABLES[observable]
    if spec.needs_receiver_baseline and getattr(receiver, "antenna_baseline_m", None) is None:
        raise ValueError(
            f"links[{i}] cannot measure {observable!r}: its receiver {link.receiver!r} has no antenna "
            "array (set antenna_baseline_m on that spacecraft)"
        )
    missing = spec.missing_noise(link.noise.applied_to(scenario.noise) if link.noise is not None else scenario.noise)
    if missing:
        raise ValueError(f"links[{i}] measures {observable}: {missing}")
    if spec.needs_both_clocks:
        for who in (link.receiver, link.transponder):
            if getattr(scenario.participant(who), "clock", None) is None:
                raise ValueError(f"links[{i}] measures {observable!r}, timed by both ends' clocks, but "
                                 f"{who!r} has no clock model (give it a 'clock' section)")
    if spec.needs_receiver_clock and getattr(receiver, "clock", None) is None:
        raise ValueError(f"links[{i}] measures {observable!r}, timed by the receiver's clock, but "
                         f"{link.receiver!r} has no clock (give that spacecraft a 'clock' section)")
