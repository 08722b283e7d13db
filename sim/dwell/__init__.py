"""The on-line composition (layer 3): one radar's model per beam crossing, from physics and
tables."""
