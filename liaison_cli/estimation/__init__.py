"""Estimators: the EKF (its steps in ekf, the compiled loop in filter_loop), batch least squares, LinCov, the
RTS smoother, process noise and the state blocks; each estimator described once (estimator: what it
carries and supports, its entry point) and registered in estimators. The steps know nothing of the dynamics
or observables; the loop wires them in."""
