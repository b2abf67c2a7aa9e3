"""The tutorial's steps, read from docs/tutorial.md and run in order in one folder: each
``bash`` block must succeed, and the ``text`` block after it must be exactly what the
block printed (stdout and stderr as one stream), so the page cannot drift from the
package. Numbers at rounding level (below 1e-9) and the sign of a zero are set aside.

``python tests/test_tutorial.py`` rewrites the page's ``text`` blocks with what the
commands print now.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

TUTORIAL = Path(__file__).resolve().parent.parent / "docs" / "tutorial.md"
BLOCK = re.compile(r"```(bash|text)\n(.*?)```", re.S)

# `cardan` as this interpreter runs it, whatever is on PATH
PRELUDE = f'cardan() {{ "{sys.executable}" -m cardan_forces.cli "$@"; }}\nset -e\n'

ROUNDING = re.compile(r"-?\d(?:\.\d+)?e-(?:09|[1-9]\d)\b")
"""A number below 1e-9 written in exponent form: a residual at rounding level."""


def steps() -> list[tuple[str, str]]:
    """``(commands, the output shown after them)`` for each bash block, in page order."""
    found: list[tuple[str, str]] = []
    for kind, body in BLOCK.findall(TUTORIAL.read_text()):
        if kind == "bash":
            found.append((body, ""))
        elif found:
            found[-1] = (found[-1][0], found[-1][1] + body)
    return found


def run(commands: str, folder: Path) -> tuple[int, str]:
    """Exit code and output (stdout and stderr interleaved) of a bash block."""
    done = subprocess.run(["bash", "-c", PRELUDE + commands], cwd=folder, text=True,
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=600)
    return done.returncode, done.stdout


def comparable(text: str) -> list[str]:
    """``text``'s lines with rounding-level numbers and the sign of zeros set aside."""
    text = re.sub(r"-(0\.0+)\b", r"\1", ROUNDING.sub("(rounding)", text))
    return [line.rstrip() for line in text.strip("\n").splitlines()]


def test_the_tutorial_has_steps_with_checked_output():
    found = steps()
    assert len(found) >= 6
    assert all(shown.strip() for _, shown in found)


def test_rounding_and_signed_zeros_are_all_that_is_set_aside():
    assert comparable("residual 2.9e-15, -0.0000") == comparable("residual 1.1e-16, 0.0000")
    assert comparable("1e-08") != comparable("2e-08")
    assert comparable("-0.0001") != comparable("0.0001")


@pytest.mark.slow  # a check of the page against the commands' output, run by the slow job
@pytest.mark.skipif(shutil.which("bash") is None, reason="the tutorial's steps are bash")
def test_the_tutorial_runs(tmp_path):
    for commands, shown in steps():
        code, printed = run(commands, tmp_path)
        assert code == 0, f"{commands}\n{printed}"
        assert comparable(printed) == comparable(shown), f"{commands}\nprinted:\n{printed}"


def rewrite() -> None:
    """The page with each bash block's ``text`` block replaced by what it prints now."""
    with tempfile.TemporaryDirectory() as folder:
        printed: list[str] = []

        def replace(match: re.Match) -> str:
            kind, body = match.groups()
            if kind == "bash":
                code, out = run(body, Path(folder))
                if code:
                    raise SystemExit(f"{body}\nexited {code}:\n{out}")
                printed.append(out)
                return match.group(0)
            return f"```text\n{printed.pop()}```" if printed else match.group(0)

        TUTORIAL.write_text(BLOCK.sub(replace, TUTORIAL.read_text()))


if __name__ == "__main__":
    rewrite()
