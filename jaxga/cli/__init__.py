"""The ``jaxga`` command line.

``jaxga optimum`` prints the exact 8-connected and any-angle optima of a map
(decisions 015 and 031); ``jaxga run`` runs a preset for many seeds; ``jaxga doe``
runs a designed experiment (:mod:`jaxga.doe`); ``jaxga compare`` compares presets with
statistical tests (:mod:`jaxga.compare`); ``jaxga replan`` re-plans around new obstacles
(:mod:`jaxga.replan`); ``jaxga presets`` and ``jaxga maps`` list the presets and the
built-in maps. Bad input (a missing or malformed file, a start or goal off the map or
blocked, an unreachable goal, an unknown corner rule) ends with a one-line message on
stderr and a non-zero exit status, never a Python traceback.

One module per command (:mod:`jaxga.cli.run`, :mod:`~jaxga.cli.optimum`,
:mod:`~jaxga.cli.doe`, :mod:`~jaxga.cli.compare`, :mod:`~jaxga.cli.replan`,
:mod:`~jaxga.cli.warmup`, :mod:`~jaxga.cli.listings`), the options they share
(:mod:`~jaxga.cli.options`), the parser (:mod:`~jaxga.cli.parser`), the output checks
(:mod:`~jaxga.cli.outputs`) and the entry point (:mod:`~jaxga.cli.entry`).
"""

from jaxga.cli.entry import console, main
from jaxga.cli.options import EXIT_BAD_INPUT, EXIT_NO_PATH
from jaxga.cli.outputs import check_outputs
from jaxga.cli.parser import build_parser

__all__ = ["EXIT_BAD_INPUT", "EXIT_NO_PATH", "build_parser", "check_outputs", "console", "main"]
