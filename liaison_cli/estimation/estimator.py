"""The estimator descriptor: an estimator's name, the states it carries, what it supports, its own settings
section and its entry point.

Every estimator is described once (estimation.estimators registers them in ESTIMATORS, as
measurements.registry registers the observables); the scenario's rules and its arrays ask the descriptor
(does it carry clock states? solve for manoeuvres? run with these dynamics?) rather than compare names.
"""

from dataclasses import dataclass
from typing import Callable


@dataclass(frozen=True)
class Estimator:
    """name: the scenario's `estimator` value; summary: one phrase for the scenario schema's description;
    run(arrays, x0_hat (n,), y_obs (m, C), truth (m, n)) -> EstimateHistory: its entry point.

    What it carries in its state beside the spacecraft: clock states (else clocks are synchronised by
    clock_sync), link-bias states (filter.bias: estimate), Delta-v blocks (it solves for manoeuvres).
    What it supports: the scenario dynamics it runs with, the RTS smoother over its pass (filter.smoother),
    considered biases (filter.bias: consider), the residual gate (filter.residual_gate_sigma), the error
    budget (estimation.lincov mirrors its gain, so campaign.studies.error_budget can split its error), a start from an
    initial batch solution (filter.initial_batch_hours, estimation.initial_batch), process noise (the SNC that
    `liaison tune` chooses; a batch has none), dynamics-parameter states (filter.estimated_parameters: a
    model's parameter such as C_R carried as a state, estimation.blocks.BLOCK_PARAMETER), empirical
    accelerations (filter.empirical_acceleration: Gauss-Markov states, estimation.blocks.BLOCK_EMPIRICAL).
    settings_section: the scenario section of its own settings, given exactly when it is chosen (None: the
    filter section only)."""

    name: str
    summary: str
    run: Callable
    settings_section: str | None = None
    carries_clocks: bool = False
    carries_biases: bool = False
    carries_manoeuvres: bool = False
    dynamics: tuple[str, ...] = ("crtbp",)
    smoother: bool = False
    consider: bool = False
    residual_gate: bool = False
    error_budget: bool = False
    initial_batch: bool = False
    process_noise: bool = False
    dynamics_parameters: bool = False
    empirical_accelerations: bool = False
    residuals: str = "innovations"  # what its residuals table holds: pre-fit innovations, or post-fit residuals
    # Its NEES is a new sample at every epoch (a filter's), or one per run and solution (a batch's: its epoch
    # state's, repeated over the epochs the solution covers), which a per-epoch band cannot judge.
    nees_per_epoch: bool = True
    # Its estimate and covariance at every epoch (a CCSDS export), None when it cannot keep them:
    # (arrays, x0_hat (n,), y_obs (m, C), truth (m, n)) -> (EstimateHistory, estimates (m, n), covariances (m, n, n)),
    # and what its estimate is, in words (the export's COMMENT line).
    covariance_record: Callable | None = None
    record_meaning: str = ""
