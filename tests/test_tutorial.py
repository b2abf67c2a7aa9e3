"""The tutorial's steps, read from docs/tutorial.md and run in order in one folder: each
``bash`` block must succeed, and every line of the ``text`` block after it must appear
in what the block printed (stdout and stderr), so the page cannot drift from the package.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

TUTORIAL = Path(__file__).resolve().parent.parent / "docs" / "tutorial.md"
BLOCK = re.compile(r"```(bash|text)\n(.*?)```", re.S)

# `cardan` as this interpreter runs it, whatever is on PATH
PRELUDE = f'cardan() {{ "{sys.executable}" -m cardan_forces.cli "$@"; }}\nset -e\n'


def steps() -> list[tuple[str, list[str]]]:
    """``(commands, expected lines)`` for each bash block, in page order."""
    found: list[tuple[str, list[str]]] = []
    for kind, body in BLOCK.findall(TUTORIAL.read_text()):
        if kind == "bash":
            found.append((body, []))
        elif found:
            found[-1][1].extend(line.strip() for line in body.splitlines() if line.strip())
    return found


def test_the_tutorial_has_steps_with_checked_output():
    found = steps()
    assert len(found) >= 6
    assert sum(bool(expected) for _, expected in found) == len(found)


@pytest.mark.skipif(shutil.which("bash") is None, reason="the tutorial's steps are bash")
def test_the_tutorial_runs(tmp_path):
    for commands, expected in steps():
        done = subprocess.run(["bash", "-c", PRELUDE + commands], cwd=tmp_path,
                              capture_output=True, text=True, timeout=600)
        printed = done.stdout + done.stderr
        assert done.returncode == 0, f"{commands}\n{printed}"
        for line in expected:
            assert line in printed, f"{commands}\nexpected {line!r} in:\n{printed}"
