"""Studies over runs (layer 4): fidelity trade, Monte Carlo, scene report and figures."""
