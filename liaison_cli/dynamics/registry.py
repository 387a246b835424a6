"""The dynamics descriptor: each dynamics model described once, as estimators (estimation.estimator) and
observables (measurements.observable) are, so the scenario's rules, its problem setup and the exports ask the
descriptor (are epochs dates? is the frame rotating? which parameters can the filter estimate?) instead of
comparing model names.

A model's numbers live beside it: its compiled propagators behind the model code (dynamics.model, one
`propagate_*` per job), its Python side (`DynamicsModel`, `EphemerisDynamicsModel`: truth, trajectories,
the filter's parameters). Adding a dynamics model is a descriptor here, a code in dynamics.model and a builder
in scenario.truth; adding an estimable parameter is a `DynamicsParameter` here and its column in the model's
compiled propagator (dynamics.model.propagate_parameter_into).
"""

from dataclasses import dataclass

MODEL_CRTBP = 0  # the codes behind the dynamics interface (dynamics.model)
MODEL_EPHEMERIS = 1


@dataclass(frozen=True)
class DynamicsParameter:
    """A parameter of a model that the filter can carry as a state (estimation.blocks.BLOCK_PARAMETER): name
    (the scenario's key under filter.estimated_parameters) and summary. The dated model has one C_R A/m for
    every spacecraft, so its C_R state is one for the formation (scenario.filter_arrays.state_layout)."""

    name: str
    summary: str


@dataclass(frozen=True)
class Dynamics:
    """name: the scenario's `dynamics` value; code: the model code the compiled propagators branch on at run time
    (the model objects, dynamics.model.DynamicsModel and EphemerisDynamicsModel, take theirs from here);
    summary: one phrase for the schema. dated: epochs are dates (TDB), so stations turn with the Earth, dated
    orbits and CCSDS dates apply; rotating_frame: the states' frame turns (measurements on a rotating frame,
    exports in it); parameters: what the filter may estimate of the model; integrator_order: the order of
    the filter's fixed-step integrator (RK4: 4, RK8: 8), which dynamics.step_choice's error estimate needs; observability:
    analysis.observability can map its partials with this model's STM (the CRTBP's adaptive DOP853); lunar_field:
    its field takes the Moon's spherical harmonics (the scenario's moon_gravity: dynamics.crtbp_field in the
    CRTBP, ephemeris_dynamics.add_moon_field in the dated model). How each
    side integrates, with its measured accuracy, is docs/model.md's."""

    name: str
    code: int
    summary: str
    dated: bool
    rotating_frame: bool
    parameters: tuple[DynamicsParameter, ...] = ()
    observability: bool = False
    integrator_order: int = 4  # the order of the filter's fixed-step integrator (dynamics.step_choice)
    lunar_field: bool = False  # its field takes the Moon's harmonics (the scenario's moon_gravity)

    def parameter(self, name: str) -> DynamicsParameter | None:
        return next((p for p in self.parameters if p.name == name), None)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)


CR = DynamicsParameter(
    "cr", "the solar-radiation-pressure coefficient's relative correction: the filter flies C_R (1 + state)")

CRTBP = Dynamics("crtbp", MODEL_CRTBP, "the Earth-Moon CRTBP, undated", dated=False, rotating_frame=True,
                 observability=True, lunar_field=True)

EPHEMERIS = Dynamics("ephemeris", MODEL_EPHEMERIS, "DE421 point masses + SRP (+ the lunar field) from ephemeris.epoch_utc", dated=True,
                     rotating_frame=False, parameters=(CR,), integrator_order=8, lunar_field=True)

DYNAMICS = {d.name: d for d in (CRTBP, EPHEMERIS)}
