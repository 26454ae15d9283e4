"""Exceptions raised for bad input.

Every error a user can cause (a malformed map file, a start or goal that is blocked or off
the map, an unreachable goal, an invalid parameter) is a subclass of :class:`JaxgaError`,
so callers - and the command line, which turns them into a one-line message and a
non-zero exit - can tell them from bugs.
"""

from __future__ import annotations


class JaxgaError(ValueError):
    """Base class of every error caused by bad input to jaxga."""


class MapFormatError(JaxgaError):
    """A map or scenario file is missing, unreadable or malformed."""


class EndpointError(JaxgaError):
    """A start or goal cell is off the map or blocked."""


class NoPathError(JaxgaError):
    """The goal cannot be reached from the start under the grid's corner rule."""


class ParameterError(JaxgaError):
    """A parameter is unknown, of the wrong type or out of range."""


class DeviceMemoryError(JaxgaError):
    """The device ran out of memory while the runs computed (XLA's ``RESOURCE_EXHAUSTED``,
    most likely on a GPU with less memory than jaxga's estimate allowed for): the message
    names the device and what to make smaller."""


class InitialisationWarning(UserWarning):
    """The initialiser filled only part of a population within its budget of attempts.

    :func:`jaxga.operators.init.initialise_population` then fills the empty slots with copies of the
    individuals it made, so the run still works, on fewer distinct individuals than asked for.
    """


class DeviceWarning(RuntimeWarning):
    """A device count asked for cannot take effect (JAX already runs with another):
    the results are the same, only the speed differs (:mod:`jaxga._runtime.parallel`)."""


class CacheWarning(RuntimeWarning):
    """The compilation cache (``$JAXGA_CACHE_DIR``) cannot be used or read: programs are
    compiled without it, so only the speed differs (:mod:`jaxga._runtime.compilation_cache`)."""


class EnvironmentWarning(RuntimeWarning):
    """A saved result is run again (:func:`jaxga.rerun`) by other versions of jaxga, JAX,
    jaxlib, NumPy or Python, or on another device, than its JSON records: the runs may
    differ from the saved ones (docs/python.md)."""


class PlatformWarning(RuntimeWarning):
    """The runs compute on a platform other than the CPU, where jaxga's results are not
    reproducible bit for bit: on a GPU a seed's result may differ from the CPU's and with
    the number of runs that share its call (decisions 037 and 048, docs/devices.md)."""
