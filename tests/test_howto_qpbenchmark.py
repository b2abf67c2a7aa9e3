"""The qpbenchmark how-to's commands run as written, in order, in one folder, with no
input to answer (stdin closed), and leave the files the page says; its qpbenchmark
command is the one ``cardan export`` writes into the test set's docstring.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from cardan_forces.experiments.export import QPBENCHMARK_RUN

PAGE = Path(__file__).resolve().parents[1] / "docs" / "how-to" / "qpbenchmark.md"


def blocks() -> list[str]:
    """The page's ``bash`` blocks, in order."""
    return re.findall(r"```bash\n(.*?)```", PAGE.read_text(), flags=re.S)


def test_the_page_runs_the_command_the_export_documents():
    lines = [line for block in blocks() for line in block.splitlines()]
    assert QPBENCHMARK_RUN.format(module="cardan_qp") in lines


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("bash") is None, reason="the page's commands are bash")
def test_the_how_to_runs_verbatim_without_a_question(tmp_path):
    pytest.importorskip("qpbenchmark")
    here = str(Path(sys.executable).parent)  # cardan and qpbenchmark of this interpreter
    env = {**os.environ, "PATH": here + os.pathsep + os.environ.get("PATH", "")}
    script = "set -e\n" + "\n".join(blocks())
    done = subprocess.run(["bash", "-c", script], cwd=tmp_path, env=env, text=True,
                          stdin=subprocess.DEVNULL, capture_output=True, timeout=1200)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    folder = tmp_path / "problems"
    for name in ("cardan_qp.py", "cardan_qp.npz", "cardan_qp.csv", "cardan_qp.md"):
        assert (folder / name).stat().st_size > 0, name
