"""Every code block of the README and of the documentation site runs as written.

A page's blocks run in order, in a fresh folder holding a copy of ``docs/examples/`` (the
maps the pages use; also as ``docs/examples/`` in it, for the README, which is read from
the repository's root), like a reader who types them one after another:

* ``python``: executed in one namespace per page;
* ``bash``: each command run by the shell (a trailing ``\\`` joins lines; ``# comments``
  are skipped); it must exit 0. A plain ``jaxga ...`` command (no pipes, redirections or
  variables) runs in this process through ``jaxga.cli.main``, the console script's own
  function, so that it shares the programs the page's Python compiled (a process of
  its own would import JAX and read every program again; the console script itself is
  tested in ``tests/tools/test_cli.py``). A line that installs (``python3 -m venv``,
  ``pip install``) is not run here: those are the README's two commands (install and run
  the main job; install and run this suite), which ``.ci/run`` runs on a fresh clone;
* ``toml``: parsed, and loaded as a preset file when it names a ``base`` preset;
* ``yaml``: parsed;
* ``text``: output and synopses, not run.

A block of any other kind fails :func:`test_every_code_block_has_a_known_kind`.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import shlex
import shutil
import subprocess
import sys
import warnings

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib
from pathlib import Path

import pytest
import yaml

from jaxga.core.errors import DeviceWarning

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
EXAMPLES = DOCS / "examples"
PAGES = [ROOT / "README.md", *sorted(p for p in DOCS.rglob("*.md") if EXAMPLES not in p.parents)]
KINDS = {"python", "bash", "toml", "yaml", "text"}
RUN = {"python", "bash", "toml", "yaml"}
FENCE = re.compile(r"^(?P<indent>[ ]*)```(?P<kind>[\w-]*)[^\n]*\n(?P<body>.*?)^(?P=indent)```",
                   re.M | re.S)
INSTALLS = re.compile(r"(^|&&\s*)(python3? -m venv|pip install)")
SHELL = re.compile(r"[|&;<>$`*?()]")
"""Characters that need the shell: a command with any of them runs in a shell."""


def blocks(page: Path) -> list[tuple[str, str]]:
    """``(kind, code)`` of every fenced block of ``page``, in order (indentation removed)."""
    out = []
    for m in FENCE.finditer(page.read_text()):
        indent = len(m["indent"])
        code = "\n".join(line[indent:] for line in m["body"].splitlines())
        out.append((m["kind"], code))
    return out


def commands(code: str) -> list[str]:
    """The shell commands of a bash block: continuation lines joined; comments and lines
    that install left out."""
    out = []
    for line in code.replace("\\\n", " ").splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        if not INSTALLS.search(line):
            out.append(line)
    return out


def run_command(command: str, env: dict) -> tuple[int, str]:
    """Run one command of a bash block: its exit code and its standard error. A plain
    ``jaxga`` command runs in this process (module docstring), any other in a shell."""
    argv = shlex.split(command, comments=True)
    if argv[0] == "jaxga" and not SHELL.search(command):
        from jaxga.cli import main

        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main(argv[1:])
            except SystemExit as e:  # argparse refused the command line
                code = e.code
        return code, err.getvalue()
    done = subprocess.run(command, shell=True, env=env, capture_output=True, text=True,
                          timeout=900)
    return done.returncode, done.stderr


RUNNABLE = [p for p in PAGES if any(kind in RUN for kind, _ in blocks(p))]


def test_every_code_block_has_a_known_kind():
    unknown = [(p.relative_to(ROOT), kind) for p in PAGES for kind, _ in blocks(p)
               if kind not in KINDS]
    assert not unknown, f"code blocks without a known kind ({', '.join(KINDS)}): {unknown}"
    assert {p.name for p in RUNNABLE} >= {"README.md", "pure-core.md", "maps.md"}


@pytest.fixture
def _registry_as_found():
    """A page registers operators of its own (``jaxga.register_operator``), as a reader
    would; the other tests in this process must not see them."""
    from jaxga.operators import registry

    before = {family: set(registry.names(family)) for family in registry.FAMILIES}
    yield
    for family, names in before.items():
        for name in set(registry.names(family)) - names:
            registry.unregister(family, name)


@pytest.mark.slow
@pytest.mark.parametrize("page", RUNNABLE, ids=[str(p.relative_to(ROOT)) for p in RUNNABLE])
@pytest.mark.usefixtures("_registry_as_found")
def test_the_code_blocks_of_a_page_run(page, tmp_path, monkeypatch):
    shutil.copytree(EXAMPLES, tmp_path, dirs_exist_ok=True)  # the pages' own folder
    shutil.copytree(EXAMPLES, tmp_path / "docs" / "examples")  # the README's, from the root
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}"
           f"{os.environ.get('PATH', '')}"}
    namespace: dict = {"__name__": "__docs__"}
    for i, (kind, code) in enumerate(blocks(page)):
        where = f"{page.relative_to(ROOT)}, block {i + 1}"
        if kind == "python":
            with warnings.catch_warnings():
                # a page's devices line is for a fresh process; this one runs JAX already
                warnings.filterwarnings("ignore", "jaxga.api.devices: JAX is already running",
                                        DeviceWarning)
                exec(compile(code, where, "exec"), namespace)  # noqa: S102 - the page's code
        elif kind == "bash":
            for command in commands(code):
                code, err = run_command(command, env)
                assert code == 0, f"{where}: `{command}` exited {code}:\n{err[-2000:]}"
        elif kind == "toml":
            data = tomllib.loads(code)
            if "base" in data:
                from jaxga.config.presets import load_preset

                (tmp_path / "block.toml").write_text(code)
                load_preset(str(tmp_path / "block.toml"))
        elif kind == "yaml":
            yaml.safe_load(code)


def _hooks():
    """docs/hooks.py, the site's MkDocs hooks, as a module."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("docs_hooks", ROOT / "docs" / "hooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_docstrings_roles_render_as_links_or_code():
    """A documented name becomes a link to its anchor (full name, a unique suffix, or
    ``~`` for the last part only); an undocumented one plain code; no role text is left."""
    html = ('<h2 id="jaxga.run">run</h2><h3 id="jaxga.GA.evolve">evolve</h3>'
            '<h3 id="jaxga.api.result.Result.path">path</h3><p>see :func:<code>jaxga.run'
            '</code>, :meth:<code>evolve</code>, :class:<code>~jaxga.core.grid.Grid</code>, '
            ':meth:<code>~jaxga.api.result.Result.path</code> and :data:<code>path'
            '</code></p>')
    out = _hooks().resolve_roles(html)
    assert ('see <a href="#jaxga.run"><code>jaxga.run</code></a>, '
            '<a href="#jaxga.GA.evolve"><code>evolve</code></a>, <code>Grid</code>, '
            '<a href="#jaxga.api.result.Result.path"><code>path</code></a> and '
            '<a href="#jaxga.api.result.Result.path"><code>path</code></a>') in out
    assert ":func:" not in out and ":class:" not in out
