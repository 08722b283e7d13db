"""The stream (layer 4): message protocol, bus and publisher, recordings, CurveZMQ."""
