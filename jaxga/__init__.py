"""jaxga: genetic-algorithm path planning for mobile robots on grid maps, in JAX."""

import contextlib

from jaxga import interrupts

interrupts.install_in_console_script()  # first: a Ctrl-C during the imports exits cleanly

from jaxga.api import GA, Result, lowering, run, sweep
from jaxga.api.compilation_cache import use_compilation_cache
from jaxga.api.doctor import doctor
from jaxga.api.planner import Planner
from jaxga.compare import Comparison, compare
from jaxga.config.registry import Operator, register_operator
from jaxga.core.errors import EndpointError, JaxgaError, MapFormatError, NoPathError, ParameterError
from jaxga.core.grid import CORNER_RULES, Grid
from jaxga.replan import replan

# Threefry lowered without a loop on the CPU: the same random bits, faster compiles
# (jaxga/api/lowering.py; JAXGA_THREEFRY=rolled keeps JAX's own lowering). Nothing is
# lowered at import, so this holds for every program jaxga compiles. A bad value is
# refused by run, sweep, doe and the command line (lowering.check_environment), before
# they compile anything: raised here, the command line could only show a traceback.
with contextlib.suppress(ParameterError):
    lowering.configure_from_environment()

__all__ = [
    "CORNER_RULES",
    "Comparison",
    "EndpointError",
    "GA",
    "Grid",
    "JaxgaError",
    "MapFormatError",
    "NoPathError",
    "Operator",
    "ParameterError",
    "Planner",
    "Result",
    "compare",
    "doctor",
    "register_operator",
    "replan",
    "run",
    "sweep",
    "use_compilation_cache",
]
__version__ = "0.1.0"
