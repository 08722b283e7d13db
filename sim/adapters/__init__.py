"""Adapters to other tools (layer 4): ASTERIX, the browser viewer, the Stone Soup reader."""
