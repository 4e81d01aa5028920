"""Every option a command's --help mentions (usage, descriptions, epilog) exists: on that command,
or on another one it refers to (``devices`` says "use an index with --device")."""
import argparse
import re

import pytest

from oclshade.cli import build_parser


def _subparsers() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


@pytest.mark.parametrize("command", sorted(_subparsers()))
def test_help_mentions_only_real_options(command):
    subs = _subparsers()
    known = {flag for sub in subs.values() for action in sub._actions for flag in action.option_strings}
    sub = subs[command]
    mentioned = set(re.findall(r"(?<![\w-])(--[a-z][a-z0-9-]*)", sub.format_help()))
    assert mentioned - known == set(), f"{command} --help mentions options it does not have"


def test_render_help_has_no_colour_option():
    assert "--colour" not in _subparsers()["render"].format_help()
