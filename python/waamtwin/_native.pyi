"""The Rust extension under the waamtwin package (pyo3). Use the functions of ``waamtwin``."""

from os import PathLike
from typing import Any, Callable, Optional, Union

import numpy as np

__version__: str

class InputError(ValueError):
    """Bad input: a scenario, a file, a field or a value (the command's exit code 2)."""

    # A study whose cases failed: what the others wrote (``waamtwin.Result``).
    result: Any

class SimulationError(RuntimeError):
    """A failure the input did not cause: a numerical breakdown, a full disk (exit code 1)."""

    result: Any

def run(argv: list[str], progress: Optional[Callable[[str, int, int], Any]] = None) -> str:
    """Run ``waamtwin ARGV...`` and return the line it prints."""

def toml_from_json(json: str) -> str:
    """A scenario given as JSON, as TOML text."""

def read_table(path: Union[str, PathLike[str]]) -> dict[str, Union[np.ndarray, list[str]]]:
    """A CSV file as a dict of its columns (float64 arrays; text columns as lists of str)."""
