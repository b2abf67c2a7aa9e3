"""Regenerate the Benchmarks page's data: one ``cardan bench`` run, with where and when.

    python docs/bench_data.py            # cardan bench --quick (the page's default)
    python docs/bench_data.py --full     # the whole bench (longer)

Writes ``docs/data/bench.json``: the run's ``--json`` summary, the command, the UTC date,
the machine (CPU, load, platform), the package's and the solvers' versions. The page
``docs/benchmarks.md`` is generated from this file when the site is built.
"""

from __future__ import annotations

import argparse
import datetime
import json
import subprocess
import sys
import tempfile
from importlib import metadata
from pathlib import Path

from cardan_forces.experiments.environment import machine, threads, versions

DATA = Path(__file__).parent / "data" / "bench.json"

OMITTED = ("profiles",)
"""Parts of the summary the page does not show (the profiles' curves: the bulk of it)."""


def run_bench(full: bool) -> dict:
    """One ``cardan bench`` run's JSON summary with its circumstances."""
    command = ["bench", "--json", "--quiet"] + ([] if full else ["--quick"])
    with tempfile.TemporaryDirectory() as folder:
        done = subprocess.run([sys.executable, "-m", "cardan_forces.cli", *command,
                               "--out", folder], capture_output=True, text=True, check=True)
    return {
        "command": "cardan " + " ".join(c for c in command if c not in ("--json", "--quiet")),
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "machine": machine(),
        "threads": threads(),
        "versions": versions(),
        "cardan_forces": metadata.version("cardan-forces"),
        "results": {k: v for k, v in json.loads(done.stdout).items() if k not in OMITTED},
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--full", action="store_true", help="the whole bench, not --quick")
    data = run_bench(parser.parse_args().full)
    DATA.write_text(json.dumps(data, indent=1) + "\n")
    print(f"wrote {DATA}")


if __name__ == "__main__":
    main()
