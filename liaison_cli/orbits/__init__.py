"""Reference orbits: the catalog, periodic-orbit families (correction, continuation, the shipped catalogue of
their tables in data/family_catalogue.npz, a cache for other member counts), departures and Lambert arcs, the
lunar orbiter from Keplerian elements (keplerian), elliptical frozen lunar orbits (frozen), and the correction of CRTBP orbits into the dated model with
its disk cache (corrected_store); numerics apart from those files (npz_cache: the caches' folder, atomic .npz
writes, damaged files; family_catalogue: the shipped .npz)."""
