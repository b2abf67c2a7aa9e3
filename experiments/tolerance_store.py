"""The store of ``cardan tolerances``: its samples in ``samples.jsonl``, appended as they
finish, the rules of the sweep's store (:mod:`.sweep_store`) for a sample instead of a
row.

The first line names the study (scene, seed, instants, formulations and the scene's
tolerances); each further line is one sample, written in one flushed write, so a
killed study loses only the samples in flight and a rerun computes only the samples
the file lacks. A last line cut short by the kill is dropped (and the file rewritten
without it); a sample index met twice is read once (the first). A file of another
study, or one that is not a sample file, is refused with one line naming it, never
half-read.
"""

from __future__ import annotations

import json
from pathlib import Path

from cardan_forces.experiments import files
from cardan_forces.experiments.environment import json_safe
from cardan_forces.experiments.sweep_store import StoreError, complete_lines

NAME = "samples.jsonl"
"""The store's file name inside ``--out``."""


def line(value: dict) -> str:
    """One line of strict JSON (non-finite numbers as ``null``)."""
    return json.dumps(json_safe(value), allow_nan=False, separators=(",", ":")) + "\n"


def read(path: Path, study: dict) -> dict[int, dict]:
    """The samples already in ``path`` by index (none if it is absent); ``study`` must
    equal the file's first line (:class:`StoreError` otherwise).
    """
    if not path.exists():
        return {}
    whole, cut = complete_lines(path, "sample file")
    lines = whole.splitlines()
    try:
        head = json.loads(lines[0]) if lines else None
        samples = [json.loads(one) for one in lines[1:]]
    except json.JSONDecodeError as err:
        raise StoreError(f"{path}: not a sample file ({err.msg}); choose another --out or "
                         "remove it") from None
    if head != {"study": json_safe(study)}:
        raise StoreError(f"{path} holds another study (scene, seed, instants or tolerances "
                         "differ); choose another --out or remove it")
    found = {}
    for sample in samples:
        if not isinstance(sample, dict) or not isinstance(sample.get("index"), int):
            raise StoreError(f"{path}: a line that is not a sample; choose another --out")
        found.setdefault(sample["index"], sample)
    if cut:  # the file rewritten whole, without the line cut short
        files.write_text(path, whole)
    return found


def opened(path: Path, study: dict):
    """``path`` open for appending, its first line written if it is new."""
    path.parent.mkdir(parents=True, exist_ok=True)
    new = not path.exists() or path.stat().st_size == 0
    f = open(path, "a", encoding="utf-8")
    if new:
        f.write(line({"study": study}))
        f.flush()
    return f


def append(f, sample: dict) -> None:
    """One sample, in one flushed write."""
    f.write(line(sample))
    f.flush()
