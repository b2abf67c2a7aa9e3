"""The store of ``cardan tolerances``: its samples in ``samples.jsonl``, appended as they
finish, the rules of the sweep's store (:mod:`.sweep_store`) for a sample instead of a
row.

The first line names the study (the scene's name and the SHA-256 of its content, seed,
instants, formulations and the scene's tolerances); each further line is one sample,
written in one flushed write, so a killed study loses only the samples in flight and a
rerun computes only the samples the file lacks. A last line cut short by the kill is
dropped (and the file rewritten without it); an empty file is a new store; a sample
index met twice is read once (the first). A file of another study (an edited scene
among them), or a line that is not one of this study's samples (not JSON, a part
missing, loads of another length or other names, a value of another type), is refused
with one line naming the file and the line, never half-read.
"""

from __future__ import annotations

import json
from pathlib import Path

from cardan_forces.experiments import files
from cardan_forces.experiments.environment import json_safe
from cardan_forces.experiments.sweep_store import StoreError, complete_lines

NAME = "samples.jsonl"
"""The store's file name inside ``--out``."""

PARTS = ("loads", "L10_Mrev", "solved", "outside")
"""A sample's parts, each with one entry per formulation."""


def line(value: dict) -> str:
    """One line of strict JSON (non-finite numbers as ``null``)."""
    return json.dumps(json_safe(value), allow_nan=False, separators=(",", ":")) + "\n"


def read(path: Path, study: dict, names: dict[str, list[str]]) -> dict[int, dict]:
    """The samples already in ``path`` by index (none if it is absent or empty);
    ``study`` must equal the file's first line and every sample must be one of its
    samples, with ``names["loads"]`` and ``names["L10_Mrev"]`` its loads and lives
    (:class:`StoreError` otherwise).
    """
    if not path.exists():
        return {}
    whole, cut = complete_lines(path, "sample file")
    lines = whole.splitlines()
    if lines:
        _check_head(path, _parsed(path, 1, lines[0]), study)
    found = {}
    for number, text in enumerate(lines[1:], 2):
        sample = _parsed(path, number, text)
        why = fault(sample, study, names)
        if why:
            raise StoreError(f"{path}, line {number}: not a sample of this study ({why}); "
                             "remove that line (a rerun computes its sample again) or "
                             "choose another --out")
        found.setdefault(sample["index"], sample)
    if cut:  # the file rewritten whole, without the line cut short
        files.write_text(path, whole)
    return found


def _parsed(path: Path, number: int, text: str):
    """Line ``number`` of ``path`` read as JSON (:class:`StoreError` if it is not)."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as err:
        raise StoreError(f"{path}, line {number}: not JSON ({err.msg}); not a sample file, "
                         "choose another --out or remove it") from None


def _check_head(path: Path, head, study: dict) -> None:
    """The first line names ``study`` (:class:`StoreError` naming what differs if not)."""
    if not (isinstance(head, dict) and isinstance(head.get("study"), dict)):
        raise StoreError(f"{path}, line 1: names no study; not a sample file, choose "
                         "another --out or remove it")
    stored, wanted = head["study"], json_safe(study)
    differ = [k for k in wanted if stored.get(k) != wanted[k]] + \
        [k for k in stored if k not in wanted]
    if differ:
        raise StoreError(f"{path} holds another study (its {', '.join(differ)} differ from "
                         "this run's: another scene or scene content, seed, instants or "
                         "tolerances); choose another --out or remove it")


def fault(sample, study: dict, names: dict[str, list[str]]) -> str | None:
    """Why ``sample`` (one parsed line) is not a sample of ``study`` whose loads and
    lives are ``names``; ``None`` if it is one.
    """
    if not isinstance(sample, dict):
        return "not a JSON object"
    if not _whole(sample.get("index")):
        return "'index' is not a whole number >= 0"
    forms = study["formulations"]
    for part in PARTS:
        entries = sample.get(part)
        if not isinstance(entries, dict) or sorted(entries) != sorted(forms):
            return f"'{part}' does not hold one entry for each of {', '.join(forms)}"
        for form, entry in entries.items():
            why = _entry_fault(part, entry, study["instants"], names)
            if why:
                return f"'{part}' of {form}: {why}"
    return None


def _entry_fault(part: str, entry, instants: int, names: dict[str, list[str]]) -> str | None:
    """Why one formulation's ``part`` of a sample is not what a sample holds."""
    if part in ("solved", "outside"):
        if not _whole(entry):
            return "not a whole number >= 0"
        return f"{entry} instants of {instants}" if part == "solved" and entry > instants \
            else None
    if not isinstance(entry, dict) or set(entry) != set(names[part]):
        return f"not the scene's {len(names[part])} named values"
    for name, value in entry.items():
        values = value if part == "loads" else [value]
        if part == "loads" and not (isinstance(value, list) and len(value) == instants):
            return f"{name} is not a list of {instants} values (one per instant)"
        if not all(_number(v) for v in values):
            return f"{name} holds a value that is not a number"
    return None


def _whole(value) -> bool:
    """``value`` is a whole number at least 0 (not a boolean)."""
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


def _number(value) -> bool:
    """``value`` is a number or ``None`` (an undefined one), not a boolean."""
    return value is None or (isinstance(value, (int, float)) and not isinstance(value, bool))


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
