"""Dynamics: the models' descriptors (registry: what each model is and supports, the parameters a filter may
estimate), the CRTBP and the dated DE421 + SRP model with their STMs (and C_R's column), integrators, clocks, time scales
(pyerfa) and the Earth's orientation (IERS data), ground stations and frames. Numerics only; the reads are
of packaged data files (DE421, the IERS tables)."""
