"""Every figure command takes ``--format png,svg,pdf``: the figure in each format asked
for, and an unknown format is one usage line with exit 2 before any work."""

import pytest

from cardan_forces.cli import main

FIGURE_COMMANDS = ("repro", "report", "bench", "engine", "secondary")


def test_secondary_writes_each_format_asked(tmp_path):
    assert main(["secondary", "--out", str(tmp_path), "--format", "svg,png", "--quiet"]) == 0
    assert {p.suffix for p in tmp_path.glob("secondary.*")} == {".csv", ".png", ".svg"}


@pytest.mark.parametrize("command", FIGURE_COMMANDS)
def test_an_unknown_format_is_one_line_and_exit_2(command, tmp_path, capsys):
    assert main([command, "--out", str(tmp_path / "out"), "--format", "png,bmp"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("cardan: error:") and "bmp" in err[0]
    assert not (tmp_path / "out").exists()


def test_a_png_is_written_at_150_dpi_or_more(tmp_path):
    from cardan_forces.experiments import images
    from PIL import Image

    assert main(["secondary", "--out", str(tmp_path), "--quiet"]) == 0
    with Image.open(tmp_path / "secondary.png") as png:
        dpi = png.info["dpi"]
    assert min(dpi) >= 149.5 and images.DPI >= 150
