"""Pure-numeric dynamics (CRTBP). No I/O; floats and arrays in fixed nondimensional units."""
