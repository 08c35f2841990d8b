"""waamtwin from Python: one function per command of the ``waamtwin`` program.

Each takes a scenario (a TOML path, TOML text, or a dict of its sections), section overrides
as dicts under the section's name, and the command's options; each returns a :class:`Result`.
"""

from os import PathLike
from pathlib import Path
from typing import Any, Callable, Mapping, Optional, Sequence, Union

import numpy as np

from ._native import InputError as InputError, SimulationError as SimulationError

__version__: str

Scenario = Union[str, PathLike[str], Mapping[str, Any]]
Progress = Optional[Callable[[str, int, int], Any]]
Table = dict[str, np.ndarray]

class Result:
    """What a command wrote, read back; a table or JSON file is also an attribute by its stem
    (``r.path``, ``r.layers``, ``r.thermal``, ``r.dwell``, ``r.manifest``, ``r.probes``)."""

    command: str
    summary: str
    files: list[str]
    @property
    def tables(self) -> dict[str, Table]: ...
    @property
    def json(self) -> dict[str, Any]: ...
    def table(self, name: str) -> Table:
        """The CSV file ``name`` (with or without ``.csv``) as a dict of columns."""
    def json_file(self, name: str) -> Any:
        """The JSON file ``name`` (with or without ``.json``) as a dict."""
    def path_of(self, name: str) -> Path:
        """Where the file ``name`` lies now (removed with this result)."""
    def write(self, directory: Union[str, PathLike[str]]) -> Path:
        """Write the command's files into ``directory``, each renamed into place."""
    def __getattr__(self, name: str) -> Any: ...

def plan(
    scenario: Scenario, *, progress: Progress = None, strategy: Optional[str] = None, **sections: Mapping[str, Any]
) -> Result:
    """Plan the part: path.csv, plan.json, generators.csv (``waamtwin plan``)."""

def simulate(
    scenario: Scenario,
    *,
    progress: Progress = None,
    resume: bool = False,
    checkpoint_every_s: Optional[float] = None,
    **sections: Mapping[str, Any],
) -> Result:
    """Plan and heat the build without dwells: thermal.json, layers.csv (``waamtwin simulate``)."""

def dwell(
    scenario: Scenario,
    *,
    progress: Progress = None,
    baselines: bool = True,
    pareto: bool = False,
    resume: bool = False,
    checkpoint_every_s: Optional[float] = None,
    **sections: Mapping[str, Any],
) -> Result:
    """Plan the cooling dwells: dwells.csv, dwell.json and the dwelled run (``waamtwin dwell``)."""

def replay(
    scenario: Scenario,
    *,
    progress: Progress = None,
    resume: bool = False,
    checkpoint_every_s: Optional[float] = None,
    **sections: Mapping[str, Any],
) -> Result:
    """Replay a logged build or a planned path.csv: probes.csv, replay.json (``waamtwin replay``)."""

def calibrate(
    scenario: Scenario,
    *,
    progress: Progress = None,
    fit: Optional[Sequence[float]] = None,
    holdout: Optional[Sequence[float]] = None,
    resume: bool = False,
    checkpoint_every_s: Optional[float] = None,
    **sections: Mapping[str, Any],
) -> Result:
    """Fit a replay's parameters to its probes: calibration.json, probes.csv (``waamtwin calibrate``)."""

def follow(
    scenario: Scenario,
    *,
    progress: Progress = None,
    until_idle_s: Optional[float] = None,
    connect: Optional[str] = None,
    resume: bool = False,
    checkpoint_every_s: Optional[float] = None,
    **sections: Mapping[str, Any],
) -> Result:
    """Follow a build while it runs: forecasts.csv, assimilation.csv (``waamtwin follow``)."""

def study(
    study: Scenario,
    *,
    progress: Progress = None,
    jobs: Optional[int] = None,
    shard: Optional[str] = None,
    **sections: Mapping[str, Any],
) -> Result:
    """A what-if study: summary.csv and one folder per case (``waamtwin study``)."""

def skeleton(scenario: Scenario, *, progress: Progress = None, **sections: Mapping[str, Any]) -> Result:
    """Skeleton arc AM, drop by drop: drops.csv, loops.csv, skeleton.json (``waamtwin skeleton``)."""

def export(
    run: Union[Result, str, PathLike[str]],
    format: str,
    *,
    pivot_mm: Optional[Sequence[float]] = None,
    part_offset_mm: Optional[Sequence[float]] = None,
    tilt_limits_deg: Optional[Sequence[float]] = None,
) -> str:
    """The machine program of a planned run: program.json/.mod/.src/.nc (``waamtwin export``)."""
