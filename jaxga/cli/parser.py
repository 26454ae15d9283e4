"""The command line's parser: one subcommand per module of :mod:`jaxga.cli`."""

from __future__ import annotations

import argparse

from jaxga.cli import compare, doctor, doe, listings, optimum, replan, run, warmup
from jaxga.cli.options import EXIT_BAD_INPUT

COMMANDS = (optimum, run, replan, doe, compare, listings, warmup, doctor)
"""The modules that add the subcommands, in the order ``jaxga --help`` lists them."""


class Parser(argparse.ArgumentParser):
    """argparse, reporting a bad command line in the one-line form of every other jaxga
    error (``jaxga: error: ...``, exit 2) instead of a usage block."""

    def error(self, message: str):  # type: ignore[override]
        self.exit(EXIT_BAD_INPUT, f"jaxga: error: {message} (see: {self.prog} --help)\n")


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
