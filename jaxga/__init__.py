"""jaxga: genetic-algorithm path planning for mobile robots on grid maps, in JAX."""

from jaxga import interrupts

interrupts.install_in_console_script()  # first: a Ctrl-C during the imports exits cleanly

from jaxga import jax_environment  # noqa: F401  (JAX first: a refused JAX_* variable is named)
from jaxga._runtime.compilation_cache import configure, use_compilation_cache
from jaxga.api import GA, Result, run, sweep
from jaxga.api.doctor import doctor
from jaxga.api.planner import Planner
from jaxga.api.problem import Problem, problem
from jaxga.api.rerun import rerun
from jaxga.compare import Comparison, compare
from jaxga.core.errors import EndpointError, JaxgaError, MapFormatError, NoPathError, ParameterError
from jaxga.core.grid import CORNER_RULES, Grid
from jaxga.core.version import VERSION as __version__  # noqa: F401  (the package's version)
from jaxga.operators.registry import Operator, register_operator
from jaxga.replan import replan

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
    "Problem",
    "Result",
    "compare",
    "configure",
    "doctor",
    "problem",
    "register_operator",
    "replan",
    "rerun",
    "run",
    "sweep",
    "use_compilation_cache",
]
