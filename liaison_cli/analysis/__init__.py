"""Analysis of a run or a geometry: accuracy and consistency metrics (metrics), consistency by direction and the
one verdict every report uses (consistency), errors and sigmas in each spacecraft's RIC frame (ric), a run's per-epoch state table (epoch_states),
observability of a scenario's links (observability) and dilution of precision of TDoA pairs (dop)."""

from liaison_cli.compiled_cache import install as _install_compiled_cache

_install_compiled_cache()  # before the first @njit(cache=True) of the package: numba picks a locator there
