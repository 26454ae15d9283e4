"""The suite's guard on compiled programs: each test file has a budget of XLA programs.

Most of the suite's time is XLA compiling programs (``benchmarks/suite_time.py``), so a
test that builds a new program where a shared one would do costs far more than its
assertions. This plugin counts, per test file and per pytest process, JAX's backend
compile events (``/jax/core/compile/backend_compile_duration``: a program XLA compiled or
read from the persistent compilation cache; a program already in memory counts nothing)
from the start of the file's first test to the end of its last one, module fixtures
included, and fails the file's last test at teardown when the count exceeds the file's
budget in ``tests/compile_budgets.toml`` (``default`` for a file not listed). Work in
processes a test starts (notebook kernels, command lines, ``jax.distributed``) is not
seen here.

A budget is an upper bound: a file that runs after another one in the same process may
find some of its programs in memory already and count fewer. At the end, the terminal
summary names the files that compiled the most, with their budgets (with ``pytest-xdist``
the workers send their counts to the controller).

``JAXGA_COMPILE_BUDGET=off`` turns the check off (for example while profiling), and
``JAXGA_COMPILE_BUDGET=report`` keeps the summary without failing.
``JAXGA_COMPILE_COUNTS=PATH`` also writes every file's count to ``PATH`` (JSON), for
setting the budgets.
"""

from __future__ import annotations

import json
import os
import sys
from collections import Counter
from pathlib import Path

import jax.monitoring
import pytest

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

BACKEND_COMPILE = "/jax/core/compile/backend_compile_duration"
BUDGETS_FILE = Path(__file__).with_name("compile_budgets.toml")
ENV = "JAXGA_COMPILE_BUDGET"
COUNTS_ENV = "JAXGA_COMPILE_COUNTS"
SHOWN = 12
"""Files named in the terminal summary, most programs first."""


def load_budgets(path: Path = BUDGETS_FILE) -> tuple[int, dict[str, int]]:
    """``(default, {file relative to tests/: budget})`` from the budgets file."""
    with path.open("rb") as f:
        data = tomllib.load(f)
    return int(data["default"]), {k: int(v) for k, v in data["files"].items()}


class CompileBudget:
    """Counts compiled programs per test file and enforces the budgets (module docstring)."""

    def __init__(self, mode: str) -> None:
        self.mode = mode
        self.programs = 0
        self._started = 0  # the count when the running test's setup began
        self.per_file: Counter[str] = Counter()
        self.default, self.budgets = load_budgets()
        jax.monitoring.register_event_duration_secs_listener(self._listen)

    def _listen(self, event: str, duration: float, **_kwargs) -> None:
        if event == BACKEND_COMPILE:
            self.programs += 1

    def budget(self, name: str) -> int:
        """The budget of the test file ``name`` (relative to ``tests/``)."""
        return self.budgets.get(name, self.default)

    @staticmethod
    def name(item: pytest.Item) -> str:
        return Path(item.path).resolve().relative_to(BUDGETS_FILE.parent).as_posix()

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_protocol(self, item: pytest.Item, nextitem: pytest.Item | None):
        before = self.programs
        yield
        self.per_file[self.name(item)] += self.programs - before

    @pytest.hookimpl(wrapper=True)
    def pytest_runtest_teardown(self, item: pytest.Item, nextitem: pytest.Item | None):
        result = yield
        last = nextitem is None or nextitem.path != item.path
        if not last or self.mode != "on":
            return result
        name = self.name(item)
        # this test's own programs so far, and the file's earlier tests'
        count = self.per_file[name] + self.programs - self._started
        if count > self.budget(name):
            pytest.fail(f"{name} compiled {count} programs, over its budget of "
                        f"{self.budget(name)} (tests/compile_budgets.toml): share the "
                        "canonical problems (tests/canonical.py) or jit once at module "
                        "level instead of compiling new programs", pytrace=False)
        return result

    @pytest.hookimpl(tryfirst=True)
    def pytest_runtest_setup(self, item: pytest.Item) -> None:
        self._started = self.programs

    def pytest_sessionfinish(self, session: pytest.Session) -> None:
        workeroutput = getattr(session.config, "workeroutput", None)
        if workeroutput is not None:  # an xdist worker: the controller reports
            workeroutput["jaxga_programs"] = json.dumps(dict(self.per_file))

    def pytest_testnodedown(self, node, error) -> None:
        """xdist's controller: add a finished worker's counts."""
        data = getattr(node, "workeroutput", {}).get("jaxga_programs")
        if data:
            self.per_file.update(json.loads(data))

    def pytest_terminal_summary(self, terminalreporter) -> None:
        if not self.per_file:
            return
        counts = os.environ.get(COUNTS_ENV)
        if counts:
            Path(counts).write_text(json.dumps(dict(sorted(self.per_file.items())), indent=1))
        top = self.per_file.most_common(SHOWN)
        terminalreporter.write_line(
            f"compiled programs: {sum(self.per_file.values())} in "
            f"{len(self.per_file)} files; most: " + ", ".join(
                f"{name} {n}/{self.budget(name)}" for name, n in top if n))


def register(config: pytest.Config) -> None:
    """Register the plugin unless ``$JAXGA_COMPILE_BUDGET`` is ``off``."""
    mode = os.environ.get(ENV, "on")
    if mode not in ("on", "off", "report"):
        raise pytest.UsageError(f"${ENV} must be on, off or report, got {mode!r}")
    if mode != "off":
        config.pluginmanager.register(CompileBudget(mode), "jaxga_compile_budget")
