"""Scenario schema, kinematics, SimPy engine, message bus and command line."""

__version__ = "0.1.0"
