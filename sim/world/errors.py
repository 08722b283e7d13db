"""What an error means to the command line, declared by the error's class.

The commands' modules are imported only when a command uses them (``shipradar run`` without
``--asterix`` never loads the ASTERIX adapter), so :func:`shipradar.sim.cli.main` cannot list
their error classes; it asks instead whether an error is marked with one of these. Each
marker is a plain class mixed into an exception class beside its builtin base
(``class EndpointError(ValueError, BadInputError)``), so the builtin base still decides what
``except ValueError`` and friends catch.
"""

from __future__ import annotations

__all__ = ["BadInputError", "PeerError"]


class BadInputError:
    """The input (a scenario field, an option, a file) is outside what is accepted, and the
    error's message says which, with the value and the allowed range: the command line prints
    the message and exits 2."""


class PeerError:
    """A subscriber or a publisher let the command down (it never came, or it stopped
    reading): the command line prints the message and exits 1."""
