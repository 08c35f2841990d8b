"""waamtwin from Python: plan, simulate and dwell a wire-arc additive build, replay and
calibrate against thermocouples, follow a build while it runs.

One function per command of the ``waamtwin`` program. Each takes a scenario, as a path to its
TOML file, as TOML text, or as a dict of its sections (the same keys; docs/INTERFACE.md), plus
keyword arguments: a dict under a section's name is merged into that section
(``dwell={"confidence": 0.95}``), anything else is one of the command's options
(``baselines=False``). Each returns a :class:`Result`: its tables as dicts of numpy arrays named
as the CSV columns (``r.path["x"]``, ``r.layers["preheat_max_c"]``), its JSON files as dicts
(``r.thermal``, ``r.dwell``, ``r.manifest``), and ``r.write(dir)`` writes exactly the files the
command writes.

A run is the command's own: the same checks, the same numbers, the same files. It lets go of
the GIL while it works (other Python threads go on), calls ``progress(stage, done, total)`` at
most ten times a second, and stops on Ctrl-C (``KeyboardInterrupt``; ``follow`` ends as its
command does, with its outputs). Bad input raises :class:`InputError` (a ``ValueError``) with
the command's message; a numerical failure raises :class:`SimulationError`.
"""

from __future__ import annotations

import itertools
import json
import os
import re
import shutil
import tempfile
import tomllib
import weakref
from pathlib import Path
from typing import Any, Callable, Mapping, Optional, Union

import numpy as np

from . import _native
from ._native import InputError, SimulationError, __version__

__all__ = [
    "InputError",
    "SimulationError",
    "Result",
    "plan",
    "simulate",
    "dwell",
    "replay",
    "calibrate",
    "follow",
    "study",
    "skeleton",
    "export",
    "__version__",
]

Scenario = Union[str, os.PathLike, Mapping[str, Any]]
Progress = Optional[Callable[[str, int, int], Any]]

# A scenario given as text or a dict is written beside the files it names (the working
# directory, or the TOML file's own folder when a file is given with overrides), so that its
# relative paths mean what they mean to the command; the name is removed after the run.
_counter = itertools.count()


class Result:
    """What a command wrote, read back.

    Attributes: ``command`` (its name), ``summary`` (the line the command prints), ``files``
    (the names it wrote, relative to its output folder), ``tables`` (every CSV by its stem, a
    dict of numpy arrays: float64, or str for a text column), ``json`` (every JSON file by its stem).
    A table or JSON file is also an attribute by its stem: ``r.path``, ``r.layers``,
    ``r.thermal``.
    """

    def __init__(self, command: str, summary: str, folder: Path):
        self.command = command
        self.summary = summary
        self._folder = folder
        self.files = _listing(folder)
        self._tables: dict = {}
        self._json: dict = {}
        # The run's temporary folder goes with the result.
        weakref.finalize(self, shutil.rmtree, folder.parent, True)

    def _stems(self, suffix: str) -> list:
        return [f[: -len(suffix)] for f in self.files if f.endswith(suffix) and "/" not in f]

    def table(self, name: str) -> dict:
        """The CSV file ``name`` (with or without ``.csv``) as a dict of columns."""
        stem = name.removesuffix(".csv")
        if stem not in self._tables:
            if stem not in self._stems(".csv"):
                raise KeyError(f"{self.command} wrote no {stem}.csv; it wrote {self.files}")
            columns = _native.read_table(self._folder / f"{stem}.csv")
            # Text columns (a probe's name, a risk) as numpy arrays of str, like the numbers.
            self._tables[stem] = {
                k: (np.asarray(v, dtype=str) if isinstance(v, list) else v)
                for k, v in columns.items()
            }
        return self._tables[stem]

    def json_file(self, name: str) -> dict:
        """The JSON file ``name`` (with or without ``.json``) as a dict."""
        stem = name.removesuffix(".json")
        if stem not in self._json:
            if stem not in self._stems(".json"):
                raise KeyError(f"{self.command} wrote no {stem}.json; it wrote {self.files}")
            with open(self._folder / f"{stem}.json", encoding="utf-8") as f:
                self._json[stem] = json.load(f)
        return self._json[stem]

    @property
    def tables(self) -> dict:
        return {s: self.table(s) for s in self._stems(".csv")}

    @property
    def json(self) -> dict:
        return {s: self.json_file(s) for s in self._stems(".json")}

    def __getattr__(self, name: str):
        if name.startswith("_"):
            raise AttributeError(name)
        if name in self._stems(".csv"):
            return self.table(name)
        if name in self._stems(".json"):
            return self.json_file(name)
        raise AttributeError(
            f"{self.command} wrote no {name}.csv or {name}.json; it wrote {self.files}"
        )

    def path_of(self, name: str) -> Path:
        """Where the file ``name`` lies now (a temporary folder, removed with this result)."""
        return self._folder / name

    def write(self, directory: Union[str, os.PathLike]) -> Path:
        """Write the command's files into ``directory`` (created if missing), each under a
        temporary name first and renamed, as the command writes them."""
        out = Path(directory)
        for name in self.files:
            target = out / name
            target.parent.mkdir(parents=True, exist_ok=True)
            part = target.with_name(f".{target.name}.part")
            shutil.copyfile(self._folder / name, part)
            os.replace(part, target)
        return out

    def __repr__(self) -> str:
        return f"<waamtwin.Result {self.command}: {self.summary!r}, {len(self.files)} files>"


def _listing(folder: Path) -> list:
    """The files under `folder`, relative to it, sorted."""
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


def _merge(base: dict, extra: Mapping) -> dict:
    out = dict(base)
    for key, value in extra.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = _merge(out[key], value)
        else:
            out[key] = value
    return out


def _is_toml_text(s: str) -> bool:
    return "\n" in s or "=" in s


class _ScenarioFile:
    """The scenario as a file the command reads, and what to call it in messages."""

    def __init__(self, scenario: Scenario, sections: Mapping[str, Mapping]):
        self.temporary: Optional[Path] = None
        if isinstance(scenario, (str, os.PathLike)) and not (
            isinstance(scenario, str) and _is_toml_text(scenario)
        ):
            path = Path(scenario)
            if not sections:
                self.path, self.label = path, None
                return
            try:
                with open(path, "rb") as f:
                    table = tomllib.load(f)
            except OSError as e:
                raise InputError(f"{path}: {e.strerror}") from None
            except tomllib.TOMLDecodeError as e:
                raise InputError(f"{path}: {e}") from None
            base, self.label = path.parent, f"{path} (with overrides)"
        elif isinstance(scenario, str):
            try:
                table = tomllib.loads(scenario)
            except tomllib.TOMLDecodeError as e:
                raise InputError(f"<scenario text>: {e}") from None
            base, self.label = Path.cwd(), "<scenario text>"
        elif isinstance(scenario, Mapping):
            table, base, self.label = dict(scenario), Path.cwd(), "<scenario dict>"
        else:
            raise TypeError(
                f"scenario: {type(scenario).__name__}; expected a path, TOML text or a dict"
            )
        text = _native.toml_from_json(json.dumps(_merge(table, sections)))
        self.temporary = base / f".waamtwin-{os.getpid()}-{next(_counter)}.toml"
        self.temporary.write_text(text, encoding="utf-8")
        self.path = self.temporary

    def relabel(self, e: Exception) -> Exception:
        if self.temporary is None or not e.args:
            return e
        # The line numbers are the generated file's, which the user never saw: the field's
        # name that follows them says where.
        message = re.sub(
            re.escape(str(self.temporary)) + r"( line \d+)?", self.label, str(e.args[0])
        )
        return type(e)(message)

    def remove(self):
        if self.temporary is not None:
            self.temporary.unlink(missing_ok=True)


def _flags(command: str, options: Mapping[str, Any], allowed: tuple) -> list:
    flags = []
    for key, value in options.items():
        if key not in allowed:
            raise TypeError(
                f"waamtwin.{command}() got an unexpected option {key!r}; its options are "
                f"{', '.join(allowed) or 'none'}, and sections are given as dicts"
            )
        if value is None or value is False:
            continue
        flag = "--" + key.replace("_", "-")
        if value is True:
            flags.append(flag)
        elif isinstance(value, (list, tuple)):
            flags += [flag, ",".join(str(v) for v in value)]
        else:
            flags += [flag, str(value)]
    return flags


_CHECKPOINTS = ("resume", "checkpoint_every_s")


def _run(command, scenario, kwargs, allowed, progress, extra=()):
    sections = {k: v for k, v in kwargs.items() if isinstance(v, Mapping)}
    options = {k: v for k, v in kwargs.items() if not isinstance(v, Mapping)}
    flags = list(extra) + _flags(command, options, allowed)
    tmp = Path(tempfile.mkdtemp(prefix="waamtwin-"))
    out = tmp / "out"
    source = None
    try:
        source = _ScenarioFile(scenario, sections)
        summary = _native.run([command, str(source.path), "-o", str(out), *flags], progress)
    except (InputError, SimulationError) as e:
        err = source.relabel(e) if source else e
        if command == "study" and (out / "summary.csv").is_file():
            # A study whose cases failed still wrote the rest: the error carries them, and the
            # folder goes with that result (its summary and failed tables).
            err.result = Result(command, str(err), out)
        else:
            shutil.rmtree(tmp, ignore_errors=True)
        raise err from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    finally:
        if source is not None:
            source.remove()
    return Result(command, summary, out)


def plan(scenario: Scenario, *, progress: Progress = None, **kwargs) -> Result:
    """Plan the part: path.csv, plan.json, generators.csv and the recordings
    (``waamtwin plan``). Option: ``strategy`` ("ctpp", "planar", "tube-perpendicular",
    "tube-non-planar")."""
    return _run("plan", scenario, kwargs, ("strategy",), progress)


def simulate(scenario: Scenario, *, progress: Progress = None, **kwargs) -> Result:
    """Plan and heat the build without dwells: thermal.json, layers.csv
    (``waamtwin simulate``). Options: ``resume``, ``checkpoint_every_s``."""
    return _run("simulate", scenario, kwargs, _CHECKPOINTS, progress)


def dwell(scenario: Scenario, *, progress: Progress = None, **kwargs) -> Result:
    """Plan the cooling dwells: dwells.csv, dwell.json and the dwelled run
    (``waamtwin dwell``). Options: ``baselines`` (default True), ``pareto``, ``resume``,
    ``checkpoint_every_s``."""
    baselines = kwargs.pop("baselines", True)
    extra = [] if baselines else ["--no-baselines"]
    return _run("dwell", scenario, kwargs, ("pareto",) + _CHECKPOINTS, progress, extra)


def replay(scenario: Scenario, *, progress: Progress = None, **kwargs) -> Result:
    """Replay a logged build (or a planned path.csv) against its probes: probes.csv,
    replay.json, or simulate's files for a plan (``waamtwin replay``). Options: ``resume``,
    ``checkpoint_every_s``."""
    return _run("replay", scenario, kwargs, _CHECKPOINTS, progress)


def calibrate(scenario: Scenario, *, progress: Progress = None, **kwargs) -> Result:
    """Fit a replay's parameters to its probes: calibration.json, probes.csv
    (``waamtwin calibrate``). Options: ``fit`` and ``holdout`` as (t0_s, t1_s), ``resume``,
    ``checkpoint_every_s``."""
    extra = []
    for key in ("fit", "holdout"):
        window = kwargs.pop(key, None)
        if window is not None:
            t0, t1 = window
            extra += [f"--{key}", f"{float(t0)}:{float(t1)}"]
    return _run("calibrate", scenario, kwargs, _CHECKPOINTS, progress, extra)


def follow(scenario: Scenario, *, progress: Progress = None, **kwargs) -> Result:
    """Follow a build while it runs: forecasts.csv, assimilation.csv, alarms.csv,
    follow.json (``waamtwin follow``). Options: ``until_idle_s``, ``connect`` (a rerun
    viewer's URL), ``resume``, ``checkpoint_every_s``."""
    return _run("follow", scenario, kwargs, ("until_idle_s", "connect") + _CHECKPOINTS, progress)


def study(study: Scenario, *, progress: Progress = None, **kwargs) -> Result:
    """A what-if study: summary.csv and one folder per case (``waamtwin study``). ``study``
    is the study's TOML (path, text or dict). Options: ``jobs``, ``shard`` ("I/N"). Where
    cases fail the error raised carries the rest as ``e.result``: ``e.result.table("summary")``
    the finished cases, ``e.result.failed`` the failed ones with their messages."""
    return _run("study", study, kwargs, ("jobs", "shard"), progress)


def skeleton(scenario: Scenario, *, progress: Progress = None, **kwargs) -> Result:
    """Skeleton arc AM, drop by drop: drops.csv, loops.csv, path.csv, skeleton.json
    (``waamtwin skeleton``)."""
    return _run("skeleton", scenario, kwargs, (), progress)


def export(
    run: Union[Result, str, os.PathLike],
    format: str,
    *,
    pivot_mm=None,
    part_offset_mm=None,
    tilt_limits_deg=None,
    min_move_mm=None,
    rotary_rpm_max=None,
    tilt_rpm_max=None,
) -> str:
    """The machine program of a planned run (a :class:`Result` of plan, simulate or dwell, or
    its folder): program.json, .mod (ABB RAPID), .src (KUKA KRL) or .nc (G-code), written
    beside its path.csv (``waamtwin export``); returns the command's line. ``format``: "json",
    "rapid", "krl" or "gcode"; ``min_move_mm``: the shortest move kept (default 0.1; 0 keeps
    every path point); ``rotary_rpm_max``, ``tilt_rpm_max``: G-code's table's top speeds, rpm
    (moves that ask more are warned of on stderr)."""
    folder = run.path_of("") if isinstance(run, Result) else Path(run)
    flags = ["--format", format]
    for flag, value in (
        ("--min-move-mm", min_move_mm),
        ("--rotary-rpm-max", rotary_rpm_max),
        ("--tilt-rpm-max", tilt_rpm_max),
    ):
        if value is not None:
            flags += [flag, str(float(value))]
    for key, value in (
        ("pivot_mm", pivot_mm),
        ("part_offset_mm", part_offset_mm),
        ("tilt_limits_deg", tilt_limits_deg),
    ):
        if value is not None:
            flags += ["--" + key.replace("_", "-"), ",".join(str(float(v)) for v in value)]
    line = _native.run(["export", str(folder), *flags], None)
    if isinstance(run, Result):
        run.files = _listing(folder)
    return line
