"""Where a preset's cold compilation goes: tracing, lowering, XLA, and XLA's kernels by module.

    python benchmarks/compile_anatomy.py [--presets sga,imga,...] [--seeds 1] [--no-write]

For each preset, one fresh process (cold compile, no persistent cache, one XLA device)
runs ``jaxga.run`` on ``classic_ga_gapp3_20x20`` (population 60, mpmga 3 islands of 20,
300 generations) and reports:

* ``compile_s`` as ``jaxga.run`` reports it, split into tracing (JAX's
  ``jaxpr_trace_duration`` events), lowering (``Traced.lower``) and XLA
  (``Lowered.compile``), and the process's CPU seconds over the same call (user +
  system, every thread): with 2 cores, a CPU time near twice the wall time means the
  compilation is already limited by the CPU, not by waiting;
* per program (the map's tables, init, evolve, finish): XLA seconds and the number of
  kernels XLA emitted (``fusion`` instructions of the optimised HLO, each compiled on its
  own), and the jaxga
  modules whose code the most kernels come from (the innermost jaxga stack frame of each
  fusion's metadata; the code a folded call (:mod:`jaxga._batching.folding`) emits around the
  operator it folds, such as the pooled gated operators' block loop or a compacted
  loop's bookkeeping, is traced when the program is lowered under the stack of the
  call's ``fold_call``, so it counts as ``folding``).

The compile target is < 10 s per preset (decision 012); this says what a shorter
compile would have to cut.
"""

from __future__ import annotations

import argparse
import collections
import json
import re

from _results import (
    PRESETS,
    STANDARD_SETTING,
    cold_child,
    instrumented_run,
    markdown_table,
    parse_args,
    program_name,
    record,
)

FUSION = re.compile(r"\s*(ROOT )?%\S+ = .*? fusion\(")
"""An HLO ``fusion`` instruction (its result may be a tuple)."""


def kernels_by_module(hlo: str) -> tuple[int, collections.Counter]:
    """Fusion count of an optimised HLO module and the jaxga module of each fusion's
    innermost stack frame (``"other"``: no jaxga frame, e.g. JAX's own code)."""
    lines = hlo.splitlines()

    def table(name: str) -> dict[int, str]:
        if name not in lines:
            return {}
        out = {}
        for line in lines[lines.index(name) + 1:]:
            if not line.strip():
                break
            key, value = line.split(" ", 1)
            out[int(key)] = value
        return out

    files = {k: v.strip('"') for k, v in table("FileNames").items()}
    locations = {k: int(re.search(r"file_name_id=(\d+)", v).group(1))
                 for k, v in table("FileLocations").items()}
    frames = {k: tuple(int(x) for x in re.search(
        r"file_location_id=(\d+) parent_frame_id=(\d+)", v).groups())
        for k, v in table("StackFrames").items()}

    def module(frame: int) -> str:
        seen = set()
        while frame in frames and frame not in seen:
            seen.add(frame)
            loc, parent = frames[frame]
            path = files.get(locations.get(loc, -1), "")
            name = path.rsplit("/", 1)[-1]
            # api.py: the program wrappers around the engine; look at the caller's frame
            if "/jaxga/" in path and name != "api.py":
                return name.removesuffix(".py")
            frame = parent - 1  # the text prints a frame's parent id plus one (0: none)
        return "other"

    count, by = 0, collections.Counter()
    for line in lines:
        if FUSION.match(line):
            count += 1
            m = re.search(r"stack_frame_id=(\d+)", line)
            by[module(int(m.group(1))) if m else "other"] += 1
    return count, by


def child(preset: str, seeds: int) -> dict:
    """One cold ``jaxga.run`` in this process, instrumented."""
    r, parts = instrumented_run(preset, seeds)
    xla = parts["xla"]
    programs = {}
    for seconds, compiled, module in xla:
        name = program_name(module)
        if name in programs:
            raise RuntimeError(f"{name} compiled twice in one run")
        n, by = kernels_by_module(compiled.as_text())
        programs[name] = {"xla_s": seconds, "kernels": n, "by_module": by.most_common(4)}
    return {"compile_s": r.timing["compile_s"], "trace_s": parts["trace_s"],
            "lower_s": parts["lower_s"], "xla_s": sum(s for s, *_ in xla),
            "run_wall_s": r.timing["total_s"], "run_cpu_s": parts["cpu_s"],
            "programs": programs}


def measure(preset: str, seeds: int) -> dict:
    """:func:`child`'s numbers from a fresh process (cold compile, one device)."""
    return cold_child(__file__, f"{preset}:{seeds}", JAXGA_DEVICES="1")[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", default=",".join(PRESETS))
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--no-write", action="store_true")
    a = parse_args(ap, child)
    whole, programs = [], []
    for preset in a.presets.split(","):
        m = measure(preset, a.seeds)
        print(preset, json.dumps(m), flush=True)
        whole.append([preset, m["compile_s"], m["trace_s"], m["lower_s"], m["xla_s"],
                      m["run_wall_s"], m["run_cpu_s"]])
        for name, p in m["programs"].items():
            programs.append([preset, name, p["xla_s"], p["kernels"],
                             ", ".join(f"{mod} {n}" for mod, n in p["by_module"])])
    body = (
        f"{STANDARD_SETTING}, {a.seeds} seed(s), one XLA device, one fresh process per preset "
        f"(cold compile, no persistent cache). Seconds. compile = `jaxga.run`'s "
        f"`compile_s`; trace, lower, XLA = its parts (JAX's tracing events, "
        f"`Traced.lower`, `Lowered.compile`); run wall / run CPU = the whole `jaxga.run` "
        f"call's wall time and the process's CPU time over it (user + system).\n\n"
        + markdown_table(["preset", "compile", "trace", "lower", "XLA", "run wall",
                          "run CPU"], whole)
        + "\n\nXLA per program: kernels = `fusion` instructions of the optimised HLO; "
        "modules = the jaxga module of each kernel's innermost jaxga stack frame "
        "(the four largest).\n\n"
        + markdown_table(["preset", "program", "XLA s", "kernels", "kernels by module"],
                         programs)
    )
    record("cold compile anatomy of every preset", body, write=not a.no_write)


if __name__ == "__main__":
    main()
