"""The command line's parser: one subcommand per module of :mod:`jaxga.cli`."""

from __future__ import annotations

import argparse
import re
import sys

from jaxga.cli import compare, doctor, doe, listings, optimum, replan, run, warmup
from jaxga.cli.options import EXIT_BAD_INPUT
from jaxga.core.numerals import ASCII_DECIMAL, ASCII_INTEGER

COMMANDS = (optimum, run, replan, doe, compare, listings, warmup, doctor)
"""The modules that add the subcommands, in the order ``jaxga --help`` lists them."""


LONGEST_WORD = 240
"""The most characters of one word (a run without spaces) that a one-line message shows
whole (a deep file path fits): a value of thousands of characters given on the command
line is shortened in the line that refuses it (:func:`shortened`)."""

_LONG_WORD = re.compile(rf"\S{{{LONGEST_WORD + 1},}}")

LONGEST_LINE = 1000
"""The most characters of a one-line message once its long words are cut: a value with
spaces (``--set "key=[1, 1, 1, ...]"``) is many short words."""


def shortened(message: str) -> str:
    """``message`` with every word longer than :data:`LONGEST_WORD` characters cut to its
    first 150 and last 60, the number left out named between them, and then the whole
    line cut to its first 600 and last 300 characters where it is still longer than
    :data:`LONGEST_LINE`: a refusal echoes what it refuses, and a hostile value
    (``--set key=<10,000 digits>``) would otherwise make that one line as long as the
    value."""

    def cut(m: re.Match) -> str:
        word = m.group(0)
        return f"{word[:150]}...[{len(word) - 210:,} characters]...{word[-60:]}"

    message = _LONG_WORD.sub(cut, message)
    if len(message) > LONGEST_LINE:  # the line itself: its start and its end kept
        message = f"{message[:600]}...[{len(message) - 900:,} characters]...{message[-300:]}"
    return message


class Parser(argparse.ArgumentParser):
    """argparse, reporting a bad command line in the one-line form of every other jaxga
    error (``jaxga: error: ...``, exit 2) instead of a usage block.

    Options are never abbreviated: argparse would read ``--seed 42`` as ``--seeds 42``
    (42 runs of seeds 0-41, not one run of seed 42) without a word; here it is refused,
    naming the options it could stand for."""

    def __init__(self, *args, **kwargs) -> None:
        kwargs.setdefault("allow_abbrev", False)  # the subcommands' parsers too
        super().__init__(*args, **kwargs)
        self._words: list[str] = []

    def parse_known_args(self, args=None, namespace=None):  # type: ignore[override]
        self._words = [str(a) for a in (sys.argv[1:] if args is None else args)]
        out = super().parse_known_args(args, namespace)
        self._refuse_repeats()
        return out

    def _refuse_repeats(self) -> None:
        """An option that takes one value, given twice (``--generations 5 --generations
        6``): argparse keeps the last without a word; refused, as ``--generations 5 --set
        generations=6`` is. Options that collect (``--set``, ``--factor``) may repeat."""
        once = {o: a for a in self._actions if isinstance(a, argparse._StoreAction)
                for o in a.option_strings}
        given: dict[str, list[str]] = {}
        for word in self._words:
            if word == "--":
                break
            name = word.split("=", 1)[0]
            if name in once:
                given.setdefault(once[name].dest, []).append(name)
        for names in given.values():
            if len(names) > 1:
                self.error(f"{names[0]} is given {len(names)} times: which one? Give it once")

    def _get_value(self, action: argparse.Action, arg_string: str):  # type: ignore[override]
        """argparse's conversion, with ``int`` and ``float`` values read as written in
        ASCII: Python's own take ``2_0`` (20) and other scripts' digits, which no one
        types as a number of seeds by intent."""
        pattern = {int: ASCII_INTEGER, float: ASCII_DECIMAL}.get(action.type)
        if pattern is not None and not pattern.fullmatch(arg_string):
            raise argparse.ArgumentError(
                action, f"invalid {action.type.__name__} value: {arg_string!r}")
        return super()._get_value(action, arg_string)

    def error(self, message: str):  # type: ignore[override]
        self.exit(EXIT_BAD_INPUT, f"jaxga: error: {shortened(message)}{self._hint(message)} "
                                  f"(see: {self.prog} --help)\n")

    def _hint(self, message: str) -> str:
        """``; did you mean --seeds?`` for an unknown option that begins a known one."""
        if not message.startswith("unrecognized arguments:"):
            return ""
        commands = {name: sp for a in self._actions
                    if isinstance(a, argparse._SubParsersAction)
                    for name, sp in a.choices.items()}  # argparse reports them here
        named = [commands[w] for w in self._words if w in commands][:1]
        parsers = [self, *(named or commands.values())]  # the command's own options
        known = {o for p in parsers for a in p._actions for o in a.option_strings
                 if o.startswith("--")}
        words = [w for w in message.split(":", 1)[1].split() if w.startswith("--")]
        meant = sorted({o for w in words for o in known if o.startswith(w.split("=")[0])})
        return f"; did you mean {' or '.join(meant)}?" if meant else ""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``jaxga`` command: each command module adds its own."""
    parser = Parser(
        prog="jaxga", description="Genetic-algorithm path planning on grid maps, in JAX."
    )
    commands = parser.add_subparsers(dest="command", metavar="COMMAND")
    commands.required = True
    for module in COMMANDS:
        module.add_parser(commands)
    return parser
