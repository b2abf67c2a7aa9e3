"""What a report states about where it ran: CPU, platform, package versions; and
numbers made safe to print (text, Markdown, CSV) and to write as JSON.
"""

from __future__ import annotations

import importlib.metadata
import math
import os
import platform
from pathlib import Path

from cardan_forces.solvers import available


def machine() -> str:
    """CPU model, logical CPUs, platform and Python version, in one line."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (f"{cpu}, {os.cpu_count()} logical CPUs, {platform.platform()}, "
            f"Python {platform.python_version()}")


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


def json_number(value: float) -> float | str:
    """A JSON-safe float: ``inf``/``nan`` as strings, read back with ``float()``."""
    value = float(value)
    return value if math.isfinite(value) else str(value)


def number_text(value: float | None, spec: str, undefined: str = "-") -> str:
    """``value`` formatted by ``spec``, or ``undefined`` where it is not a finite number
    (a failed record's residual, a peak over no solved instant, a missing reference):
    tables and Markdown show ``-`` (right-aligned in the width ``spec`` asks for), CSV
    cells pass ``undefined=""`` (an empty cell). Never prints ``inf`` or ``nan``.
    """
    if value is not None and math.isfinite(float(value)):
        return format(value, spec)
    padded = format(math.inf, spec)  # the width spec asks for, if any
    return undefined.rjust(len(padded)) if padded.startswith(" ") else undefined
