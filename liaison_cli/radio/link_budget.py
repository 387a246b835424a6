"""One-way radio link budget: EIRP, free-space loss, G/T -> C/N0 -> Es/N0 (Turan et al. 2022, Table 2)."""

import math
from dataclasses import dataclass

from liaison_cli.dynamics.constants import BOLTZMANN_DBW_PER_K_HZ, SPEED_OF_LIGHT_KM_S


@dataclass(frozen=True)
class LinkLeg:
    """One direction of a crosslink. Decibel quantities as in Table 2."""

    distance_km: float
    frequency_mhz: float
    tx_power_dbw: float
    tx_losses_db: float
    tx_antenna_gain_dbi: float
    data_rate_bps: float
    rx_losses_db: float
    rx_g_over_t_db_k: float
    margin_db: float = 0.0
    code_rate: float = 1.0  # information bits per channel symbol (1 = uncoded)

    @property
    def free_space_loss_db(self) -> float:
        wavelength_km = SPEED_OF_LIGHT_KM_S / (self.frequency_mhz * 1e6)
        return 20.0 * math.log10(4.0 * math.pi * self.distance_km / wavelength_km)

    @property
    def eirp_dbw(self) -> float:
        return self.tx_power_dbw - self.tx_losses_db + self.tx_antenna_gain_dbi

    @property
    def c_over_n0_dbhz(self) -> float:
        """Received carrier-to-noise density, before the design margin is taken."""
        return (
            self.eirp_dbw
            - self.free_space_loss_db
            - self.rx_losses_db
            + self.rx_g_over_t_db_k
            - BOLTZMANN_DBW_PER_K_HZ
        )

    @property
    def symbol_rate_sps(self) -> float:
        return self.data_rate_bps / self.code_rate

    @property
    def symbol_duration_s(self) -> float:
        return 1.0 / self.symbol_rate_sps

    @property
    def es_over_n0_db(self) -> float:
        """Symbol energy to noise density with the link margin held back."""
        return self.c_over_n0_dbhz - self.margin_db - 10.0 * math.log10(self.symbol_rate_sps)


def db_to_linear(value_db: float) -> float:
    return 10.0 ** (value_db / 10.0)
