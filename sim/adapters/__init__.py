"""Adapters to other tools (layer 4): ASTERIX, DIS, the browser viewer, the Stone Soup reader,
and the export of a recording (ASTERIX, pcap, CSV, Parquet).

An adapter imports the stream (:mod:`shipradar.sim.stream`), never the reverse.
"""
