"""``jaxga compare``: presets side by side with statistical tests (:mod:`jaxga.compare`)."""

from __future__ import annotations

import argparse
import sys

from jaxga._runtime.parallel import add_parallel_arguments
from jaxga.cli.options import (
    EXACT_HELP,
    EXIT_NO_PATH,
    RULE_DEFAULT,
    SIZE_CLASS_HELP,
    add_map_arguments,
    load_info,
    not_lead,
    plain_map,
    write_json,
)
from jaxga.compare import TESTS, check_metric, compare, split_presets
from jaxga.core.errors import ParameterError
from jaxga.core.grid import check_corner_rule
from jaxga.plot import (
    plot_comparison,
)


def cmd_compare(args: argparse.Namespace) -> int:
    """``jaxga compare``: several presets on one map with the same seeds; per-preset
    summary, pairwise tests with effect sizes (Holm-corrected), JSON, box plots."""

    presets = split_presets(args.presets)
    if len(presets) < 2:
        raise ParameterError(f"--presets needs at least two preset names, got {args.presets!r}")
    check_metric(args.metric)
    if args.test not in TESTS:
        raise ParameterError(f"unknown test {args.test!r}; choose from {', '.join(TESTS)}")
    if args.corner_rule is not None:

        check_corner_rule(args.corner_rule)
    grid = args.map
    if not plain_map(args):
        # --corner-rule, else the map's own rule: a preset that names another is refused
        grid = load_info(args, args.corner_rule)
    progress = None if args.quiet else (lambda label: print(f"running {label} ...",
                                                              file=sys.stderr, flush=True))
    comp = compare(presets, grid, seeds=args.seeds, metric=args.metric, test=args.test,
                   progress=progress, generations=args.generations,
                   corner_rule=args.corner_rule, sets=args.set or (),
                   size_class=args.size_class,
                   any_angle_budget=None if args.exact_optimum else "auto")
    if not_lead(f"{len(presets)} presets x {args.seeds} seeds",
                 sum(r.timing["total_s"] for r in comp.results.values())):
        return 0
    print(comp.summary())
    if args.json:
        write_json(args.json, comp.to_json())
    if args.plot:

        plot_comparison(comp, args.plot)
        print(f"wrote {args.plot}")
    if not any(r.success.any() for r in comp.results.values()):
        reasons = sorted({r.reason for r in comp.results.values() if r.reason})
        print("jaxga: no path: no preset found a path"
              + "".join(f"; {reason}" for reason in reasons), file=sys.stderr)
        return EXIT_NO_PATH
    return 0


def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add the ``compare`` command to ``jaxga``'s parser."""
    p = commands.add_parser("compare", help="compare presets on a map with statistical tests")
    p.add_argument("--presets", required=True, metavar="A,B,...",
                   help="comma-separated preset names (jaxga presets) or TOML files")
    add_map_arguments(p, rule_default=RULE_DEFAULT)
    p.add_argument("--seeds", type=int, default=30,
                   help="seeded runs per preset, the same seeds for all (default 30)")
    p.add_argument("--metric", default="length",
                   help="main metric: length (post-optimised, default), raw_length, gap, "
                   "raw_gap, fitness_gap, turns, angle_sum, convergence_generation")
    p.add_argument("--test", default="mannwhitneyu",
                   help="mannwhitneyu (default; independent samples) or wilcoxon (paired "
                   "by seed; only when the presets share random numbers)")
    p.add_argument("--size-class", action=argparse.BooleanOptionalAction, default=None,
                   help=SIZE_CLASS_HELP)
    p.add_argument("--exact-optimum", action="store_true", help=EXACT_HELP)
    p.add_argument("--generations", type=int, help="override every preset's generations")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a configuration key in every preset")
    p.add_argument("--json", metavar="OUT", help="write the comparison as JSON")
    p.add_argument("--plot", metavar="OUT.png",
                   help="box plots of the metric per preset (optima as reference lines)")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    add_parallel_arguments(p)
    p.set_defaults(func=cmd_compare, compiles=True)
