"""One import namespace: only ``cardan_forces`` is installed; the README example runs."""

import ast
import graphlib
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


RANKS = {"util": -1, **{layer: k for k, layer in enumerate(LAYERS)}, "commands": len(LAYERS)}
"""The layers bottom up: the utilities every layer may use, then the data flow's layers,
then the commands; the package's root (its API and the CLI) sits above them all."""


def _rank(module: str) -> int:
    part = module.split(".")[1] if module.count(".") else ""
    return RANKS.get(part, len(RANKS))


def test_layers_import_only_downwards():
    """No module imports one of a higher layer (driveline < formulations < solvers <
    experiments < paper_repro < commands < the root), lazy imports included; the
    solvers know problem classes, not drive lines; the utilities import nothing of the
    package."""
    modules = _modules()
    for name, path in modules.items():
        for target in _imports(name, path, modules):
            assert _rank(target) <= _rank(name), f"{name} imports {target}"
            assert not (".solvers" in name and ".driveline" in target), (name, target)
            assert not (".util" in name and ".util" not in target), (name, target)


PAPER_REPRO_MAY_USE = {"study", "environment", "progress", "images", "engine", "files"}
"""What paper_repro takes from experiments: the study layer, the run's environment, the
progress bars, the image files shared with ``cardan report``, MuJoCo's comparison
with the rigid set (``cardan engine``), which repro draws as a method, and the writing
of output files whole."""


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


def _package_dirs() -> dict[str, Path]:
    """Every package of the distribution (pyproject's list) and the folder it installs from."""
    from importlib.util import find_spec

    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib
    packages = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"][
        "packages"]
    return {p: Path(find_spec(p).submodule_search_locations[0]) for p in packages}


def _modules() -> dict[str, Path]:
    """Every module of ``cardan_forces.*``, by dotted name (a package by its ``__init__``)."""
    modules = {}
    for package, folder in _package_dirs().items():
        for path in folder.glob("*.py"):
            name = package if path.stem == "__init__" else f"{package}.{path.stem}"
            modules[name] = path
    return modules


def _type_checking_only(node: ast.AST) -> bool:
    return isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)


def _imports(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The package's modules that ``name`` imports, at its top or inside a function;
    ``from pkg import x`` is an edge to ``pkg.x`` where that is a module, else to ``pkg``.
    Imports under ``if TYPE_CHECKING:`` never run and are left out."""
    package = name if path.stem == "__init__" else name.rpartition(".")[0]
    tree = ast.parse(path.read_text())
    skipped = {id(n) for top in ast.walk(tree) if _type_checking_only(top)
               for n in ast.walk(top)}
    targets = set()
    for node in ast.walk(tree):
        if id(node) in skipped:
            continue
        if isinstance(node, ast.Import):
            targets |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(parent + ([base] if base else []))
            targets |= {f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base
                        for alias in node.names}
    found = set()
    for target in targets:
        while target and target not in modules:
            target = target.rpartition(".")[0]
        if target and target != name:
            found.add(target)
    return found


def test_import_graph_has_no_cycle():
    """No module of ``cardan_forces.*`` (every layer, the CLI and its commands) imports,
    directly or through others, a module that imports it back: lazy imports inside
    functions included, since one that closes a cycle hides an order dependency."""
    modules = _modules()
    assert {"cardan_forces.cli", "cardan_forces.commands.sets",
            "cardan_forces.driveline.scene", "cardan_forces.paper_repro.repro"} <= set(modules)
    graph = {name: _imports(name, path, modules) for name, path in modules.items()}
    try:
        tuple(graphlib.TopologicalSorter(graph).static_order())
    except graphlib.CycleError as err:
        cycle = err.args[1][::-1]  # graphlib lists each module before its importer
        raise AssertionError("import cycle: " + " imports ".join(cycle)) from None


def test_the_cycle_check_sees_relative_and_lazy_imports(tmp_path):
    """The graph reads ``from .x import`` and an import inside a function."""
    path = tmp_path / "a.py"
    path.write_text("from .b import f\n\ndef g():\n    from cardan_forces.p import c\n")
    modules = {"cardan_forces.p.a": path, "cardan_forces.p.b": path,
               "cardan_forces.p.c": path, "cardan_forces.p": path}
    assert _imports("cardan_forces.p.a", path, modules) == {"cardan_forces.p.b",
                                                           "cardan_forces.p.c"}


SOLVERS = "cardan_forces.solvers"
JUDGE_READS = {"record", "stacking", "conversions"}
"""The solvers' modules the judge may import: the records it fills, the layout of the
stacked problems it reads, and the conversion to the conic form it measures on."""


def _within_solvers(module: str, modules: dict) -> set[str]:
    """The solvers' modules (short names) that ``solvers.<module>`` imports."""
    name = f"{SOLVERS}.{module}"
    return {target.rpartition(".")[2] for target in _imports(name, modules[name], modules)
            if target.startswith(SOLVERS + ".")}


def test_one_solve_walks_down_registry_adapter_judge_data():
    """Within the solvers layer a solve goes down: the registry dispatches to an adapter
    (``<name>_``, which declares itself through ``backend``), the judge measures the
    answer, the record holds it. So the judge imports no adapter, neither the registry
    nor its plugins, only the data it reads (:data:`JUDGE_READS`); the record (plain
    data), the stacked layout and the backend's declaration import neither the judge
    nor the registry (lazy imports included), and no adapter but :data:`FALLS_BACK`
    imports the registry."""
    modules = _modules()
    adapters = {name.rpartition(".")[2] for name in modules
                if name.startswith(SOLVERS + ".") and name.endswith("_")}
    assert {"clarabel_", "scipy_", "numpy_batched_"} <= adapters
    judge = _within_solvers("judge", modules)
    assert not judge & (adapters | {"registry", "plugins"}), judge
    assert judge <= JUDGE_READS, judge - JUDGE_READS
    assert _within_solvers("record", modules) == set()
    assert not _within_solvers("stacking", modules) & (adapters | {"registry", "judge"})
    assert "judge" in _within_solvers("registry", modules)
    assert not _within_solvers("backend", modules) & (adapters | {"registry", "judge"})
    declaring = {a for a in adapters if "registry" in _within_solvers(a, modules)}
    assert declaring == FALLS_BACK, declaring


FALLS_BACK = {"reduced_ipm_"}
"""The adapters that import the registry: an adapter declares itself through
:mod:`~cardan_forces.solvers.backend` (below the registry); only the reduced-space
interior point calls the registry back, to solve an instant it gives up on with its
fallback backend."""
