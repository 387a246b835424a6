"""Estimators. The EKF steps know nothing of the dynamics; the loop wires dynamics and measurements in."""
