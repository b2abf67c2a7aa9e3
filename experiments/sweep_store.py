"""The store of ``cardan sweep``: its rows in ``sweep.csv``, appended as points finish.

Each finished point's rows are appended in one flushed write, so a killed sweep loses
only the points in flight and a rerun computes only the rows the CSV lacks. Cells are
written and read by the type of the :class:`~.sweep_point.Row` field they hold (not by
their column names); an undefined number (``inf``, NaN) is an empty cell. A file that
is not a sweep CSV (not UTF-8 text, other columns, a cell that does not read as its
field's type) is refused with one line naming it, never half-read.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import io
import math
from pathlib import Path

import numpy as np
from cardan_forces.experiments.environment import number_text
from cardan_forces.solvers import Status

from . import files
from .sweep_point import KEY, Row, SweepError

COLUMNS = tuple(f.name for f in dataclasses.fields(Row))
FORMATS = {"max_equilibrium": ".2e", "simulate_s": ".4g", "solve_s": ".4g", "total_s": ".4g"}
"""CSV number formats other than 10 significant digits."""

MESSAGE_CHARS = 300
"""A row's message is kept to one line of at most this many characters."""


class StoreError(SweepError):
    """An existing store (``sweep.csv``, a study's samples) that cannot be read back, or
    of another study (exit code 2).
    """


def complete_lines(path: Path, what: str) -> tuple[str, bool]:
    """A store's text up to its last complete line, and whether a line was cut short
    (by a run killed while appending); :class:`StoreError` if it is not text (``what``:
    the kind of file, for the message).
    """
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        raise StoreError(f"{path} is not a {what} (not UTF-8 text); choose another --out "
                         "or remove it") from None
    whole = text if text.endswith("\n") else text[: text.rfind("\n") + 1]
    return whole, whole != text


def spell(value, spec: str = ".10g") -> str:
    """How the CSV spells a value: numbers to 10 significant digits unless ``spec`` says
    otherwise, an empty cell where undefined (``inf``/``nan``).
    """
    if isinstance(value, Status):
        return value.value
    if isinstance(value, str):
        return value
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    return number_text(float(value), spec, "")


def number(cell: str) -> float:
    """A number cell read back: NaN for an empty (undefined) cell."""
    return float(cell) if cell else math.nan


READERS = {"str": str, "int": int, "float": number, "Status": Status}
"""Cell readers by the annotation of a :class:`Row` field."""


def key_of(row: Row) -> tuple[str, ...]:
    """The row's key as the CSV spells it."""
    return tuple(spell(getattr(row, k)) for k in KEY)


def cells(row: Row) -> dict[str, str]:
    """The CSV cells of ``row``."""
    out = {k: spell(getattr(row, k), FORMATS.get(k, ".10g")) for k in COLUMNS}
    out["message"] = " ".join(row.message.split())[:MESSAGE_CHARS]
    return out


def parse(record: dict[str, str]) -> Row:
    """A CSV record as a :class:`Row` (ValueError if a cell is not its field's type)."""
    return Row(**{f.name: READERS[f.type](record[f.name]) for f in dataclasses.fields(Row)})


def read_rows(path: Path) -> list[Row]:
    """The rows of an existing ``sweep.csv`` (none if absent). A line cut short by a
    killed sweep, and a second row of a key already stored (the first is kept), are
    dropped and the file rewritten without them; anything else that is not a sweep CSV
    is a :class:`StoreError`.
    """
    if not path.exists():
        return []
    whole, cut = complete_lines(path, "sweep CSV")
    reader = csv.DictReader(io.StringIO(whole))
    try:
        if reader.fieldnames is not None and tuple(reader.fieldnames) != COLUMNS:
            raise StoreError(f"{path} was written with other columns; choose another --out")
        records = [r for r in reader if None not in r and None not in r.values()]
        unique: dict[tuple[str, ...], Row] = {}
        for row in map(parse, records):
            unique.setdefault(key_of(row), row)
        rows = list(unique.values())
    except (csv.Error, ValueError) as err:
        if isinstance(err, StoreError):
            raise
        raise StoreError(f"{path}, line {reader.line_num}: not a sweep row ({err}); choose "
                         "another --out or remove it") from None
    if cut or len(rows) != whole.count("\n") - 1:
        with files.replacing(path, newline="") as f:
            append(f, rows, header=True)
    return rows


@contextlib.contextmanager
def locked(folder: Path):
    """Hold ``folder``'s sweep for this process (an advisory lock on ``.sweep.lock``
    where the system has ``flock``): a second sweep into the same folder while one runs
    is a :class:`StoreError` instead of a second writer computing the same rows.
    """
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock
        yield
        return
    with open(folder / ".sweep.lock", "a") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise StoreError(f"another cardan sweep is writing into {folder}; wait for it "
                             "to end (a rerun then resumes) or choose another --out") from None
        except OSError:  # a file system without locks (some network mounts): run unheld
            pass
        yield


def append(f, rows: list[Row], header: bool = False) -> None:
    """Append ``rows`` (and the header) to ``f`` in one write, flushed: an interrupt
    lands before or after a point's rows, never inside a line.
    """
    text = io.StringIO()
    w = csv.DictWriter(text, COLUMNS, lineterminator="\n")
    if header:
        w.writeheader()
    w.writerows(cells(row) for row in rows)
    f.write(text.getvalue())
    f.flush()
