"""``jaxga warmup``: a day's programs compiled ahead."""

from __future__ import annotations

import argparse
import time

import jax

from jaxga._runtime import parallel
from jaxga._runtime.parallel import add_parallel_arguments
from jaxga.api.warmup import warmup
from jaxga.cli.options import given_presets, parse_int_list
from jaxga.core.errors import JaxgaError
from jaxga.core.grid import CORNER_RULES


def cmd_warmup(args: argparse.Namespace) -> int:
    """``jaxga warmup``: compile the presets' programs ahead into the persistent cache."""
    # XLA compiles every program afresh (no read from JAX's own cache), so that each is
    # stored whole (jaxga._runtime.executables); before this process compiles anything
    jax.config.update("jax_enable_compilation_cache", False)
    presets = given_presets(args.presets)
    maps: list = [*parse_int_list(args.sizes)] if args.sizes else []
    maps += list(args.map or ())
    maps = list(dict.fromkeys(maps))  # --sizes 20,20: one program set, not two
    if not maps:
        raise JaxgaError("nothing to warm up: give --sizes or --map")
    lead = parallel.process_index() == 0

    def show(row: dict) -> None:
        if lead:
            print(f"{row['preset']:>10}  {row['map']:<28} {row['seeds']:>4} seeds  "
                  f"compile {row['compile_s']:6.1f} s", flush=True)

    t0 = time.perf_counter()
    rows = warmup(presets, maps, seeds=parse_int_list(args.seeds) if args.seeds else None,
                  corner_rule=args.corner_rule, size_class=args.size_class, report=show)
    if lead:
        print(f"{len(rows)} program sets ready in {time.perf_counter() - t0:.0f} s "
              f"(cache: {jax.config.jax_compilation_cache_dir})")
    return 0


def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add the ``warmup`` command to ``jaxga``'s parser."""
    p = commands.add_parser("warmup", help="compile presets' programs ahead into the persistent "
                       "compilation cache (any seed count and generation count then reuses "
                       "them)")
    p.add_argument("--presets", metavar="A,B,...",
                   help="presets to compile (default: every built-in preset)")
    p.add_argument("--sizes", default="20,32,64", metavar="N,N,...",
                   help="open N x N maps to compile for (default 20,32,64; '' for none)")
    p.add_argument("--map", action="append", metavar="MAP",
                   help="also a built-in map name or a map file (repeatable)")
    p.add_argument("--seeds", metavar="N,N,...",
                   help="seed counts to compile for (default: 4 and the platform's program "
                   "sizes, 32 per device on the CPU, powers of two from 32 to 2048 on a GPU: "
                   "together "
                   "they serve every seed count)")
    p.add_argument("--corner-rule", default=None, metavar="RULE",
                   help=f"one of {', '.join(CORNER_RULES)} (default: strict on the open maps, "
                   "a named map's own)")
    p.add_argument("--size-class", action=argparse.BooleanOptionalAction, default=None,
                   help="compile the size classes' programs (default: as jaxga run, the "
                   "classes of sides over 64; --sizes N compiles the N x N class, --map "
                   "MAP a map's own class, each side padded on its own: a 604 x 307 map "
                   "is in the 768 x 384 class; --size-class also pads 32 and 64)")
    add_parallel_arguments(p)
    p.set_defaults(func=cmd_warmup, compiles=True)
