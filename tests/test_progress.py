"""Progress bars: on stderr with count, rate and time left only when the command line
asked and stderr is a terminal; ``--quiet`` silences bars and progress lines.
"""

from __future__ import annotations

import io
import sys

import pytest
from cardan_forces.experiments import progress

from cardan_forces.cli import main


class Terminal(io.StringIO):
    """A stderr that says it is a terminal."""

    def isatty(self) -> bool:
        return True


@pytest.fixture
def restore():
    yield
    progress.configure(quiet=False)
    progress._STATE["on"] = False  # as the Python API starts: no bars


def test_a_bar_on_a_terminal_shows_count_rate_and_time_left(monkeypatch, restore):
    screen = Terminal()
    monkeypatch.setattr(sys, "stderr", screen)
    progress.configure(quiet=False)
    assert list(progress.bar(range(5), "work", unit="case")) == list(range(5))
    text = screen.getvalue()
    # the count, and the elapsed<remaining, rate fields (values depend on the clock)
    assert "work" in text and "/5" in text and "case/s" in text and "<" in text
    with progress.ticks(3, "intervals", "instant") as tick:
        for _ in range(3):
            tick("a message a loop sends")
    assert "/3" in screen.getvalue() and "instant/s" in screen.getvalue()


@pytest.mark.parametrize("stderr, quiet", [(io.StringIO(), False), (Terminal(), True)])
def test_no_bar_off_a_terminal_or_when_quiet(monkeypatch, restore, stderr, quiet):
    monkeypatch.setattr(sys, "stderr", stderr)
    progress.configure(quiet=quiet)
    items = [1, 2, 3]
    assert progress.bar(items, "work") is items  # passed through untouched
    lines = print
    with progress.ticks(3, "work", lines=lines) as tick:
        assert tick is lines
    assert stderr.getvalue() == ""


def test_python_api_draws_no_bar_even_on_a_terminal(monkeypatch, restore):
    monkeypatch.setattr(sys, "stderr", Terminal())
    progress._STATE["on"] = False
    assert not progress.shown()


def test_quiet_report_says_nothing(tmp_path, capsys, empty_pictures, restore):
    """Progress and the files written go to stderr, which --quiet silences; a report has
    no answer for stdout (its files are it). The pages are written as empty files: what
    is said is the subject here, the pictures are test_report_figures'."""
    assert main(["report", "propshaft", "--instants", "2", "--out", str(tmp_path)]) == 0
    assert "report:" in capsys.readouterr().err  # the plain progress lines, not a TTY
    assert main(["report", "propshaft", "--instants", "2", "--out", str(tmp_path),
                 "--quiet"]) == 0
    captured = capsys.readouterr()
    assert captured.err == "" and captured.out == "" and (tmp_path / "report-1.png").exists()
