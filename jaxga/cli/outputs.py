"""Outputs checked before any work: writable, not an input, not another output (decision 033)."""

from __future__ import annotations

import argparse
import contextlib
import io
import os
from pathlib import Path

import numpy as np

from jaxga import export
from jaxga._runtime.parallel import (
    ENV_PROCESS_ID,
    env_int,
)
from jaxga.config.presets import preset_files
from jaxga.core.errors import JaxgaError
from jaxga.core.files import PACKAGE, same_file
from jaxga.core.files import check_outputs as check_output_files
from jaxga.core.matplotlib_env import matplotlib_ready
from jaxga.maps import (
    scenario_path,
)
from jaxga.maps.builtin import builtin_names, builtin_path
from jaxga.maps.ros import read_ros_yaml

OUTPUT_OPTIONS = ("json", "plot", "path_out", "checkpoint")


def input_files(args: argparse.Namespace) -> list[tuple[str, str | None]]:
    """``(label, path)`` of every file the command reads: the map (and a ROS map's image),
    the scenario file, the path JSON of replan, preset TOML files."""
    out: list[tuple[str, str | None]] = []
    maps = getattr(args, "map", None)
    for m in (maps if isinstance(maps, list) else [maps]):
        if m and not Path(m).is_file() and m in builtin_names():  # a built-in map's file
            out.append(("built-in map", str(builtin_path(m))))
        if m and Path(m).is_file():
            out.append(("map", m))
            if Path(m).suffix.lower() in (".yaml", ".yml"):
                with contextlib.suppress(JaxgaError, OSError):  # a bad YAML: named later
                    out.append(("map's image", str(read_ros_yaml(m).image)))
    out.append(("scenario file", getattr(args, "scen", None)))
    if getattr(args, "scenario", None) is not None and maps and not getattr(args, "scen", None):
        found = scenario_path(maps if isinstance(maps, str) else maps[0])
        out.append(("scenario file", str(found) if found else None))
    out.append(("path JSON", getattr(args, "path_json", None)))
    out.append(("path file", getattr(args, "path", None)))
    presets = [getattr(args, "preset", None), *str(getattr(args, "presets", "") or "")
               .split(",")]
    for p in presets:  # a preset TOML and the files of its base chain
        if p and Path(p).is_file():
            out.extend(("preset file", f) for f in preset_files(p))
    return out


def _inside(path: str, folder: str) -> bool:
    """Whether ``path`` names a file in ``folder`` or below it (symbolic links
    resolved)."""
    target, top = Path(path).resolve(), Path(folder).resolve()
    return top in target.parents


def check_outputs(args: argparse.Namespace) -> None:
    """Check every output (``--json``, ``--plot``, ``--path-out``, a DOE's
    ``--checkpoint`` folder) before the work, not after it
    (:func:`jaxga.core.files.check_outputs`): writable where it is, not a folder, not an
    input of the command nor another output; the plot's extension must be an image format
    matplotlib writes (no extension: ``.png`` is added, as matplotlib would, and
    reported)."""
    pid = _process_id(args)
    if getattr(args, "path_out", None):
        export.path_format(args.path_out)  # .csv or .yaml, refused in one line otherwise
    plot = getattr(args, "plot", None)
    if plot and not Path(plot).suffix and not os.path.lexists(plot):
        args.plot = plot + ".png"  # an existing name is checked as given (a device, ...)
    if pid not in (None, 0):  # only process 0 writes the outputs
        return
    outputs = {f"--{o.replace('_', '-')}": getattr(args, o, None) for o in OUTPUT_OPTIONS
               if o != "checkpoint"}
    inputs = input_files(args)
    package = PACKAGE
    for option, path in outputs.items():
        if path is not None and str(path) == "-":  # not standard output: a file named -
            raise JaxgaError(f"cannot write {option} -: jaxga writes its outputs to files "
                             "(standard output carries the summary); give a file name, "
                             "./- for a file of that name")
        if path and str(path).endswith(("/", os.sep)):  # POSIX: a folder's name
            raise JaxgaError(f"cannot write {option} {path}: a name ending in '/' names a "
                             "folder, not a file")
        if path and (_inside(path, package) or Path(path).resolve() == package):
            raise JaxgaError(f"cannot write {option} {path}: it is inside jaxga's own "
                             f"folder {package} (its code, built-in maps and presets)")
    check_output_files(outputs, inputs)
    folder = getattr(args, "checkpoint", None)
    if folder and (_inside(folder, package) or Path(folder).resolve() == package):
        raise JaxgaError(f"cannot use --checkpoint {folder}: it is inside jaxga's own "
                         f"folder {package} (its code, built-in maps and presets)")
    if folder:
        for label, path in [*inputs, *outputs.items()]:
            if path and Path(path).is_dir() and same_file(path, folder):
                raise JaxgaError(f"cannot use --checkpoint {folder}: it is the {label}")
        for option, path in outputs.items():  # the DOE's own files live there
            if path and _inside(path, folder):
                raise JaxgaError(f"cannot write {option} {path}: it is inside the "
                                 f"--checkpoint folder {folder}, whose files the DOE "
                                 "reads to resume")
    plot = getattr(args, "plot", None)
    if plot:
        matplotlib_ready()
        from matplotlib.figure import Figure

        formats = Figure().canvas.get_supported_filetypes()
        suffix = Path(plot).suffix.lower().lstrip(".")
        if suffix not in formats:
            raise JaxgaError(f"cannot write --plot {plot}: {suffix!r} is not an image format "
                             f"matplotlib writes ({', '.join(sorted(formats))})")
        else:  # some formats need outside tools (pgf: LaTeX for any text): try one first
            probe = Figure()
            probe.text(0.5, 0.5, "jaxga")
            try:
                probe.savefig(io.BytesIO(), format=suffix)
            except Exception as err:  # noqa: BLE001 - any backend failure, named
                raise JaxgaError(f"cannot write --plot {plot}: matplotlib cannot write "
                                 f"{suffix!r} here ({err})") from None


def write_empty_path(args: argparse.Namespace) -> None:
    """Where there is no path, ``--path-out`` holds an empty path (a CSV header alone, or
    a ``nav_msgs/Path`` without poses), so that a robot reading the file cannot follow
    the path of an earlier request still there; and says so. Only process 0 writes."""
    out = getattr(args, "path_out", None)
    if not out or _process_id(args) not in (None, 0):
        return
    export.write_path(out, np.zeros((0, 2)))
    print(f"wrote {out} (an empty path: no path)")


def _process_id(args: argparse.Namespace) -> int | None:
    """This process's id in a multi-process command (``--process-id`` or its variable);
    None for a single process. Only process 0 writes the outputs."""
    pid = getattr(args, "process_id", None)
    return env_int(ENV_PROCESS_ID) if pid is None else pid
