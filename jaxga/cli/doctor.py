"""``jaxga doctor``: does this machine's JAX backend compute jaxga's results?"""

from __future__ import annotations

import argparse

import jax

from jaxga.api.doctor import doctor
from jaxga.cli.options import EXIT_DEVICE_DISAGREES, given_presets, write_json
from jaxga.core.errors import JaxgaError


def cmd_doctor(args: argparse.Namespace) -> int:
    """``jaxga doctor``: the probes of :func:`jaxga.api.doctor.doctor`, a table, the
    verdict line last; exit status :data:`EXIT_DEVICE_DISAGREES` when it disagrees."""
    if args.quick and args.presets is not None:
        raise JaxgaError("--presets names the whole runs, which --quick leaves out: give "
                         "one or the other")
    named = given_presets(args.presets)
    device = jax.devices()[0]
    print(f"checking {device.platform} ({device.device_kind}) against the CPU", flush=True)
    presets = () if args.quick else named
    report = doctor(device, presets=presets,
                    report=lambda line: print(f"  {line}", flush=True))
    print(report.table())
    if args.json:
        write_json(args.json, report.as_dict())
    print(f"{report.verdict} in {report.seconds:.0f} s")
    return 0 if report.agrees else EXIT_DEVICE_DISAGREES


def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add the ``doctor`` command to ``jaxga``'s parser."""
    p = commands.add_parser(
        "doctor", help="check that JAX's default backend (a GPU, ...) computes jaxga's "
        "results as the CPU does: random bits, initial walks of 2048 runs in one call, "
        "whole runs of every preset, a throughput figure")
    p.add_argument("--presets", metavar="A,B,...",
                   help="presets of the whole runs (default: every built-in preset)")
    p.add_argument("--quick", action="store_true",
                   help="the exact probes only (random bits, walks): what run, sweep, compare "
                   "and doe check once per device kind before computing off the CPU")
    p.add_argument("--json", metavar="OUT", help="write the report as JSON")
    p.set_defaults(func=cmd_doctor, compiles=True)
