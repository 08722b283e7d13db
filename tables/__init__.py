"""Off-line level of the radar model (seed chapter 2.1): table builders, file format, cache, lookup."""
