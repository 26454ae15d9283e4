"""A DOE's checkpoint folder: its manifest (what was run; another configuration is refused),
one file per finished point and per confirmation, written atomically, and the JSON encoding
of responses (infinities, failed seeds).
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from jaxga._runtime import parallel
from jaxga.core.errors import ParameterError
from jaxga.core.files import atomic_write
from jaxga.core.grid import Grid
from jaxga.doe.fit import RESPONSES

# ----------------------------------------------------------------------------- results


def json_float(v: float) -> float | None:
    return None if v is None or not math.isfinite(v) else float(v)


# ----------------------------------------------------------------------------- checkpoint


def _atomic_write_json(path: Path, data: Any) -> None:
    """Write JSON to ``path`` atomically (:func:`jaxga.core.files.atomic_write`): a killed
    process leaves either the old file or the new one."""
    atomic_write(path, lambda f: json.dump(data, f))


def map_fingerprint(grid: Grid, name: str) -> dict[str, Any]:
    blocked = np.ascontiguousarray(grid.blocked_np(), dtype=np.uint8)
    return {"name": name, "width": int(grid.width), "height": int(grid.height),
            "start": list(grid.start_xy), "goal": list(grid.goal_xy),
            "corner_rule": grid.corner_rule,
            "blocked_sha256": hashlib.sha256(blocked.tobytes()).hexdigest()}


class Checkpoint:
    """A directory of finished points: ``manifest.json``, ``point-NNNN.json``,
    ``confirm_<coded>.json``."""

    def __init__(self, directory: str | Path, manifest: dict[str, Any]) -> None:

        self.dir = Path(directory)
        # every point file carries its experiment's mark: a file copied in from another
        # experiment's checkpoint (same index, other configuration) is refused, not read
        self.mark = hashlib.blake2b(json.dumps(manifest, sort_keys=True, default=str)
                                    .encode(), digest_size=8).hexdigest()
        config = manifest.get("config")
        self.generations = config.get("generations") if isinstance(config, dict) else None
        # Several processes (jaxga._runtime.parallel): process 0 alone reads and writes the
        # checkpoint; the others receive what it read (and its refusal) by broadcast, so
        # every process agrees on which points remain even without a shared filesystem.
        self.lead = parallel.process_index() == 0
        error = self._check(manifest) if self.lead else None
        error = parallel.broadcast(error)
        if error:
            raise ParameterError(error)

    def _check(self, manifest: dict[str, Any]) -> str | None:
        """Validate (or create) the manifest; the refusal message, or None."""
        if self.dir.exists() and not self.dir.is_dir():
            return f"checkpoint {self.dir} is a file, not a directory"
        self.dir.mkdir(parents=True, exist_ok=True)
        path = self.dir / "manifest.json"
        if path.exists() or path.is_symlink():
            if not path.is_file():  # a FIFO would block the read for good
                return (f"checkpoint {self.dir}: its manifest {path.name} is not a regular "
                        "file; use another directory or delete it")
            try:
                old = json.loads(path.read_text(encoding="utf-8"))
            except (OSError, ValueError, RecursionError) as e:
                return f"checkpoint {self.dir}: unreadable manifest: {e}"
            if not isinstance(old, dict):
                return (f"checkpoint {self.dir}: unreadable manifest: not a JSON object; use "
                        "another directory or delete it")
            if old != manifest:
                keys = sorted(k for k in old.keys() | manifest.keys()
                              if old.get(k) != manifest.get(k))
                if keys == ["device"]:
                    return (f"checkpoint {self.dir} was computed on {old.get('device')}, this "
                            f"run is on {manifest['device']}: resume it there, or use "
                            "another directory (two devices' points are not mixed in one fit)")
                return (f"checkpoint {self.dir} was written by a different configuration "
                        f"(differs in {', '.join(keys)}); use another directory or delete it")
        else:
            if any(self.dir.glob("point-*.json")):
                return f"checkpoint {self.dir} has points but no manifest"
            _atomic_write_json(path, manifest)
        return None

    def _point(self, q: int) -> Path:
        return self.dir / f"point-{q:04d}.json"

    def _read(self, path: Path, n_seeds: int) -> dict[str, list]:
        """The responses saved in ``path``, checked: every response, one value (a number
        or null) per seed; ``ParameterError`` naming the file otherwise."""
        if not path.is_file():  # a FIFO would block the read for good
            raise ParameterError(f"checkpoint file {path} is not a regular file: delete it "
                                 "and run again to recompute it")
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError, RecursionError) as e:
            raise ParameterError(f"checkpoint file {path} is unreadable ({e}): delete it "
                                 f"and run again to recompute it") from None
        stem = path.stem
        if isinstance(data, dict) and stem.startswith("point-") and "point" in data \
                and data["point"] != int(stem.removeprefix("point-")):
            raise ParameterError(f"checkpoint file {path} holds point {data['point']!r}, not "
                                 f"{int(stem.removeprefix('point-'))}: delete it and run "
                                 "again to recompute it")
        if isinstance(data, dict) and data.get("experiment") != self.mark:
            raise ParameterError(f"checkpoint file {path} was written by another experiment "
                                 "(not this checkpoint's configuration): delete it and run "
                                 "again to recompute it")
        responses = data.get("responses") if isinstance(data, dict) else None
        ok = (isinstance(responses, dict) and set(responses) == set(RESPONSES)
              and all(isinstance(v, list) and len(v) == n_seeds
                      and all(x is None or x in _INFINITIES
                              or (isinstance(x, (int, float)) and not isinstance(x, bool))
                              for x in v)
                      for v in responses.values()))
        if not ok:
            raise ParameterError(
                f"checkpoint file {path} does not hold the responses ({', '.join(RESPONSES)}) "
                f"of {n_seeds} seeds: delete it and run again to recompute it")
        wrong = _impossible_response(responses, self.generations)
        if wrong:
            raise ParameterError(f"checkpoint file {path} holds an impossible value: {wrong}; "
                                 "delete it and run again to recompute it")
        reason = data.get("reason", "")
        if not isinstance(reason, str):
            raise ParameterError(f"checkpoint file {path}: reason must be a string, got "
                                 f"{reason!r}; delete it and run again to recompute it")
        return {**responses, "reason": reason}

    def _broadcast_read(self, paths: list[Path], n_seeds: int) -> list[dict[str, list] | None]:
        """Process 0 reads (None for files not written yet); every process gets its result
        or its refusal."""

        saved, error = None, None
        if self.lead:
            try:
                saved = [self._read(p, n_seeds) if p.exists() else None for p in paths]
            except ParameterError as e:
                error = str(e)
        saved, error = parallel.broadcast((saved, error))
        if error:
            raise ParameterError(error)
        return saved

    def load_points(self, n: int, n_seeds: int) -> list[dict[str, list] | None]:
        """The saved responses of points ``0..n-1`` (None where not finished yet), as
        process 0 read them."""
        return self._broadcast_read([self._point(q) for q in range(n)], n_seeds)

    def save_point(self, q: int, responses: dict[str, np.ndarray], reason: str = "") -> None:
        """Write point ``q``'s responses and, if some seeds found no path, why."""
        if self.lead:
            _atomic_write_json(self._point(q), {"point": q, "experiment": self.mark,
                                                "responses": _encode(responses),
                                                "reason": reason})

    def _confirm(self, coded: np.ndarray) -> Path:
        return self.dir / ("confirm_" + "_".join(f"{int(c):+d}" for c in coded) + ".json")

    def load_confirmation(self, coded: np.ndarray, n_seeds: int) -> dict[str, list] | None:
        return self._broadcast_read([self._confirm(coded)], n_seeds)[0]

    def save_confirmation(self, coded: np.ndarray, responses: dict[str, np.ndarray]) -> None:
        if self.lead:
            _atomic_write_json(self._confirm(coded), {"coded": [int(c) for c in coded],
                                                      "experiment": self.mark,
                                                      "responses": _encode(responses)})


_INTEGER_RESPONSES = ("convergence_generation", "turns")


_LENGTH_LIKE = ("length", "raw_length", "convergence_generation", "turns", "smoothness")


def _impossible_response(responses: Mapping[str, list], generations: int | None = None
                         ) -> str:
    """What no run can have returned (what :func:`seed_responses` makes of a Result), as
    text naming the response and seed; "" if every value is possible. A success is 0 or
    1; a failed seed has fitness 0 and no length-like value (null); a successful one has
    a fitness >= 0 (+inf when extreme weights overflow float32) and finite length-like
    values >= 0, whole numbers for the generation (at most ``generations``) and the
    turns."""
    for s, ok in enumerate(responses["success"]):
        if ok not in (0, 1):
            return f"success of seed {s} is {ok!r}, not 0 or 1"
        fit = _INFINITIES.get(responses["fitness"][s], responses["fitness"][s])
        if fit is None or math.isnan(fit) or fit < 0 or (fit != 0 and not ok):
            return (f"fitness of seed {s} is {fit!r} for a "
                    f"{'successful' if ok else 'failed'} seed")
        for key in _LENGTH_LIKE:
            v = responses[key][s]
            if isinstance(v, str):  # "inf": only a fitness can overflow
                return f"{key} of seed {s} is {v!r}"
            if not ok:
                if v is not None:
                    return f"{key} of the failed seed {s} is {v!r}, not null"
                continue
            if v is None or not math.isfinite(v) or v < 0 \
                    or (key in _INTEGER_RESPONSES and v != int(v)):
                return f"{key} of seed {s} is {v!r}"
            if key == "convergence_generation" and generations is not None \
                    and v > generations:
                return f"{key} of seed {s} is {v!r}, after the last of {generations}"
    return ""


_INFINITIES = {"inf": math.inf, "-inf": -math.inf}


def _encode(responses: Mapping[str, np.ndarray]) -> dict[str, list]:
    """NaN -> null, +-inf -> "inf" / "-inf" (a fitness can overflow float32 with extreme
    weights); Python floats round-trip exactly through JSON."""
    def one(x: float):
        return ("inf" if x > 0 else "-inf") if math.isinf(x) else json_float(x)

    return {k: [one(float(x)) for x in v] for k, v in responses.items()}


def decode(responses: Mapping[str, list]) -> dict[str, np.ndarray]:
    return {k: np.array([np.nan if x is None else _INFINITIES.get(x, x) for x in v], float)
            for k, v in responses.items() if k in RESPONSES}
