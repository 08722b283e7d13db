"""One way to register a ``shipradar`` sub-command (issue 31, item 5): an entry of
``shipradar.sim.cli.SUBCOMMANDS``, which both the parser and ``main``'s dispatch read."""

from __future__ import annotations

import argparse

import pytest

from shipradar.sim import cli


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def test_the_parser_holds_the_registered_commands_in_order_each_calling_its_run():
    top = _subparsers(cli.build_parser())
    firsts = list(dict.fromkeys(cmd.path[0] for cmd in cli.SUBCOMMANDS))
    assert list(top) == firsts
    for cmd in cli.SUBCOMMANDS:
        parser = top[cmd.path[0]]
        if len(cmd.path) == 2:
            assert cmd.path[0] in cli.GROUPS
            parser = _subparsers(parser)[cmd.path[1]]
        assert parser.get_default("func") is cmd.run, cmd.path
        assert (parser.add_help is False) == cmd.own_parser


def test_every_command_in_the_module_is_registered_once():
    runs = [cmd.run for cmd in cli.SUBCOMMANDS]
    assert len(set(runs)) == len(runs)
    assert len({cmd.path for cmd in cli.SUBCOMMANDS}) == len(runs)
    defined = {getattr(cli, name) for name in dir(cli) if name.startswith("cmd_")}
    assert defined == set(runs)


@pytest.mark.parametrize("argv", [["montecarlo", "--runs", "3", "x.yaml"],
                                  ["fidelity", "-h"], ["report", "x.yaml", "--out", "d"]])
def test_a_command_with_its_own_parser_gets_the_words_after_its_name(argv):
    args = cli._parse(argv)
    cmd = next(c for c in cli.SUBCOMMANDS if c.path == (argv[0],))
    assert cmd.own_parser and args.func is cmd.run and args.rest == argv[1:]


def test_the_other_commands_are_parsed_by_argparse():
    args = cli._parse(["recording", "compare", "a.rec", "b.rec", "--rtol", "1e-3"])
    assert args.func is cli.cmd_recording_compare
    assert (args.expected, args.actual, args.rtol) == ("a.rec", "b.rec", 1e-3)
    assert cli._parse(["evaluate", "--rescore", "d"]).func is cli.cmd_evaluate
