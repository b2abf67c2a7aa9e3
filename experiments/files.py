"""Output files written whole or not at all, and the report of what a run wrote.

Every command that writes files writes each through :func:`replacing`: the content goes
to a temporary file in the same folder, which is renamed over the target (``os.replace``,
atomic on POSIX and Windows within one file system) only once it is complete. A write
that fails (a full disk, an interrupt, an error while formatting) removes the temporary
file and leaves the earlier file, if any, as it was; a reader never sees half a file.

:func:`stale` finds the files an earlier run left in an output folder that this run did
not write (``repro --fig 13`` after a full run), so a command can remove or list them;
:func:`replacing` remembers which files it wrote over one of an earlier run, so that
:func:`say_written` says how many a run replaced.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from . import progress


def folder(text: str) -> str:
    """An argparse type for every command's ``--out``: an output folder, refused with
    one line when empty or blank (an empty path would write into the current folder).
    """
    if not text.strip():
        raise argparse.ArgumentTypeError(f"expected an output folder, got {text!r} (an "
                                         "empty path would be the current folder)")
    return text


_FOUND: dict[Path, bool] = {}
"""Each file :func:`replacing` wrote since the last :func:`say_written` (its resolved
path) and whether a file was there before its first write: one of an earlier run, which
this run replaced."""


@contextlib.contextmanager
def replacing(path: Path | str, mode: str = "w", **options) -> Iterator:
    """An open file whose content replaces ``path`` when the block ends without error
    (``mode`` ``"w"`` text or ``"wb"`` binary; ``options`` as for :func:`open`, e.g.
    ``newline=""`` for CSV). The folder must exist. On an error the earlier ``path`` is
    untouched and the partial temporary file removed.
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"mode {mode!r}: only 'w' and 'wb' replace a file")
    path = Path(path)
    _FOUND.setdefault(path.resolve(), path.is_file())
    if mode == "w":
        options.setdefault("encoding", "utf-8")
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.",
                                         suffix=".part")
    try:
        with open(handle, mode, **options) as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.chmod(temporary, NEW_FILE_MODE)
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise


def _umask() -> int:
    """The process's umask (read once, at import: setting it to read it is not safe
    while other threads create files).
    """
    umask = os.umask(0o022)
    os.umask(umask)
    return umask


NEW_FILE_MODE = 0o666 & ~_umask()
"""Permissions a plain ``open`` gives a new file; ``mkstemp`` makes its files private,
an output file is not."""


def write_text(path: Path | str, text: str) -> Path:
    """``text`` into ``path`` (UTF-8), atomically (:func:`replacing`); the path."""
    with replacing(path) as f:
        f.write(text)
    return Path(path)


def savez(path: Path | str, **arrays) -> Path:
    """``numpy.savez`` of ``arrays`` into ``path``, atomically (:func:`replacing`)."""
    import numpy as np

    with replacing(path, "wb") as f:
        np.savez(f, **arrays)
    return Path(path)


def stale(folder: Path | str, written: Iterable[Path | str],
          patterns: Iterable[str]) -> list[Path]:
    """Files in ``folder`` matching any of the glob ``patterns`` that are not among
    ``written``: what an earlier run left there that this run did not produce.
    """
    mine = {Path(p).resolve() for p in written}
    found = {p for pattern in patterns for p in Path(folder).glob(pattern) if p.is_file()}
    return sorted(p for p in found if p.resolve() not in mine)


LISTED = 8
"""Most files :func:`say_written` names one by one (more: their count)."""


def say_written(command: str, paths: Iterable[Path | str], removed: Iterable[Path | str] = (),
                note: str = "") -> None:
    """One line on stderr naming where ``command`` wrote (its folder when every path
    shares one), how many of ``paths`` replaced a file of an earlier run (:data:`_FOUND`,
    which this call empties: the run's writes are said), which files of an earlier run
    it ``removed``, and a ``note`` (e.g. what a resumed run found); none with
    ``--quiet``.
    """
    paths, removed = [Path(p) for p in paths], [Path(p) for p in removed]
    replaced = sum(_FOUND.get(p.resolve(), False) for p in paths)
    _FOUND.clear()
    if not paths or progress.quiet():
        return
    folders = {p.parent for p in paths}
    names = ", ".join(p.name for p in paths) if len(paths) <= LISTED else f"{len(paths)} files"
    where = f"{folders.pop()}/ ({names})" if len(folders) == 1 \
        else ", ".join(str(p) for p in paths)
    again = f" (replacing {replaced} file{'s' * (replaced != 1)} of an earlier run)" \
        if replaced else ""
    gone = f"; removed an earlier run's {', '.join(p.name for p in removed)}" if removed \
        else ""
    note = f"; {note}" if note else ""
    print(f"cardan {command}: wrote {where}{again}{gone}{note}", file=sys.stderr)
