"""Reference orbits: the catalog, periodic-orbit families (correction, continuation, cache), departures and
Lambert arcs, the lunar orbiter from Keplerian elements (keplerian), and the correction of CRTBP orbits into the dated model with its disk cache (corrected_store);
numerics apart from the two caches' files (npz_cache: their folder, atomic .npz writes, damaged files)."""
