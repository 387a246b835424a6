"""Observables: a registry of descriptors (registry), one module per kind with its compiled value and
partials (range, range-rate, LOS, pseudorange, dual one-way, TDoA / FDoA), and visibility."""
