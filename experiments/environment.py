"""What a report states about where it ran: CPU, platform, package versions; and
numbers made safe to print (text, Markdown, CSV) and to write as JSON.
"""

from __future__ import annotations

import importlib.metadata
import json
import math
import os
import platform
from pathlib import Path

import numpy as np
from cardan_forces.solvers import available


def machine() -> str:
    """CPU model, logical CPUs, the load average (1, 5, 15 min: other processes' share
    of the CPUs during a timed run), platform and Python version, in one line.
    """
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        load = ", load average {:.1f} {:.1f} {:.1f}".format(*os.getloadavg())
    except (AttributeError, OSError):  # not on this platform
        load = ""
    return (f"{cpu}, {os.cpu_count()} logical CPUs{load}, {platform.platform()}, "
            f"Python {platform.python_version()}")


def threads() -> str:
    """The threads a timed run uses: one BLAS/OpenMP thread per process (the commands
    set it), and numba's for the batches of the ``newton`` family and of
    ``reduced-ipm``.
    """
    try:
        import numba
    except ImportError:
        return "one BLAS/OpenMP thread; numba not installed"
    return (f"one BLAS/OpenMP thread; the newton family's and reduced-ipm's batches on "
            f"{numba.get_num_threads()} numba threads")


def versions() -> str:
    """Installed versions of NumPy, SciPy, the distributions every available backend
    declares it runs on, and Matplotlib.
    """
    found = []
    declared = [d for backend in available().values() for d in backend.distributions]
    for dist in dict.fromkeys(("numpy", "scipy", *declared, "matplotlib")):
        try:
            found.append(f"{dist} {importlib.metadata.version(dist)}")
        except importlib.metadata.PackageNotFoundError:
            continue
    return ", ".join(found)


def json_number(value: float) -> float | None:
    """A JSON-safe float: ``None`` (JSON ``null``) where ``value`` is not finite (the
    record's status or the row's message says why).
    """
    value = float(value)
    return value if math.isfinite(value) else None


def json_safe(value):
    """``value`` (dicts, lists, tuples, NumPy arrays and scalars) as plain JSON types,
    every number that is not finite as ``None``.
    """
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [json_safe(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return json_number(value)
    return value


def json_text(value) -> str:
    """The package's one JSON encoder: strict JSON (no ``NaN``/``Infinity``), indented,
    non-finite numbers as ``null``; what every ``--json`` output prints.
    """
    return json.dumps(json_safe(value), indent=2, allow_nan=False)


def number_text(value: float | None, spec: str, undefined: str = "-") -> str:
    """``value`` formatted by ``spec``, or ``undefined`` where it is not a finite number
    (a failed record's residual, a peak over no solved instant, a missing reference):
    tables and Markdown show ``-`` (right-aligned in the width ``spec`` asks for), CSV
    cells pass ``undefined=""`` (an empty cell). Never prints ``inf`` or ``nan``, nor a
    negative zero (``-0.0000`` for ``-1e-7`` at four decimals is ``0.0000``).
    """
    if value is not None and math.isfinite(float(value)):
        text = format(value, spec)
        return format(0.0, spec) if text.lstrip().startswith("-") and _zero(text) else text
    padded = format(math.inf, spec)  # the width spec asks for, if any
    return undefined.rjust(len(padded)) if padded.startswith(" ") else undefined


def _zero(text: str) -> bool:
    try:
        return float(text) == 0.0
    except ValueError:
        return False
