"""Analysis of a run or a geometry: accuracy and consistency metrics (metrics), observability of a
scenario's links (observability) and dilution of precision of TDoA pairs (dop)."""
