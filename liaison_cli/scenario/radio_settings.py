"""Scenario radio settings: the noise section (sigmas given, or derived from a link budget by a ranging
method and the carrier), link budgets, and the link file of `liaison budget` (with the dual one-way
receiver)."""

from typing import ClassVar, Literal

from pydantic import ConfigDict, Field, model_validator

from liaison_cli.radio.carrier import TURNAROUND_S_BAND
from liaison_cli.radio.link_budget import LinkLeg
from liaison_cli.radio.ranging import carrier_sigmas_from_link_budget, pn_chip_rate_bias_m, sigma_from_link_budget
from liaison_cli.scenario.schema_rules import (Rule, all_of, any_of, check_rules, equals, given, negate, not_given,
                                               schema_rules, when)
from liaison_cli.scenario.spec_base import StrictModel


class LinkLegSpec(StrictModel):
    """One direction of a crosslink (000 Table 2): EIRP, free-space loss and G/T give C/N0 and Es/N0."""

    distance_km: float = Field(gt=0, description="transmitter-receiver distance (km)")
    frequency_mhz: float = Field(gt=0, description="carrier frequency (MHz)")
    tx_power_dbw: float = Field(description="transmitter power (dBW)")
    tx_losses_db: float = Field(ge=0, description="transmitter losses (dB)")
    tx_antenna_gain_dbi: float = Field(description="transmit antenna gain (dBi)")
    data_rate_bps: float = Field(gt=0, description="information bit rate (bit/s)")
    rx_losses_db: float = Field(ge=0, description="receiver losses (dB)")
    rx_g_over_t_db_k: float = Field(description="receiver figure of merit G/T (dB/K)")
    margin_db: float = Field(0.0, ge=0, description="design margin held back from Es/N0 (dB)")
    code_rate: float = Field(1.0, gt=0, le=1, description="information bits per channel symbol, 1 = uncoded "
                             "(dimensionless)")

    def leg(self) -> LinkLeg:
        return LinkLeg(**self.model_dump())


class LinkBudgetSpec(StrictModel):
    """Both legs of a two-way transponder link."""

    uplink: LinkLegSpec = Field(description="receiver to transponder")
    downlink: LinkLegSpec = Field(description="transponder back to the receiver")


RANGING_METHODS = ("time_derived", "telemetry", "pn", "tone")
RangingMethod = Literal["time_derived", "telemetry", "pn", "tone"]
CLOCK_KEYS = ("ranging_clock_hz", "loop_bandwidth_hz", "ranging_power_fraction_db")


class CarrierSpec(StrictModel):
    """Carrier-phase observables of a two-way coherent link, from the link budget (001 Eq. 5, 9)."""

    power_fraction_db: float = Field(le=0, description="residual carrier share of each leg's received power (dB)")
    loop_bandwidth_hz: float = Field(gt=0, description="one-sided carrier PLL noise bandwidth at both ends (Hz)")
    doppler_count_s: float = Field(gt=0, description="Doppler count (integration) time (s)")
    turnaround_ratio: float = Field(TURNAROUND_S_BAND, gt=0, description="transponder downlink/uplink frequency "
                                    "ratio; default S-band 240/221 (dimensionless)")

    def sigmas(self, link_budget: "LinkBudgetSpec") -> dict:
        return carrier_sigmas_from_link_budget(
            link_budget.uplink.leg(), link_budget.downlink.leg(), self.power_fraction_db,
            self.loop_bandwidth_hz, self.doppler_count_s, self.turnaround_ratio)


class NoiseSpec(StrictModel):
    """Range sigma: `sigma_m` directly, or `ranging_method` + `link_budget` (000 Eq. 1-4, 001 Eq. 62-63).
    Range-rate and LOS sigmas: directly, or from the link budget's carrier (`carrier`, 001 Eq. 5 and 9)."""

    RULES: ClassVar[tuple] = (
        Rule(any_of(given("sigma_m"), given("ranging_method")), "give 'sigma_m' or both 'ranging_method' and 'link_budget'"),
        Rule(negate(all_of(given("sigma_m"), given("ranging_method"))),
             "give either 'sigma_m' or 'ranging_method' + 'link_budget', not both"),
        Rule(when(given("ranging_method"), given("link_budget")), "'ranging_method' and 'link_budget' go together"),
        Rule(when(given("carrier"), given("link_budget")),
             "'carrier' derives its sigmas from the link budget: give 'link_budget'"),
        Rule(when(given("link_budget"), any_of(given("ranging_method"), given("carrier"))),
             "'link_budget' is used by 'ranging_method' or 'carrier'; give one of them"),
        Rule(when(equals("ranging_method", "telemetry", "pn", "tone"), all_of(*map(given, CLOCK_KEYS))),
             lambda spec: f"ranging_method {spec.ranging_method!r} needs "
                          f"{', '.join(k for k in CLOCK_KEYS if getattr(spec, k) is None)}"),
        Rule(when(given("pn_chip_rate_offset_hz"), equals("ranging_method", "pn")),
             "'pn_chip_rate_offset_hz' applies to ranging_method 'pn' only"),
        *(Rule(when(given("carrier"), not_given(key)), f"give either '{key}' or 'carrier' (which derives it), not both")
          for key in ("range_rate_sigma_m_s", "los_path_sigma_m")))
    model_config = ConfigDict(json_schema_extra=schema_rules(*RULES))

    sigma_m: float | None = Field(None, gt=0, description="1-sigma of range-like channels (m)")
    ranging_method: RangingMethod | None = Field(None, description="derive the range sigma from link_budget by "
                                                 "this method instead of giving sigma_m")
    link_budget: LinkBudgetSpec | None = Field(None, description="for ranging_method and carrier")
    correlator_integration_s: float = Field(0.3, gt=0, description="correlator integration time (s)")
    ranging_clock_hz: float | None = Field(None, gt=0, description="PN / telemetry ranging clock, or the major "
                                           "tone (Hz)")
    loop_bandwidth_hz: float | None = Field(None, gt=0, description="one-sided ranging clock / tone tracking loop "
                                            "bandwidth (Hz)")
    ranging_power_fraction_db: float | None = Field(None, le=0, description="share of the received uplink power in "
                                                    "the ranging clock or tone (dB)")
    carrier: CarrierSpec | None = Field(None, description="derive the range-rate and LOS sigmas from link_budget")
    bias_m: float = Field(0.0, description="constant bias added to the range-like channels of every link in the "
                          "truth (m)")
    bias_sigma_m: float = Field(0.0, ge=0, description="per run and link, a random bias of this 1-sigma is added "
                                "(m)")
    bias_distribution: Literal["normal", "uniform"] = Field(
        "normal", description="the per-run bias's law: normal, or uniform over +-sqrt(3) bias_sigma_m (003)")
    pn_chip_rate_offset_hz: float | None = Field(
        None, description="PN ranging: received minus local chip rate; adds the constant bias of 000 Eq. 2 (Hz)")
    range_rate_sigma_m_s: float | None = Field(None, gt=0, description="1-sigma of range-rate channels (m/s)")
    los_path_sigma_m: float | None = Field(
        None, gt=0, description="path-difference error across the receiver's baseline (LOS, 001 Eq. 8) (m)")
    tdoa_sigma_ns: float | None = Field(None, gt=0, description="1-sigma of TDoA channels (004 Table 3: 20 ns) (ns)")
    fdoa_sigma_hz: float | None = Field(None, gt=0, description="1-sigma of FDoA channels (004 Table 3: 0.04 Hz) "
                                        "(Hz)")
    carrier_frequency_hz: float | None = Field(None, gt=0, description="the transmitter's carrier, for FDoA (Hz)")

    @model_validator(mode="after")
    def _one_source_of_sigma(self):
        return check_rules(self, self.RULES)

    def resolved_sigma_m(self) -> float:
        if self.sigma_m is not None:
            return self.sigma_m
        return sigma_from_link_budget(
            self.ranging_method,
            self.link_budget.uplink.leg(),
            self.link_budget.downlink.leg(),
            self.correlator_integration_s,
            self.ranging_clock_hz,
            self.loop_bandwidth_hz,
            self.ranging_power_fraction_db,
        )

    def resolved_bias_m(self) -> float:
        """The constant range bias: `bias_m`, plus the PN chip-rate-mismatch bias (000 Eq. 2) if given."""
        if self.pn_chip_rate_offset_hz is None:
            return self.bias_m
        return self.bias_m + pn_chip_rate_bias_m(self.ranging_clock_hz, self.pn_chip_rate_offset_hz,
                                                 self.correlator_integration_s)

    def resolved_range_rate_sigma_m_s(self) -> float | None:
        if self.carrier is not None:
            return self.carrier.sigmas(self.link_budget)["range_rate_sigma_m_s"]
        return self.range_rate_sigma_m_s

    def resolved_los_path_sigma_m(self) -> float | None:
        if self.carrier is not None:
            return self.carrier.sigmas(self.link_budget)["los_path_sigma_m"]
        return self.los_path_sigma_m


class DualOneWayReceiverSpec(StrictModel):
    """A dual one-way ranging receiver (002 §2, Eq. 8-12): code (DLL) and carrier (PLL) tracking."""

    carrier_frequency_hz: float = Field(gt=0, description="carrier frequency (Hz)")
    c_n0_db_hz: float = Field(gt=0, le=100, description="received carrier-to-noise density C/N0 (dB-Hz)")
    code_loop_bandwidth_hz: float = Field(gt=0, description="B_n of the DLL (Hz)")
    code_integration_s: float = Field(gt=0, description="predetection integration of the DLL (s)")
    front_end_bandwidth_hz: float = Field(gt=0, description="two-sided front-end bandwidth B_fe (Hz)")
    chip_rate_hz: float = Field(gt=0, description="spreading-code rate R_c (chip/s)")
    correlator_spacing_s: float = Field(gt=0, description="early-to-late spacing D (s)")
    doppler_bandwidth_hz: float = Field(gt=0, description="B_d of the PLL (Hz)")
    carrier_integration_s: float = Field(gt=0, description="coherent integration of the PLL (s)")

    @model_validator(mode="after")
    def _spacing_below_two_chips(self):
        if self.correlator_spacing_s * self.chip_rate_hz >= 2.0:
            raise ValueError(f"correlator_spacing_s = {self.correlator_spacing_s} is "
                             f"{self.correlator_spacing_s * self.chip_rate_hz:.3g} chips; the DLL model needs < 2 chips")
        return self

    def receiver(self):
        from liaison_cli.radio.dual_one_way import DualOneWayReceiver

        return DualOneWayReceiver(**self.model_dump())


class RangingLinkFile(StrictModel):
    """A crosslink for `liaison budget`: both legs' link budgets plus the ranging parameters, and optionally
    the carrier (Doppler / LOS); or a dual one-way receiver (002), or both. Methods whose parameters are
    missing (telemetry / PN / tone need the ranging clock or tone) are reported as not computable."""

    description: str = ""
    link_budget: LinkBudgetSpec | None = None
    dual_one_way: DualOneWayReceiverSpec | None = None
    correlator_integration_s: float = Field(0.3, gt=0)
    ranging_clock_hz: float | None = Field(None, gt=0)
    loop_bandwidth_hz: float | None = Field(None, gt=0)
    ranging_power_fraction_db: float | None = Field(None, le=0)
    carrier: CarrierSpec | None = None

    @model_validator(mode="after")
    def _something_to_compute(self):
        if self.link_budget is None and self.dual_one_way is None:
            raise ValueError("give 'link_budget' (transponder ranging) or 'dual_one_way' (002 receiver), or both")
        if self.carrier is not None and self.link_budget is None:
            raise ValueError("'carrier' derives its sigmas from the link budget: give 'link_budget'")
        return self

    def sigma_by_method(self) -> dict:
        """{method: sigma_m or None when its parameters are missing}; empty without a link budget."""
        if self.link_budget is None:
            return {}
        clock = tuple(getattr(self, k) for k in CLOCK_KEYS)
        out = {}
        for method in RANGING_METHODS:
            if method != "time_derived" and None in clock:
                out[method] = None
                continue
            out[method] = sigma_from_link_budget(
                method, self.link_budget.uplink.leg(), self.link_budget.downlink.leg(),
                self.correlator_integration_s, *clock,
            )
        return out
