"""Observables: a registry of descriptors (registry), one module per kind with its compiled value and
partials (range, range-rate, LOS, pseudorange, dual one-way, TDoA / FDoA), and visibility."""

from liaison_cli.compiled_cache import install as _install_compiled_cache

_install_compiled_cache()  # before the first @njit(cache=True) of the package: numba picks a locator there
