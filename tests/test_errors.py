"""The command line's exit code for an error comes from the error's class (its marker in
shipradar.sim.world.errors), not from a list of the commands' modules, which are imported
only when used."""

from __future__ import annotations

import argparse

import pytest

from shipradar.sim import cli
from shipradar.sim.adapters.asterix.encode import AsterixError
from shipradar.sim.stream.bus import EndpointError, PublisherStalledError, SubscriberTimeoutError
from shipradar.sim.stream.recording import RecordingError, RecordingExistsError
from shipradar.sim.stream.security import CurveKeyError
from shipradar.sim.world.errors import BadInputError, PeerError
from shipradar.tables.budget import BuildTimeError, MemoryBudgetError

BAD_INPUT = [(cli.BadInput, Exception), (EndpointError, ValueError),
             (RecordingError, ValueError), (RecordingExistsError, FileExistsError),
             (AsterixError, ValueError), (CurveKeyError, ValueError),
             (MemoryBudgetError, ValueError), (BuildTimeError, ValueError)]
PEER = [(SubscriberTimeoutError, TimeoutError), (PublisherStalledError, TimeoutError)]


@pytest.mark.parametrize(("cls", "base", "code", "marker"),
                         [(c, b, cli.EXIT_BAD_INPUT, BadInputError) for c, b in BAD_INPUT]
                         + [(c, b, cli.EXIT_FAILURE, PeerError) for c, b in PEER])
def test_each_error_exits_with_its_code_and_keeps_its_builtin_base(cls, base, code, marker,
                                                                   monkeypatch, capsys):
    assert issubclass(cls, marker) and issubclass(cls, base)

    def fails(args):
        raise cls("the message names the field, the value and the range")

    monkeypatch.setattr(cli.argparse.ArgumentParser, "parse_args",
                        lambda self, argv=None: argparse.Namespace(func=fails))
    assert cli.main(["validate", "x.yaml"]) == code
    assert "the message names the field" in capsys.readouterr().err


def test_an_unmarked_error_is_not_swallowed(monkeypatch):
    def fails(args):
        raise ValueError("a bug, not bad input")

    monkeypatch.setattr(cli.argparse.ArgumentParser, "parse_args",
                        lambda self, argv=None: argparse.Namespace(func=fails))
    with pytest.raises(ValueError, match="a bug"):
        cli.main(["validate", "x.yaml"])
