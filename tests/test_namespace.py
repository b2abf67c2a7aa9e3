"""One import namespace: only ``cardan_forces`` is installed; the README example runs."""

import re
import subprocess
import sys
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("driveline", "formulations", "solvers", "experiments", "paper_repro")


def test_only_cardan_forces_is_a_top_level_module():
    top = metadata.distribution("cardan-forces").read_text("top_level.txt").split()
    assert top == ["cardan_forces"]


def test_generic_names_are_not_importable_outside_the_checkout(tmp_path):
    code = ("import importlib.util as u; import cardan_forces.driveline, cardan_forces.cli; "
            f"print([n for n in {LAYERS!r} if u.find_spec(n) is not None])")
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                         text=True, check=True).stdout
    assert out.strip() == "[]"


def test_layers_import_only_downwards():
    """Lower layers never import upper ones (driveline < formulations < solvers < ...)."""
    order = {name: k for k, name in enumerate(LAYERS[:3])}
    for layer, rank in order.items():
        for path in (ROOT / layer).glob("*.py"):
            imported = re.findall(r"^\s*(?:from|import) cardan_forces\.(\w+)",
                                  path.read_text(), flags=re.M)
            above = [m for m in imported if order.get(m, 99) > rank]
            assert not above, f"{path.name} imports {above}"


PAPER_REPRO_MAY_USE = {"study", "environment", "progress", "images", "engine"}
"""What paper_repro takes from experiments: the study layer, the run's environment, the
progress bars, the image files shared with ``cardan report`` and MuJoCo's comparison
with the rigid set (``cardan engine``), which repro draws as a method."""


def test_paper_repro_uses_experiments_one_way():
    """paper_repro may use the study layer (and the environment record); experiments
    never import paper_repro (no sideways dependency between the two)."""
    for path in (ROOT / "experiments").glob("*.py"):
        assert not re.search(r"^\s*(?:from|import) cardan_forces\.paper_repro", path.read_text(),
                             flags=re.M), path.name
    for path in (ROOT / "paper_repro").glob("*.py"):
        text = path.read_text()
        used = set(re.findall(r"^\s*from cardan_forces\.experiments\.(\w+)", text, flags=re.M))
        for names in re.findall(r"^\s*from cardan_forces\.experiments import ([\w, ]+)", text,
                                flags=re.M):
            used |= {n.strip() for n in names.split(",")}
        assert used <= PAPER_REPRO_MAY_USE, (path.name, used - PAPER_REPRO_MAY_USE)


def test_readme_python_example_runs(capsys):
    text = (ROOT / "README.md").read_text()
    block = re.search(r"## From Python.*?```python\n(.*?)```", text, flags=re.S).group(1)
    exec(compile(block, "README.md", "exec"), {})
    lines = capsys.readouterr().out.splitlines()
    assert lines[:2] == ["29 7", "4"]
    assert lines[2].count("float:") == 2 and "slip:intermediate" in lines[2]
    assert lines[3] == "solved True"
