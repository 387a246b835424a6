"""Dynamics: the models' descriptors (registry: what each model is and supports, the parameters a filter may
estimate), their right-hand sides and STMs (crtbp; crtbp_field composes the CRTBP's field with the terms beyond its
point masses: the Moon's GRGM1200A harmonics, read by lunar_gravity and evaluated by spherical_harmonics, or its
J2 alone in closed form (zonal_j2); the dated
DE421 + SRP field in ephemeris_dynamics, with C_R's column and the Moon's harmonics turned by lunar_orientation), the interface estimators call (model, ephemeris_model), the integrators (integrators: fixed-step RK4 and
RK8, adaptive DOP853 compiled for the CRTBP and scipy's for the dated truth; step_choice: the filter's substeps from a Richardson estimate of their error), the truth's random unmodelled forces (random_forcing: Gauss-Markov paths), clocks,
time scales (pyerfa) and the Earth's orientation (IERS data), ground stations and frames. Numerics only; the reads
are of packaged data files (DE421, the IERS tables, GRGM1200A)."""

from liaison_cli.compiled_cache import install as _install_compiled_cache

_install_compiled_cache()  # before the first @njit(cache=True) of the package: numba picks a locator there
