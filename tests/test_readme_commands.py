"""The README's commands, run as a user would in the README's order in one folder, never
destroy one another's outputs: no command replaces a file an earlier one wrote. Each
runs with options that make it small (``--quick``, few instants), appended after the
README's own.
"""

from __future__ import annotations

import os
import re
import shlex
from pathlib import Path

import pytest
from cardan_forces.paper_repro.request import ALL_METHODS, ENGINE

from cardan_forces.cli import main

README = Path(__file__).resolve().parents[1] / "README.md"

SMALL = {
    "repro": ["--quick", "--no-penalty"],
    "report": ["--instants", "3"],
    "bench": ["--formulation", "min_norm", "--solver", "numpy-kkt"],
    "sweep": ["--quick", "--workers", "1"],
    "life": ["--instants", "3", "--no-engine"],
    "tolerances": ["--samples", "2", "--instants", "2"],
}
"""What each command that writes files adds to the README's command line."""

READS_ONLY = {"scene", "sets", "solve"}
"""The README's commands that write no file (``scene dump`` writes by ``>``)."""


def readme_commands() -> list[list[str]]:
    """Every ``cardan`` command of the README's code blocks, in order, as arguments
    (comments dropped; ``&&`` chains split; a ``> FILE`` kept at the end)."""
    blocks = re.findall(r"```\n(.*?)```", README.read_text(), flags=re.S)
    found = []
    for block in blocks:
        for line in block.splitlines():
            for part in line.split("&&"):
                words = shlex.split(part, comments=True)
                if words[:1] == ["cardan"]:
                    found.append(words[1:])
    return found


def _snapshot(root: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(root)): (p.stat().st_ino, p.stat().st_mtime_ns)
            for p in root.rglob("*") if p.is_file()}


def test_the_readme_names_every_command_that_writes_files():
    commands = {words[0] for words in readme_commands()}
    assert commands == set(SMALL) | READS_ONLY


def test_the_readme_says_what_no_penalty_draws():
    text = " ".join(README.read_text().split())
    said = text.split("`cardan repro --no-penalty`", 1)[1].split(".", 1)[0]
    assert "penalty simulation out" in said and "rigid-model methods" in said
    assert ("MuJoCo" in said) == (ENGINE in ALL_METHODS)


@pytest.mark.slow
def test_no_readme_command_replaces_an_earlier_ones_files(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    owner: dict[str, str] = {}
    seen = _snapshot(tmp_path)
    for words in readme_commands():
        if words[0] in READS_ONLY and ">" not in words:
            continue
        target = words[words.index(">") + 1] if ">" in words else None
        argv = words[:words.index(">")] if target else [*words, *SMALL[words[0]]]
        assert main(argv) == 0, argv
        captured = capsys.readouterr()
        if target:
            Path(target).write_text(captured.out)
        now = _snapshot(tmp_path)
        command = " ".join(words)
        replaced = [p for p in seen if p in now and now[p] != seen[p]]
        assert not replaced, f"{command} replaced {[(p, owner[p]) for p in replaced]}"
        assert "replacing" not in captured.err, captured.err
        owner.update({p: command for p in now if p not in seen})
        seen = now
    assert len(set(owner.values())) == len(SMALL) + 2  # repro twice, scene dump
    assert os.path.isfile(tmp_path / "results" / "repro" / "report.md")
