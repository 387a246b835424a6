"""Estimators: the EKF (its steps in ekf, the compiled loop in filter_loop, its start from an initial batch
solution in initial_batch), batch least squares, LinCov, the RTS smoother, process noise, clock synchronisation
by a quadratic fit (clock_sync), the state blocks (blocks: spacecraft, clocks, constants, dynamics parameters)
and the named argument groups of the compiled kernels (kernel_args); each estimator described once (estimator: what it
carries and supports, its entry point) and registered in estimators. The steps know nothing of the dynamics
or observables; the loop wires them in."""
