"""Off-line level of the radar model (seed 2.1): table builders, file format, cache, lookup."""
