"""``jaxga doe``: a designed experiment (:mod:`jaxga.doe`)."""

from __future__ import annotations

import argparse
import sys

from jaxga._runtime.parallel import add_parallel_arguments
from jaxga.cli.options import add_preset_arguments, not_lead, problem_for_run, write_json
from jaxga.core.errors import JaxgaError
from jaxga.doe import AGACD_TABLE3, DESIGNS, RESPONSE_ALIASES, RESPONSES, Factor, run_doe
from jaxga.plot import (
    plot_main_effects,
    save_figure,
)


def cmd_doe(args: argparse.Namespace) -> int:
    """``jaxga doe``: a designed experiment (AGACD 5.2.1) with its confirmation run."""

    if args.factor:
        factors = [Factor.parse(text) for text in args.factor]
    elif args.design == "agacd-table4":
        factors = list(AGACD_TABLE3)
    else:
        raise JaxgaError("give the factors with --factor NAME=LOW,MID,HIGH (only "
                         "--design agacd-table4 has default factors, AGACD Table 3)")

    def progress(done: int, total: int) -> None:
        if not args.quiet:
            print(f"design points done: {done}/{total}", file=sys.stderr, flush=True)

    result = run_doe(
        problem_for_run(args), None, factors, design=args.design, seeds=args.seeds,
        response=args.response, direction=args.direction, checkpoint=args.checkpoint,
        block=args.block, progress=progress,
    )
    if not_lead(f"{len(result.coded)} design points x {len(result.seeds)} seeds",
                 result.timing["total_s"]):
        return 0
    print(result.report())
    data = result.to_json()
    if args.json:
        write_json(args.json, data)
    if args.plot:

        save_figure(plot_main_effects(data).figure, args.plot)
        print(f"wrote {args.plot}")
    return 0


def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add the ``doe`` command to ``jaxga``'s parser."""
    p = commands.add_parser("doe", help="a designed experiment over hyper-parameters (AGACD 5.2.1)")
    add_preset_arguments(p)
    p.add_argument("--design", default="agacd-table4", choices=DESIGNS,
                   help="AGACD's 9-run design (its Table 4), an orthogonal array or the "
                   "full factorial (default agacd-table4)")
    p.add_argument("--factor", action="append", metavar="NAME=LOW,MID,HIGH",
                   help="a factor and its levels coded -1,0,1, e.g. population.size=40,50,60 "
                   "(repeat; default for agacd-table4: AGACD Table 3)")
    p.add_argument("--seeds", type=int, default=5, help="seeded runs per point (default 5)")
    p.add_argument("--response", default="fitness",
                   choices=(*RESPONSES, *RESPONSE_ALIASES),
                   help="the response fitted (default fitness; angle_sum = smoothness)")
    p.add_argument("--direction", choices=("max", "min"),
                   help="maximise or minimise the response (default: max for fitness and "
                   "success, min for the others)")
    p.add_argument("--checkpoint", metavar="DIR",
                   help="write each finished point to DIR; rerun the same command to resume")
    p.add_argument("--block", type=int,
                   help="design points per compiled call (default: all; 1 with --checkpoint)")
    p.add_argument("--json", metavar="OUT", help="write the design, responses and fit as JSON")
    p.add_argument("--plot", metavar="OUT.png", help="main-effects plot")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    add_parallel_arguments(p)
    p.set_defaults(func=cmd_doe, compiles=True)
