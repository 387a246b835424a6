"""Estimators: the EKF (its steps in ekf, the compiled loop in filter_loop), batch least squares, LinCov, the
RTS smoother, process noise and the state blocks. The steps know nothing of the dynamics or observables;
the loop wires them in."""
