"""The integrators: every way liaison steps an ordinary differential equation, one module per kind.

- `rk4`: fixed-step classical RK4 for the CRTBP: the filter's state + STM, the STM on a coarser grid than the
  state (`rk4_state_stm_into`, and `rk4_state_stm` allocating its result), state + STM with every step
  (`rk4_variational_into`, `rk4_variational`), and the compiled truth's sampled trajectory (`rk4_states_forced`,
  with an unmodelled acceleration, constant or drawn per run; `rk4_states`, a Python call of it with none).
- `rk8`: fixed-step 8th order Runge-Kutta on DOP853's 12-stage tableau (`dop853_tableau`, vendored as literal
  floats with the error and dense-output rows): the stage kernels (`rk8_stage_input`, `rk8_combine`), the
  CRTBP's (`rk8_advance` in place, `rk8_state`, `rk8_state_stm`), the CRTBP truth with the lunar harmonics
  (`rk8_states_forced`), the dated ephemeris field's (`rk8_advance_ephemeris`), and the batch's step schedule
  (`step_counts`).
- `dop853`: adaptive DOP853 compiled for the CRTBP, with scipy's step-size control and dense output: the
  reference propagations of a state or a state + STM (`dop853_states`, `dop853_state_stm`) that the orbit
  corrector, the catalogue, observability and the orbit plots use.
- `adaptive`: scipy's adaptive DOP853 behind one wrapper taking the right-hand side (`dop853_samples`, with
  restarts at terminal events): the dated ephemeris truth (`dynamics.ephemeris_dynamics.dop853_ephemeris_states`)
  calls it with its shadow-edge events.

The right-hand sides stay with their models (`dynamics.crtbp`, `dynamics.ephemeris_dynamics`); the compiled
kernels call them directly, so numba inlines them (no function arguments in compiled code). A name ending
in `_into` does its job into the caller's buffers (no allocation); the same name without it allocates.
"""
