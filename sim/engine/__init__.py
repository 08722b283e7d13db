"""The SimPy engine (layer 4): the antenna clock, dwell events, blocks of revolutions, parallel
radars."""
