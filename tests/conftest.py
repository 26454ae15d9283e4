"""Shared test configuration: JAX's persistent compilation cache, hypothesis profiles, the
``slow`` tier (pyproject.toml) and the per-file budget of compiled programs
(:mod:`tests.compile_budget`)."""

from __future__ import annotations

import os
from pathlib import Path

import jax
import pytest
from hypothesis import HealthCheck, settings

from tests import compile_budget

CACHE_DIR = Path(os.environ.get("JAXGA_TEST_JAX_CACHE", Path(__file__).parent / ".jax_cache"))
jax.config.update("jax_compilation_cache_dir", str(CACHE_DIR))
os.environ["JAXGA_CACHE_DIR"] = str(CACHE_DIR)  # the CLI's own cache, when run in-process
# `jaxga run` in-process would otherwise give the whole test session one device per core
# (jaxga._runtime.parallel) if it were the first JAX computation: keep the session's one device.
os.environ.setdefault("JAXGA_DEVICES", "1")
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)

settings.register_profile(
    "jaxga",
    deadline=None,
    max_examples=60,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
    derandomize=True,
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "jaxga"))

DATA = Path(__file__).parent / "data"


MAX_MAPPED_REGIONS = 30_000
"""Free compiled programs when the process maps more regions than this.

Every compiled XLA:CPU program keeps ~3 memory mappings per kernel alive; the whole suite
in one process compiles several hundred programs, and at Linux's default
``vm.max_map_count`` (65,530) XLA segfaults (it did, in ``put_executable_and_time``,
~400 tests in). Programs compiled again later come from the persistent cache."""


def mapped_regions() -> int | None:
    """How many memory regions this process maps (None off Linux)."""
    try:
        with open("/proc/self/maps", "rb") as maps:
            return sum(1 for _ in maps)
    except OSError:  # not Linux
        return None


def pytest_configure(config: pytest.Config) -> None:
    compile_budget.register(config)


@pytest.fixture(autouse=True)
def _store_as_configured_here(monkeypatch):
    """Each test starts with the store of the suite's settings (JAX's cache folder,
    ``$JAXGA_CACHE_DIR``): a command an earlier test ran in this process called
    ``jaxga.configure``, whose folder would otherwise win over a test's own."""
    from jaxga._runtime import compilation_cache

    monkeypatch.setattr(compilation_cache, "_configured", {})


@pytest.fixture(autouse=True)
def _bounded_compiled_programs():
    yield
    n = mapped_regions()
    if n is not None and n > MAX_MAPPED_REGIONS:
        from jaxga.api import clear_compiled

        clear_compiled()


SLOWEST_FILES = ("test_docs.py", "test_api.py", "test_notebooks.py", "test_distributed.py",
                 "test_device_check.py",
                 "test_crossover.py", "test_behaviour.py", "test_field.py", "test_registry.py",
                 "test_batching.py", "test_init.py", "test_engine.py", "test_mutation.py",
                 "test_doe.py")
"""The test files that take the longest on the 2-core CI machine with a cold compilation
cache (``benchmarks/suite_time.py``; decision 024), roughly slowest first: they run first.

``--dist loadfile`` (pyproject.toml) hands whole files to the two workers in queue
order, and by default xdist queues files by their number of tests, which put the
notebooks and the ``jax.distributed`` tests (few tests, 2-3 minutes each) last: one
worker then ran alone for up to two minutes at the end. Longest first (with
``--no-loadscope-reorder``, the queue follows this collection order) leaves only short
files for the end."""


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config, items):
    """Queue :data:`SLOWEST_FILES` first, in that order; every file's own order is kept."""
    rank = {name: i for i, name in enumerate(SLOWEST_FILES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))
