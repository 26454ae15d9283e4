"""Every core of a machine, and several processes or hosts, for one experiment.

Runs (seeds x sweep points) are one leading axis (``jaxga.api.sweep``). This module
decides how that axis is split (docs/devices.md):

* **Devices of one process.** On a CPU, XLA gives a process one device by default and
  leaves the other cores mostly idle (two host devices run faster than one:
  decision 017). :func:`set_local_devices` / :func:`use_all_cores` ask JAX for one CPU
  device per core through its ``jax_num_cpu_devices`` option, which must be set before
  JAX's backend starts (the first array or ``jax.devices()`` call). Decision: the JAX
  option rather than editing ``XLA_FLAGS``: it is JAX's documented way, it is checked
  (JAX refuses it once the backend runs, which we turn into a warning), it also works
  after ``import jax`` and it does not leak into child processes. A user's own
  ``--xla_force_host_platform_device_count`` in ``XLA_FLAGS`` or ``JAX_NUM_CPU_DEVICES``
  is respected unless a device count is asked for explicitly (``--devices N``). On a GPU
  the runs go over the process's GPUs (choose them with ``CUDA_VISIBLE_DEVICES``); the
  CPU device count does not matter there.

* **Several processes.** :func:`initialize` calls ``jax.distributed.initialize``. Each
  process then computes a contiguous share of the runs on its own devices (the sharded
  ``jit`` of ``api.py`` with a mesh of its *local* devices) and the shares are gathered
  through the key-value store of JAX's distributed runtime (the coordination service that
  ``jax.distributed`` runs in process 0): every process publishes its share as NumPy bytes
  and reads the others' (:func:`allgather_runs`), so every process returns the same
  ``Result`` and ``jaxga run`` writes its JSON and plots on process 0 only.
  Decision, instead of one global array over all processes' devices and
  ``multihost_utils.process_allgather``: the runs are independent, so no collective is
  needed during the computation, and a collective over gloo cannot be interrupted when
  a peer dies (it blocks until gloo's own timeout or XLA aborts the process), whereas a
  key-value read has a timeout after which we can look at the peer's liveness and raise
  a clear error. The split is the same as the device split: the runs are padded (with
  copies of the last run, dropped afterwards) to a multiple of processes x local devices
  and every process computes the same number of runs, so every process compiles the same
  program. A run's result depends only on its seed and point, so the gathered result is
  identical to a single-process run (``tests/api/test_distributed.py`` checks it).

* **Failures.** Within ``timeout`` seconds (``--process-timeout``, default 60):
  if a process never joins, the others print one line and exit with status 4 (JAX alone
  would abort them with a C++ stack trace after its initialisation timeout); if a process
  other than 0 dies or its host becomes unreachable, a monitor thread in every other
  process notices that its heartbeat counter (written into the key-value store every
  second) has stopped, prints one line naming it ("process 1 of 2 was lost") and ends the
  process with status 4. JAX's own heartbeat check (which aborts every process with a
  stack trace) is set to ``2 * timeout + 10`` seconds so that ours comes first. A process
  that ends normally (even after an error of its own) writes ``exit`` instead of a
  counter; a peer that exited without sending its share raises
  :class:`ProcessLostError`. If process 0 (the coordinator, which hosts the service) dies,
  JAX's runtime ends the other processes at once (non-zero status, its own message "the
  JAX distributed service detected fatal errors"); no Python code runs in them after
  that. (``jax_enable_recoverability`` would keep the survivors alive without the monitor,
  but then JAX's shutdown does not wait for the other processes and a process that ends
  after process 0 is aborted: worse.)

* **GPU.** The runs always go over :func:`run_devices`, the local devices of JAX's
  default backend: with a CUDA build of JAX (``pip install ".[cuda]"``, i.e.
  ``jax[cuda12]``) that is every visible GPU (``CUDA_VISIBLE_DEVICES``), one program per
  GPU as on CPU devices. The one-device-per-core setting is CPU-only by construction: it
  is JAX's ``jax_num_cpu_devices``, which sizes the CPU backend alone; on a GPU machine
  that backend computes none of the runs (``benchmarks/device_check.py`` uses it for its
  CPU reference). Only the CPU path runs in the test suite (no GPU on CI);
  ``benchmarks/device_check.py`` is the check to run on a GPU.
"""

from __future__ import annotations

import argparse
import atexit
import io
import itertools
import json
import math
import os
import re
import socket
import sys
import threading
import time
import warnings
from collections.abc import Sequence
from typing import Any

import jax
import numpy as np
from jax.errors import JaxRuntimeError

from jaxga.core.errors import DeviceWarning, JaxgaError
from jaxga.core.fields import shown_value
from jaxga.core.grid import as_integer
from jaxga.core.numerals import ascii_float, ascii_int

ENV_DEVICES = "JAXGA_DEVICES"
ENV_COORDINATOR = "JAXGA_COORDINATOR"
ENV_NUM_PROCESSES = "JAXGA_NUM_PROCESSES"
ENV_PROCESS_ID = "JAXGA_PROCESS_ID"
ENV_PROCESS_TIMEOUT = "JAXGA_PROCESS_TIMEOUT"
DEFAULT_PROCESS_TIMEOUT = 60.0
MAX_PROCESS_TIMEOUT = 1_000_000
"""Longest ``--process-timeout`` in seconds (about 11.6 days): JAX's coordination
service takes its timeouts as 32-bit integers (twice this plus slack still fits)."""
EXIT_PROCESS_LOST = 4  # exit status of the CLI when a process is lost or never joins

_CHUNK_BYTES = 2 << 20  # key-value values above ~100 MB stall the runtime's heartbeats
_POLL_MS = 1000
_ALIVE = "jaxga/alive"
_HEARTBEAT_S = 1.0
_FORCE_FLAG = "--xla_force_host_platform_device_count"


class ProcessLostError(JaxgaError):
    """A process of a multi-process experiment died, was killed or never joined."""

    def __init__(self, message: str, process: int | None = None) -> None:
        super().__init__(message)
        self.process = process


def cores() -> int:
    """The number of CPU cores this process may run on (its affinity mask)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - macOS, Windows
        return os.cpu_count() or 1


def user_device_setting() -> str | None:
    """The user's own CPU device count setting, if any (``XLA_FLAGS`` or
    ``JAX_NUM_CPU_DEVICES``), as text for messages; None if there is none."""
    # the one JAX uses: JAX_NUM_CPU_DEVICES over XLA_FLAGS, and of a flag given twice
    # the last, as XLA reads it
    if os.environ.get("JAX_NUM_CPU_DEVICES", "-1").strip() != "-1":  # -1: JAX's unset
        return f"JAX_NUM_CPU_DEVICES={os.environ['JAX_NUM_CPU_DEVICES']}"
    flags = os.environ.get("XLA_FLAGS", "")
    found = re.findall(re.escape(_FORCE_FLAG) + r"=(\S*)", flags)
    if found:
        return f"XLA_FLAGS {_FORCE_FLAG}={found[-1]}"
    return None


def max_cpu_devices() -> int:
    """The most XLA CPU devices a process may ask for: four per core, at least 8.

    Runs do not depend on the device count, only their speed does, and past one device
    per core a CPU only spends more time: 64 devices on 2 cores compiled and ran for two
    minutes where one device took four seconds, and a thousand did not finish."""
    return max(8, 4 * cores())


def set_local_devices(n: int | None = None, *, warn: bool = True) -> int | None:
    """Give this process ``n`` XLA CPU devices (default: one per core) for the runs.

    Must run before JAX's backend starts (before the first JAX array or ``jax.devices()``;
    importing JAX is fine). ``n=None`` keeps a user's explicit ``XLA_FLAGS``
    ``--xla_force_host_platform_device_count`` or ``JAX_NUM_CPU_DEVICES`` and otherwise
    uses :func:`cores`; an explicit ``n`` overrides them. If the backend has already
    started with another device count, warns (unless ``warn`` is False; results do not
    depend on the device count, only the speed does) and leaves it. Returns the device
    count asked for, or None when the user's own setting was kept.

    Only the CPU backend's device count (``jax_num_cpu_devices``): where JAX's default
    backend is a GPU, the runs go over the GPUs (:func:`run_devices`) whatever this sets.
    """
    if n is None:
        setting = user_device_setting()
        if setting is not None:
            value = setting.rsplit("=", 1)[1]
            count = int(value) if value.isascii() and value.isdigit() else 0
            if count > max_cpu_devices() and warn:  # kept (the user's JAX), but said
                warnings.warn(
                    f"{setting} gives JAX {count} CPU devices on {cores()} core(s): "
                    f"jaxga splits its runs over all of them, which is slower, not faster "
                    f"(at most {max_cpu_devices()} pay here; --devices N, $JAXGA_DEVICES)",
                    DeviceWarning, stacklevel=2)
            return None
        n = cores()
    try:
        n = as_integer(n)
    except TypeError:
        raise JaxgaError(f"the device count must be a whole number, got {shown_value(n)}") \
            from None
    if n < 1:
        raise JaxgaError(f"the device count must be >= 1, got {n}")
    if n > max_cpu_devices():
        raise JaxgaError(f"the device count must be at most {max_cpu_devices()} on this "
                         f"machine's {cores()} core(s) (four per core; more devices than "
                         f"cores make runs slower, not faster), got {n}")
    try:
        jax.config.update("jax_num_cpu_devices", n)
    except RuntimeError:
        have = len(jax.local_devices(backend="cpu"))
        if have != n and warn:
            warnings.warn(
                f"jaxga.api.devices: JAX is already running with {have} CPU device(s); "
                f"asking for {n} has no effect. Call jaxga.api.devices.use_all_cores() (or "
                "set_local_devices) right after `import jax`, before any JAX computation. "
                "Results are the same, only slower.", DeviceWarning, stacklevel=2)
    return n


def use_all_cores() -> int | None:
    """One XLA CPU device per core, so that ``jaxga.run``/``sweep`` use every core.

    The documented one-liner for Python users, before any JAX computation::

        import jaxga._runtime.parallel; jaxga._runtime.parallel.use_all_cores()

    Same as :func:`set_local_devices` with no argument.
    """
    return set_local_devices(None)


def run_devices() -> list[Any]:
    """The devices this process splits its runs over: ``jax.local_devices()`` of JAX's
    default backend (its CPU devices, :func:`set_local_devices`; or its GPUs).

    Starts JAX's backends (after it, :func:`set_local_devices` can no longer change the
    count)."""
    return list(jax.local_devices())


class _Session:
    """This process's part of a multi-process experiment: its id, the timeout, the
    counter that names each gather, and the liveness monitor.

    The monitor thread writes this process's heartbeat counter into the key-value store
    every second and reads everyone's (one ``key_value_dir_get``); a peer whose counter
    has not moved for ``timeout`` seconds is lost: the thread prints one line naming it
    and ends this process with status :data:`EXIT_PROCESS_LOST` (JAX's runtime would abort
    it with a stack trace after its own, longer, heartbeat timeout). A process that exits
    normally writes ``exit`` instead of a counter and is not missed.
    """

    def __init__(self, client: Any, process_id: int, num_processes: int,
                 timeout: float) -> None:
        self.client = client
        self.process_id = process_id
        self.num_processes = num_processes
        self.timeout = float(timeout)
        self.gathers = itertools.count()
        self.broadcasts = itertools.count()
        self.device_counts: list[int] | None = None
        self.beats: dict[int, str] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._monitor, name="jaxga-liveness",
                                        daemon=True)
        self._thread.start()
        atexit.register(self.close)

    def _monitor(self) -> None:
        me, start = self.process_id, time.monotonic()
        seen = dict.fromkeys(range(self.num_processes), start)
        for n in itertools.count():
            try:
                self.client.key_value_set(f"{_ALIVE}/{me}", str(n), allow_overwrite=True)
                beats = {int(k.rsplit("/", 1)[1]): v
                         for k, v in self.client.key_value_dir_get(_ALIVE)}
            except Exception:  # the service is gone: JAX's runtime reports that itself
                return
            now = time.monotonic()
            for j in range(self.num_processes):
                if j == me or beats.get(j) == "exit":
                    continue
                if beats.get(j) != self.beats.get(j):
                    seen[j] = now
                elif now - seen[j] > self.timeout:
                    if self._stop.is_set():
                        return
                    _give_up(f"process {j} of {self.num_processes} was lost: no heartbeat "
                             f"for {self.timeout:.0f} s (it died, was killed or its host is "
                             "unreachable)")
            self.beats = beats
            if self._stop.wait(_HEARTBEAT_S):
                return

    def close(self) -> None:
        """Stop the monitor and tell the others that this process ends normally."""
        if self._stop.is_set():
            return
        self._stop.set()
        try:
            self.client.key_value_set(f"{_ALIVE}/{self.process_id}", "exit",
                                      allow_overwrite=True)
        except Exception:
            pass

    def wait_for(self, key: str, process: int, what: str) -> str:
        """The value of ``key``, written by ``process``; raises ProcessLostError if that
        process ends normally without writing it (a lost process ends this one through
        the monitor)."""
        while True:
            try:
                return self.client.blocking_key_value_get(key, _POLL_MS)
            except JaxRuntimeError as e:
                if "DEADLINE_EXCEEDED" not in str(e):
                    raise
            if self.beats.get(process) == "exit":
                try:
                    return self.client.key_value_try_get(key)
                except JaxRuntimeError:
                    raise ProcessLostError(
                        f"process {process} of {self.num_processes} ended without sending "
                        f"{what} (see its own error message)", process=process) from None


_session: _Session | None = None


def initialize(coordinator: str, num_processes: int, process_id: int, *,
               timeout: float = DEFAULT_PROCESS_TIMEOUT) -> None:
    """Join a multi-process experiment (``jax.distributed.initialize``), CPU or GPU.

    Every process calls it with the same ``coordinator`` (``HOST:PORT`` reachable from all
    processes; process 0 listens on that port) and ``num_processes``, and its own
    ``process_id``, before any JAX computation and after :func:`set_local_devices`. CPU
    collectives go through gloo (JAX's ``jax_cpu_collectives_implementation``; jaxga needs
    none during a run, see the module docstring). Then ``jaxga.run``/``sweep`` split the
    runs over the processes and every process returns the whole result.

    If not every process has joined within ``timeout`` seconds (or the backend's device
    exchange between processes did not finish), prints a one-line message and ends this
    process with status :data:`EXIT_PROCESS_LOST` (JAX would abort it with a stack trace
    a little later). ``timeout`` is also the silence after which a process counts as lost
    while its share is awaited.
    """
    global _session
    if num_processes < 1 or not 0 <= process_id < num_processes:
        raise JaxgaError(f"need 0 <= process id < number of processes, got process id "
                         f"{process_id} of {num_processes}")
    port = int(coordinator.rsplit(":", 1)[1]) if re.fullmatch(r".+:\d+", coordinator or "") \
        else 0
    if not 0 < port < 65536:
        raise JaxgaError(f"the coordinator must be HOST:PORT (a port from 1 to 65535), got "
                         f"{coordinator!r}")
    if not 0 < timeout <= MAX_PROCESS_TIMEOUT:  # also refuses nan
        raise JaxgaError(f"the process timeout must be > 0 s and at most "
                         f"{MAX_PROCESS_TIMEOUT:,} s, got {timeout}")
    if _session is not None:
        raise JaxgaError("jaxga._runtime.parallel.initialize was already called in this process")
    if num_processes == 1:
        return
    if jax.distributed.is_initialized():
        raise JaxgaError("jax.distributed is already initialised; call "
                         "jaxga._runtime.parallel.initialize instead of jax.distributed.initialize")
    if process_id == 0:
        _check_port_free(coordinator, port)
    jax.config.update("jax_enable_preemption_service", False)  # unused; slows exit
    jax.config.update("jax_cpu_collectives_implementation", "gloo")
    who = ("not every process joined" if process_id == 0 else
           f"process {process_id} could not join the coordinator (process 0)")
    watchdog = threading.Timer(timeout, _give_up, args=(
        f"{who} at {coordinator} within {timeout:.0f} s ({num_processes} processes "
        "expected; start them all with the same --coordinator and --num-processes)",))
    watchdog.daemon = True
    watchdog.start()
    try:
        jax.distributed.initialize(
            coordinator_address=coordinator, num_processes=num_processes,
            process_id=process_id, initialization_timeout=int(timeout) + 60,
            # JAX's own heartbeat check is the backstop: ours (the monitor) fires first.
            heartbeat_timeout_seconds=2 * int(timeout) + 10)
        jax.devices()  # the backend exchanges device lists with every process here
    except jax.errors.JaxRuntimeError as e:  # e.g. the coordinator's server did not start
        first = (str(e).strip().splitlines() or [type(e).__name__])[0]
        raise JaxgaError(f"process {process_id} could not start jax.distributed at "
                         f"{coordinator}: {first}") from None
    finally:
        watchdog.cancel()
    from jax._src import distributed

    _session = _Session(distributed.global_state.client, process_id, num_processes, timeout)


def _check_port_free(coordinator: str, port: int) -> None:
    """One :class:`JaxgaError` line when process 0 cannot listen on the coordinator's
    ``port`` (another program holds it), before JAX's coordinator service tries and fails
    with a C++ log line and a traceback. The service listens on every address of the
    machine, so the port is tried on every IPv4 address (a port held on any one of them
    is refused)."""
    try:
        with socket.create_server(("", port)):
            pass
    except OSError as e:
        why = os.strerror(e.errno) if e.errno else str(e)
        raise JaxgaError(f"process 0 cannot listen at {coordinator}: port {port} is "
                         f"taken ({why}); choose another --coordinator port") from None


def _give_up(message: str) -> None:
    print(f"jaxga: error: {message}", file=sys.stderr, flush=True)
    sys.stdout.flush()
    os._exit(EXIT_PROCESS_LOST)


def _current_session() -> _Session | None:
    """This process's session; one is made (default timeout) when the user called
    ``jax.distributed.initialize`` directly."""
    global _session
    if _session is None:
        if jax.distributed.is_initialized() and jax.process_count() > 1:
            from jax._src import distributed

            _session = _Session(distributed.global_state.client, jax.process_index(),
                                jax.process_count(), DEFAULT_PROCESS_TIMEOUT)
    return _session


def process_device_counts() -> list[int]:
    """Every process's count of local devices, in process order (``[local count]`` with
    one process). Processes may differ (hosts with other core counts, other
    ``--devices``): each publishes its own once per session and reads the others'."""
    s = _current_session()
    if s is None:
        return [jax.local_device_count()]
    if s.device_counts is None:
        s.client.key_value_set(f"jaxga/devices/{s.process_id}", str(jax.local_device_count()))
        s.device_counts = [
            jax.local_device_count() if j == s.process_id
            else int(s.wait_for(f"jaxga/devices/{j}", j, "its device count"))
            for j in range(s.num_processes)]
    return s.device_counts


def run_share(n_runs: int) -> tuple[int, slice]:
    """``(padded run count, this process's slice)``: every device of every process takes
    ``m = ceil(n_runs / devices)`` runs, so the runs are padded to ``m`` x all the
    processes' devices and each process takes ``m`` x its own device count, contiguous,
    in process order (processes of equal device counts: equal shares). Every process
    computes the same split, whatever its own device count, so each run is computed
    exactly once."""
    s = _current_session()
    me = 0 if s is None else s.process_id
    counts = process_device_counts()
    per_device = math.ceil(n_runs / sum(counts))
    first = per_device * sum(counts[:me])
    return per_device * sum(counts), slice(first, first + per_device * counts[me])


def allgather_runs(tree: Any) -> Any:
    """Every process's share of the runs (a pytree of arrays with the runs first),
    concatenated in process order; the tree itself with one process.

    The shares travel as NumPy ``.npz`` bytes (no pickle) through the distributed
    runtime's key-value store, in chunks of 2 MB. Raises :class:`ProcessLostError` naming a
    process that stops responding before its share arrives.
    """
    s = _current_session()
    leaves, treedef = jax.tree_util.tree_flatten(tree)
    leaves = [np.asarray(x) for x in leaves]
    if s is None:
        return jax.tree_util.tree_unflatten(treedef, leaves)
    k = next(s.gathers)
    prefix = f"jaxga/gather/{k}"
    blob = _pack(leaves)
    pieces = [blob[i:i + _CHUNK_BYTES] for i in range(0, len(blob), _CHUNK_BYTES)] or [b""]
    for i, piece in enumerate(pieces):
        s.client.key_value_set_bytes(f"{prefix}/{s.process_id}/{i}", piece)
    s.client.key_value_set(f"{prefix}/{s.process_id}/n", str(len(pieces)))
    shares = []
    for j in range(s.num_processes):
        if j == s.process_id:
            shares.append(leaves)
            continue
        n = int(s.wait_for(f"{prefix}/{j}/n", j, "its share of the runs"))
        blob_j = b"".join(s.client.blocking_key_value_get_bytes(
            f"{prefix}/{j}/{i}", int(s.timeout * 1000)) for i in range(n))
        shares.append(_unpack(blob_j, len(leaves)))
    # Every process has published share k, so every process has read all of share k-1:
    # this process's previous share can go (the coordinator keeps the store in memory).
    if k > 0:
        s.client.key_value_delete(f"jaxga/gather/{k - 1}/{s.process_id}")
    return jax.tree_util.tree_unflatten(
        treedef, [np.concatenate(parts, axis=0) for parts in zip(*shares)])


def broadcast(value: Any) -> Any:
    """Process 0's ``value`` (anything JSON can write) in every process; ``value`` itself
    with one process. For decisions only process 0 can make, e.g. which design points a
    checkpoint on process 0's disk has already finished."""
    s = _current_session()
    if s is None:
        return value
    key = f"jaxga/broadcast/{next(s.broadcasts)}"
    if s.process_id == 0:
        s.client.key_value_set(key, json.dumps(value))
        return json.loads(json.dumps(value))
    return json.loads(s.wait_for(key, 0, "process 0's broadcast"))


def _pack(leaves: Sequence[np.ndarray]) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, *leaves)
    return buf.getvalue()


def _unpack(blob: bytes, n: int) -> list[np.ndarray]:
    with np.load(io.BytesIO(blob), allow_pickle=False) as z:
        return [z[f"arr_{i}"] for i in range(n)]


def process_index() -> int:
    """This process's id in a multi-process experiment (0 with one process)."""
    s = _current_session()
    return 0 if s is None else s.process_id


def process_count() -> int:
    """The number of processes of the experiment (1 without ``jax.distributed``)."""
    s = _current_session()
    return 1 if s is None else s.num_processes


# --- command line -------------------------------------------------------------------


def env_int(name: str) -> int | None:
    """Integer value of environment variable ``name``; None when unset or empty."""
    v = os.environ.get(name)
    if v in (None, ""):
        return None
    try:
        return ascii_int(v)
    except ValueError:
        raise JaxgaError(f"{name} must be an integer in ASCII digits, got {v!r}") from None


def add_parallel_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--devices``, ``--coordinator``, ``--num-processes``, ``--process-id`` and
    ``--process-timeout`` to a subcommand (their defaults come from ``JAXGA_*``
    environment variables); pair with :func:`configure_from_args`."""
    g = parser.add_argument_group(
        "devices and processes",
        "runs are split over every core by default, and over several processes or hosts "
        "with --coordinator (every process runs the same command with its own "
        "--process-id; process 0 writes the outputs)")
    g.add_argument("--devices", type=int, metavar="N",
                   help=f"XLA CPU devices in this process (default: one per core, or "
                   f"${ENV_DEVICES}, or the user's XLA_FLAGS {_FORCE_FLAG})")
    g.add_argument("--coordinator", metavar="HOST:PORT",
                   help=f"address of process 0 for a multi-process run (${ENV_COORDINATOR})")
    g.add_argument("--num-processes", type=int, metavar="N",
                   help=f"number of processes (${ENV_NUM_PROCESSES})")
    g.add_argument("--process-id", type=int, metavar="I",
                   help=f"this process's id, 0..N-1 (${ENV_PROCESS_ID})")
    g.add_argument("--process-timeout", type=float, metavar="SECONDS",
                   help="give up when a process has not joined, or has stopped responding, "
                   f"for this long (default {DEFAULT_PROCESS_TIMEOUT:.0f}; "
                   f"${ENV_PROCESS_TIMEOUT})")


def configure_from_args(args: argparse.Namespace) -> None:
    """Apply :func:`add_parallel_arguments`' options (or their environment variables):
    the device count first, then :func:`initialize` when a coordinator and more than one
    process are given. Call it before the command's first JAX computation."""
    devices = args.devices if args.devices is not None else env_int(ENV_DEVICES)
    # quiet about a backend already started if only the default was asked for; a user's
    # own device count past the bound is said either way
    set_local_devices(devices, warn=devices is not None or user_device_setting() is not None)
    coordinator = args.coordinator or os.environ.get(ENV_COORDINATOR) or None
    n = args.num_processes if args.num_processes is not None else env_int(ENV_NUM_PROCESSES)
    pid = args.process_id if args.process_id is not None else env_int(ENV_PROCESS_ID)
    timeout = args.process_timeout
    if timeout is None:
        env = os.environ.get(ENV_PROCESS_TIMEOUT)
        try:
            timeout = ascii_float(env) if env else DEFAULT_PROCESS_TIMEOUT
        except ValueError:
            raise JaxgaError(f"{ENV_PROCESS_TIMEOUT} must be a number in ASCII digits, got "
                             f"{env!r}") from None
    given = {"--coordinator": coordinator, "--num-processes": n, "--process-id": pid}
    if all(v is None for v in given.values()):
        return
    missing = [k for k, v in given.items() if v is None]
    if missing and not (n == 1 and coordinator is None):
        raise JaxgaError(f"a multi-process run needs {', '.join(missing)} too (or "
                         f"{ENV_COORDINATOR}, {ENV_NUM_PROCESSES}, {ENV_PROCESS_ID})")
    if n == 1:
        return
    initialize(coordinator, n, pid, timeout=timeout)
