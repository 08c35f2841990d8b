"""Execute the example notebooks as a reader would (nbclient, a fresh kernel each, from the
repository root) and keep what they showed: the executed notebooks and their plots in OUT.

    python examples/run.py OUT

A notebook checks its own results (its assert cells); a failing cell fails the run, naming
the notebook and the cell."""

import os
import sys
from pathlib import Path

import nbformat
from nbclient import NotebookClient
from nbclient.exceptions import CellExecutionError

ROOT = Path(__file__).resolve().parent.parent


def main(out: Path) -> int:
    out.mkdir(parents=True, exist_ok=True)
    os.environ["WAAMTWIN_NOTEBOOK_OUT"] = str(out.resolve())
    failed = 0
    for path in sorted((ROOT / "examples").glob("*.ipynb")):
        nb = nbformat.read(path, as_version=4)
        client = NotebookClient(
            nb, timeout=1200, kernel_name="python3", resources={"metadata": {"path": str(ROOT)}}
        )
        try:
            client.execute()
            print(f"{path.name}: ran, {len(nb.cells)} cells")
        except CellExecutionError as e:
            failed += 1
            print(f"{path.name}: failed\n{e}", file=sys.stderr)
        nbformat.write(nb, out / path.name)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1] if len(sys.argv) > 1 else "out/notebooks")))
