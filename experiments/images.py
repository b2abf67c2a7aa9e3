"""Image files of the figure commands (``cardan repro``, ``cardan report``): the formats
they write and the one way a figure is saved in each (``--format png,svg,pdf``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

FORMATS = ("png", "svg", "pdf")
"""Image formats a figure can be written in."""


def format_list(text: str) -> tuple[str, ...]:
    """``--format``'s value: comma-separated formats of :data:`FORMATS`, order kept,
    repeats dropped (an argparse type: anything else is one usage error).
    """
    words = tuple(dict.fromkeys(w.strip().lower() for w in text.split(",") if w.strip()))
    bad = [w for w in words if w not in FORMATS]
    if bad or not words:
        raise argparse.ArgumentTypeError(
            f"{'unknown ' + ', '.join(bad) if bad else 'empty'}; choose among "
            f"{','.join(FORMATS)}")
    return words


def save(fig, stem: Path, formats=("png",), dpi: int = 110) -> list[Path]:
    """Write ``fig`` as ``stem.<format>`` for each of ``formats``; their paths."""
    paths = [stem.with_suffix(f".{fmt}") for fmt in formats]
    for path in paths:
        fig.savefig(path, dpi=dpi)
    return paths
