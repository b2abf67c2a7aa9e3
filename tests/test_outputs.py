"""Output files: written whole or not at all, and an earlier run's files in an output
folder told apart from this run's."""

from __future__ import annotations

import os
import stat

import pytest
from cardan_forces.experiments import files

from cardan_forces.cli import main


def test_a_write_that_fails_leaves_the_earlier_file_and_no_temporary(tmp_path):
    path = tmp_path / "table.csv"
    files.write_text(path, "a,b\n1,2\n")
    with pytest.raises(RuntimeError, match="formatting failed"):
        with files.replacing(path, newline="") as f:
            f.write("a,b\n3,")
            raise RuntimeError("formatting failed")
    assert path.read_text() == "a,b\n1,2\n"
    assert [p.name for p in tmp_path.iterdir()] == ["table.csv"]


def test_a_replaced_file_has_a_plain_files_permissions(tmp_path):
    """The temporary file is private; the output it becomes is as ``open`` makes it."""
    plain = tmp_path / "plain.txt"
    plain.write_text("x")
    written = files.write_text(tmp_path / "written.txt", "x")
    assert stat.S_IMODE(os.stat(written).st_mode) == stat.S_IMODE(os.stat(plain).st_mode)


def test_stale_files_are_those_matching_that_this_run_did_not_write(tmp_path):
    for name in ("fig11.csv", "fig11.png", "fig12.csv", "notes.txt"):
        (tmp_path / name).write_text("x")
    found = files.stale(tmp_path, [tmp_path / "fig12.csv"], ["fig1*.csv", "fig1*.png"])
    assert [p.name for p in found] == ["fig11.csv", "fig11.png"]


def test_repro_lists_an_earlier_runs_figures_as_not_its_own(tmp_path, capsys):
    """``repro --fig 12`` after ``--fig 11`` into one folder: the report names Fig. 11's
    files as an earlier run's (kept, not covered), stderr says where it wrote and that
    they are there."""
    argv = ["repro", "--quick", "--no-penalty", "--methods", "positive", "--out",
            str(tmp_path)]
    assert main([*argv, "--fig", "11"]) == 0
    capsys.readouterr()
    cells = [line.split(",") for line in (tmp_path / "fig11.csv").read_text().splitlines()]
    assert not any(c in ("nan", "inf", "-inf") for row in cells[1:] for c in row)
    assert main([*argv, "--fig", "12"]) == 0
    err = capsys.readouterr().err
    report = (tmp_path / "report.md").read_text()
    earlier = report.split("## Files of an earlier run", 1)[1]
    assert "`fig11.csv`" in earlier and "`fig11.png`" in earlier and "fig12" not in earlier
    assert (tmp_path / "fig11.csv").exists()
    assert f"cardan repro: wrote {tmp_path}/" in err and "listed in report.md" in err


@pytest.mark.parametrize("argv, names", [
    (["hard", "--quick", "--case", "articulation-0", "--formulation", "positive"],
     ("hard.csv", "hard.md")),
    (["secondary"], ("secondary.csv", "secondary.png")),
])
def test_a_command_that_writes_files_ends_saying_where(tmp_path, capsys, argv, names):
    """The last line on stderr names the folder and the files, which are there; a
    second run replaces them (no second copy, no temporary left) and says how many."""
    for again in ("", f" (replacing {len(names)} files of an earlier run)"):
        assert main([*argv, "--out", str(tmp_path)]) == 0
        last = capsys.readouterr().err.splitlines()[-1]
        assert last == f"cardan {argv[0]}: wrote {tmp_path}/ ({', '.join(names)}){again}"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(names)


def test_a_figure_csv_leaves_unknown_numbers_empty_and_marks_open_sides(tmp_path):
    """NaN (not solved, not computed) is an empty cell, and so is an open side of a
    rigid set, named by its ``_set_open`` code; no cell holds an infinity; reading the
    file back gives the same columns."""
    import numpy as np
    from cardan_forces.paper_repro import figures

    columns = {"t": np.array([0.0, 0.5, 1.0]),
               "load_positive": np.array([1.5, np.nan, -2.25e-300]),
               "load_set_min": np.array([-np.inf, np.nan, 0.0]),
               "load_set_max": np.array([np.inf, np.nan, 3.0])}
    path = figures.write_csv(tmp_path / "fig.csv", columns)
    lines = path.read_text().splitlines()
    assert lines[0] == "t,load_positive,load_set_min,load_set_max,load_set_open"
    assert lines[1] == "0,1.5,,,2"  # open on both sides
    assert lines[2] == "0.5,,,,"  # not known
    assert lines[3] == "1,-2.25e-300,0,3,0"  # closed
    back = figures.read_csv(path)
    for name, values in columns.items():
        np.testing.assert_array_equal(back[name], values)
