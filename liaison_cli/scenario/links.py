"""Scenario links: who measures whom and what (links, or a star / mesh topology expanded into links), a
link's own sigmas, and when every link measures."""

from typing import Literal

from pydantic import ConfigDict, Field, field_validator

from liaison_cli.measurements.registry import OBSERVABLES
from liaison_cli.scenario.schema_rules import each, equals, given, negate, not_given, schema_rules, when
from liaison_cli.scenario.spec_base import UNIQUE, StrictModel


ObservableName = Literal[tuple(OBSERVABLES)]
_DIFFERENCES = [name for name, spec in OBSERVABLES.items() if spec.needs_second_receiver]  # tdoa, fdoa


class LinkNoiseSpec(StrictModel):
    """This link's own sigmas, overriding the scenario's noise section for its channels (e.g. 003: DSN range
    10 m and range-rate 0.5 mm/s beside crosslinks at 1 m and 1 mm/s)."""

    sigma_m: float | None = Field(None, gt=0, description="1-sigma of range-like channels (pseudoranges: per "
                                  "one-way) (m)")
    range_rate_sigma_m_s: float | None = Field(None, gt=0, description="1-sigma of range-rate channels (m/s)")
    los_path_sigma_m: float | None = Field(None, gt=0, description="1-sigma of the LOS path difference across the "
                                           "receiver's baseline (m)")

    def applied_to(self, noise):
        """The scenario's noise spec with this link's values in force."""
        update = self.model_dump(exclude_none=True)
        if "sigma_m" in update:
            update["ranging_method"] = None
        if "range_rate_sigma_m_s" in update or "los_path_sigma_m" in update:
            update["carrier"] = None
        return noise.model_copy(update=update)


class LinkSpec(StrictModel):
    """A link between two participants: the receiver (mothercraft, or ground station) measures through the
    transponder (for one-way observables such as pseudorange: the transmitter). `occultation: true` blanks
    epochs at which the Earth or the Moon blocks the line of sight; links to a ground station always obey
    the station's elevation mask."""

    model_config = ConfigDict(json_schema_extra=schema_rules(when(
        given("second_receiver"), {"required": ["observables"], **each("observables", {"enum": _DIFFERENCES})},
        {"properties": {"observables": negate({"contains": {"enum": _DIFFERENCES}})}})))

    receiver: str = Field(description="the measuring end: a spacecraft or ground station name")
    transponder: str = Field(description="the other end (the transmitter of one-way observables): a spacecraft "
                             "or ground station name")
    second_receiver: str | None = Field(None, description="the other receiver of a difference of arrival (tdoa, "
                                        "fdoa): value = second minus first")
    observables: list[ObservableName] = Field(default_factory=lambda: ["range"], min_length=1,
                                              description="what the link measures, each at most once",
                                              json_schema_extra=UNIQUE)
    occultation: bool = Field(False, description="blank the epochs at which the Earth or the Moon blocks the line "
                              "of sight")
    noise: LinkNoiseSpec | None = Field(None, description="this link's sigmas (default: the noise section's)")

    @field_validator("observables")
    @classmethod
    def _no_repeats(cls, value):
        if len(set(value)) != len(value):
            raise ValueError(f"repeated observable in {value}")
        return value


class TopologySpec(StrictModel):
    """`star`: the hub (mothercraft) receives from every other spacecraft; `mesh`: every pair is linked,
    the spacecraft listed first receiving. Expanded into `links` when the scenario is read."""

    model_config = ConfigDict(json_schema_extra=schema_rules(when(equals("kind", "star"), given("hub"),
                                                                  not_given("hub"))))

    kind: Literal["star", "mesh"] = Field(description="star: the hub receives from every other spacecraft; mesh: "
                                          "every pair is linked")
    hub: str | None = Field(None, description="star: the receiving spacecraft (mothercraft)")
    observables: list[ObservableName] = Field(default_factory=lambda: ["range"], min_length=1,
                                              description="what every link measures, each at most once",
                                              json_schema_extra=UNIQUE)


def expand_topology(data: dict) -> dict:
    """Before validation: turn `topology` into the explicit link list (kept beside it for provenance)."""
    topology = data.get("topology")
    if not isinstance(topology, dict) or not isinstance(data.get("spacecraft"), list):
        return data
    names = [sc.get("name") for sc in data["spacecraft"] if isinstance(sc, dict)]
    kind, hub = topology.get("kind"), topology.get("hub")
    if kind == "star":
        if hub is None:
            raise ValueError(f"topology star needs a 'hub' (the mothercraft); spacecraft: {', '.join(map(str, names))}")
        if hub not in names:
            raise ValueError(f"topology hub {hub!r} is not a spacecraft; defined: {', '.join(map(str, names))}")
        links = [{"receiver": hub, "transponder": name} for name in names if name != hub]
        observables = topology.get("observables")
    elif kind == "mesh":
        if hub is not None:
            raise ValueError("topology mesh takes no 'hub' (every pair is linked)")
        links = [{"receiver": a, "transponder": b} for i, a in enumerate(names) for b in names[i + 1 :]]
        observables = topology.get("observables")
    else:
        raise ValueError(f"topology kind {kind!r} is not allowed; allowed: star, mesh")
    given = data.get("links")
    if given is not None:
        normalised = [{"receiver": li.get("receiver"), "transponder": li.get("transponder")}
                      for li in given if isinstance(li, dict)]
        if normalised != links:
            raise ValueError("give either 'links' or 'topology', not both")
        return data
    if observables is not None:
        links = [{**link, "observables": observables} for link in links]
    return {**data, "links": links}


class MeasurementSpec(StrictModel):
    """When every link measures, and how the truth is simulated."""

    interval_s: float = Field(gt=0, description="time between measurement epochs, from t0 (s)")
    light_time: bool = Field(True, description="simulate the truth with light time (false: instantaneous)")


def link_label(link) -> str:
    """How outputs name a link: 'receiver->transponder', and for a three-end link (TDoA, FDoA) both receivers,
    'receiver/second_receiver->transponder'."""
    receivers = link.receiver if link.second_receiver is None else f"{link.receiver}/{link.second_receiver}"
    return f"{receivers}->{link.transponder}"
