"""Mistyped options named as such, before argparse judges any positional argument.

argparse sets an unknown option aside and goes on: the option's value is then taken as the
next positional argument, and the error blames that (``calibrate --rgi sim`` answers
"argument PROCEDURE: invalid choice: 'sim'"). :func:`check_options` walks the command line
the way argparse will, down the subcommands, and stops at the first option the command it
belongs to does not have, naming it with the closest of that command's options. Python
3.12's ``suggest_on_error`` suggests choices, not options, and this package supports 3.11.

Examples
--------
>>> parser = argparse.ArgumentParser(prog="demo")
>>> _ = parser.add_argument("--rig")
>>> _ = parser.add_argument("mode", choices=["fast", "full"])
>>> unknown_option(parser, ["--rgi", "sim", "fast"])[1:]
('--rgi', '--rig')
>>> unknown_option(parser, ["--rig", "sim", "fast"]) is None
True
"""

from __future__ import annotations

import argparse
import difflib
import re
from collections.abc import Sequence

__all__ = ["check_options", "unknown_option"]

#: What argparse takes for a negative number rather than an option.
_NEGATIVE_NUMBER = re.compile(r"^-\d+$|^-\d*\.\d+$")


def _option_like(token: str) -> bool:
    return token.startswith("-") and len(token) > 1 and not _NEGATIVE_NUMBER.match(token)


def _subcommands(parser: argparse.ArgumentParser) -> argparse._SubParsersAction | None:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action
    return None


def _options(parser: argparse.ArgumentParser) -> list[str]:
    return [o for o in parser._option_string_actions if o.startswith("--")]


def _match(parser: argparse.ArgumentParser, name: str) -> argparse.Action | str | None:
    """The action ``name`` means in ``parser``; ``"ambiguous"`` for a prefix of several
    (argparse says so itself); None when it names none."""
    if name in parser._option_string_actions:
        return parser._option_string_actions[name]
    if parser.allow_abbrev and name.startswith("--"):
        found = {parser._option_string_actions[o] for o in _options(parser) if o.startswith(name)}
        if len(found) == 1:
            return found.pop()
        if found:
            return "ambiguous"
    return None


def _values_taken(action: argparse.Action, rest: Sequence[str]) -> int:
    """How many of the following tokens ``action`` takes as its values."""
    nargs = action.nargs
    if nargs is None:
        return min(1, len(rest))
    if isinstance(nargs, int):
        return min(nargs, len(rest))
    if nargs == argparse.OPTIONAL:
        return 1 if rest and not _option_like(rest[0]) else 0
    if nargs in (argparse.ZERO_OR_MORE, argparse.ONE_OR_MORE):
        count = 0
        while count < len(rest) and not _option_like(rest[count]):
            count += 1
        return count
    return len(rest)  # REMAINDER and the like: the rest is theirs


def unknown_option(
    parser: argparse.ArgumentParser, argv: Sequence[str]
) -> tuple[argparse.ArgumentParser, str, str | None] | None:
    """The first option of ``argv`` that the (sub)command it follows does not have.

    Parameters
    ----------
    parser
        The top-level parser.
    argv
        The command line, without the program.

    Returns
    -------
    tuple or None
        The (sub)command's parser, the option as given, and the closest option that
        command has (None: none is close); None when every option is known.
    """
    current, k = parser, 0
    tokens = list(argv)
    while k < len(tokens):
        token = tokens[k]
        k += 1
        if token == "--":
            return None  # the rest are positional arguments
        if _option_like(token):
            name, _, attached = token.partition("=")
            action = _match(current, name)
            if action is None:
                close = difflib.get_close_matches(name, _options(current), n=1, cutoff=0.6)
                return current, name, close[0] if close else None
            if action == "ambiguous" or attached or not name.startswith("--"):
                continue  # argparse's own message; a value given with '=' or after -x
            k += _values_taken(action, tokens[k:])
            continue
        sub = _subcommands(current)
        if sub is not None and token in sub.choices:
            current = sub.choices[token]
    return None


def check_options(parser: argparse.ArgumentParser, argv: Sequence[str]) -> None:
    """Exit with argparse's usage error (status 2) at the first unknown option of ``argv``,
    naming it and the closest option of its command; do nothing when all are known.

    Examples
    --------
    >>> parser = argparse.ArgumentParser(prog="demo")
    >>> _ = parser.add_argument("--session")
    >>> check_options(parser, ["--session", "s1"])
    """
    found = unknown_option(parser, argv)
    if found is None:
        return
    command, option, close = found
    hint = f"; did you mean {close}?" if close else ""
    known = ", ".join(sorted(_options(command)))
    command.error(f"unrecognized option {option}{hint} ({command.prog} takes {known})")
