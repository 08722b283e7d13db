"""On-line radar model: pure, vectorized physics functions, one module per phenomenon."""
