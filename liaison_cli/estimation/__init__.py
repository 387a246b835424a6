"""Estimators: the EKF (its steps in ekf, the compiled loop in filter_loop, its start from an initial batch
solution in initial_batch), batch least squares (the Gauss-Newton pieces it shares with the initial batch in
gauss_newton), LinCov, the RTS smoother, process noise (process_noise; its per-step form in the RIC frame in
ric_noise), clock synchronisation by a quadratic fit (clock_sync), the state blocks (blocks: spacecraft, clocks,
constants, dynamics parameters, empirical accelerations) and the named argument groups of the compiled kernels (kernel_args); each estimator described once (estimator: what it
carries and supports, its entry point) and registered in estimators. The steps know nothing of the dynamics
or observables; the loop wires them in."""

from liaison_cli.compiled_cache import install as _install_compiled_cache

_install_compiled_cache()  # before the first @njit(cache=True) of the package: numba picks a locator there
