"""Analysis of a run or a geometry: accuracy and consistency metrics (metrics), consistency by direction and the
one verdict every report uses (consistency), errors and sigmas in each spacecraft's RIC frame (ric),
observability of a scenario's links (observability) and dilution of precision of TDoA pairs (dop)."""
