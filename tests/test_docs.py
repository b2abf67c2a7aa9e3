"""The documentation is complete and true to the package: the reference pages (as
``docs/gen_reference.py`` generates them for the site) name every public function,
every command and every scene field; the README keeps its two commands, its length and
its example's printed values; no prose quotes a timing.
"""

from __future__ import annotations

import argparse
import importlib.util
import re
from pathlib import Path

import pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

from cardan_forces.driveline.loading import builtin_names, builtin_text
from cardan_forces.driveline.scene import LIMITS

import cardan_forces as cf
from cardan_forces import cli

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
MAIN = 'python -m pip install -e ".[all]" && cardan repro'
TESTS = 'python -m pip install -e ".[all,test]" && python -m pytest'


def _module(name: str):
    spec = importlib.util.spec_from_file_location(name, DOCS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def gen():
    return _module("gen_reference")


def _page(gen, name: str) -> str:
    """A page as the site builds it: each placeholder replaced by what is generated."""
    text = (DOCS / name).read_text()
    hooks = _module("hooks")
    for key, generate in hooks.GENERATED.items():
        placeholder = f"<!-- generated: {key} -->"
        if placeholder in text:
            text = text.replace(placeholder, generate())
    assert "<!-- generated:" not in text, name
    return text


def test_every_public_name_is_in_the_api_reference(gen):
    page = _page(gen, "reference/api.md")
    for name in cf.__all__:
        assert f"::: cardan_forces.{name}\n" in page, name


def test_every_public_name_resolves_to_its_source(tmp_path, monkeypatch):
    griffe = pytest.importorskip("griffe", reason="the docs extra reads the sources")
    monkeypatch.chdir(tmp_path)  # as the site builds: no package folder in the cwd
    package = griffe.load("cardan_forces", search_paths=[_module("hooks").api_sources()])
    for name in cf.__all__:
        member = package[name]  # an alias resolves to its target here, or raises
        assert member.docstring is not None or name == "FORMULATIONS", name


def _command_names(module) -> list[str]:
    sub = argparse.ArgumentParser().add_subparsers()
    module.add_parser(sub)
    return list(sub.choices)


def test_every_command_is_in_the_cli_reference(gen):
    page = _page(gen, "reference/cli.md")
    for module in cli.COMMANDS:
        for name in _command_names(module):
            assert f"## cardan {name}\n" in page, name
    for name, _ in gen.commands():  # sub-commands too (cardan scene list, ...)
        assert f"## {name}\n" in page


def test_every_scene_field_is_in_the_scene_reference(gen):
    page = _page(gen, "reference/scene.md")
    for cls, field in gen.scene_fields():
        section = page.split(f"### {cls}\n", 1)[1].split("\n### ", 1)[0]
        assert f"| `{field}` |" in section, (cls, field)
    for kind in LIMITS:
        assert f"| `{kind}` |" in page


def _keys(value, found: set[str]) -> set[str]:
    if isinstance(value, dict):
        for key, inner in value.items():
            found.add(key)
            _keys(inner, found)
    elif isinstance(value, list):
        for inner in value:
            _keys(inner, found)
    return found


def test_every_key_of_the_built_in_scenes_is_on_the_scene_page(gen):
    page = _page(gen, "reference/scene.md")
    for name in builtin_names():
        for key in _keys(tomllib.loads(builtin_text(name)), set()):
            assert re.search(rf"\b{re.escape(key)}\b", page), (name, key)


def test_the_determinacy_table_is_the_rank_the_api_gives(gen):
    rows = {r["scene"]: r for r in gen.determinacy_rows()}
    paper = rows["paper"]
    assert paper["rank"] + paper["nullity"] == paper["forces"]
    # the paper's line: one closed loop; a slip joint removes it; the propshaft has none
    assert paper["modes"]["closed loop"] == 1
    assert rows["paper-slip"]["modes"]["closed loop"] == 0
    assert sum(rows["propshaft"]["modes"].values()) == rows["propshaft"]["nullity"]


def test_readme_is_short_with_both_commands():
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= 200
    assert f"```\n{MAIN}\n```" in text and f"```\n{TESTS}\n```" in text
    for target in re.findall(r"\]\(((?:docs/|[A-Z]+)[^)#]*)\)", text):
        assert (ROOT / target).exists(), target


def test_ci_runs_the_readme_test_command_and_builds_the_docs():
    text = (ROOT / ".ci" / "run").read_text()
    assert TESTS in text and "mkdocs build --strict" in text


def test_readme_example_prints_what_its_comments_say(capsys):
    text = (ROOT / "README.md").read_text()
    block = re.search(r"## From Python.*?```python\n(.*?)```", text, flags=re.S).group(1)
    exec(compile(block, "README.md", "exec"), {})
    printed = iter(capsys.readouterr().out.splitlines())
    for line in block.splitlines():
        if line.startswith("print("):
            said = next(printed)
            if "#" in line:
                assert said == line.split("#", 1)[1].split(":")[0].strip(), line


TIMING = re.compile(r"\d\s*(us|µs|ms)\b|\d\s*(x|times) (faster|slower)|instants/s")


@pytest.mark.parametrize("path", [ROOT / "README.md", ROOT / "CONTRIBUTING.md",
                                  *sorted(DOCS.rglob("*.md"))], ids=lambda p: p.name)
def test_no_prose_quotes_a_timing(path):
    text = path.read_text()
    if path.name == "benchmarks.md":  # generated from the stored run, with its machine
        return
    assert not TIMING.search(text), TIMING.search(text).group(0)


def test_the_constants_the_explanations_state():
    from cardan_forces.driveline.determinacy import DETERMINATE_TOL
    from cardan_forces.solvers.record import ACCEPT

    text = "\n".join(p.read_text() for p in sorted((DOCS / "explanation").glob("*.md")))
    assert DETERMINATE_TOL == 1e-8 and "below 1e-8" in text
    assert ACCEPT == 1e-6 and re.search(r"above\s+1e-6", text)
    joint = cf.load_scene("paper-penalty").joints[0]  # the paper's clearances, in mm
    assert round(joint.radial_clearance_m * 1e3, 6) == 0.25 and "radial 0.25 mm" in text
    assert round(joint.axial_clearance_m * 1e3, 6) == 0.75 and "axial 0.75 mm" in text
    op = cf.build_operator(cf.simulate(cf.load_scene("paper")))
    paper = cf.build_formulation("paper", op, 100)
    assert len(paper.unknown_names) == 34 and "34 polar unknowns" in text


def test_every_method_of_an_element_kind_is_in_its_how_to(gen):
    from cardan_forces.driveline.elements.base import ElementKind

    page = _page(gen, "how-to/element.md")
    for name, member in vars(ElementKind).items():
        if callable(member) and not name.startswith("_"):
            assert f"| `{name}(" in page, name


def _python_blocks(page: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", (DOCS / page).read_text(), flags=re.S)


def test_the_plugin_example_solves_a_least_norm_problem():
    namespace: dict = {}
    exec(compile(_python_blocks("how-to/backend.md")[0], "backend.md", "exec"), namespace)
    (backend,) = namespace["backends"]()
    op = cf.build_operator(cf.simulate(cf.load_scene("paper")))
    problem = cf.build_formulation("min_norm", op, 100)
    assert isinstance(problem, backend.accepts)
    outcome = backend.solve(problem)
    residual = problem.A @ outcome.z - problem.b
    assert outcome.status == "solved"
    assert float(abs(residual).max()) <= 1e-9 * float(abs(problem.b).max())


def test_the_formulation_how_to_quotes_the_source():
    import inspect

    from cardan_forces.formulations import convex

    quoted = re.search(r"```python\n(.*?)```", (DOCS / "how-to/formulation.md").read_text(),
                       flags=re.S).group(1)
    source = " ".join(inspect.getsource(convex.min_norm).split())
    assert " ".join(quoted.split()) in source


def _cardan_lines() -> list[tuple[str, str]]:
    """Every ``cardan ...`` command in a code block of the README or the docs."""
    found = []
    for path in [ROOT / "README.md", ROOT / "CONTRIBUTING.md", *sorted(DOCS.rglob("*.md"))]:
        for block in re.findall(r"```[a-z]*\n(.*?)```", path.read_text(), flags=re.S):
            for line in block.replace("\\\n", " ").splitlines():
                line = line.split("#", 1)[0].split(">", 1)[0].split("|", 1)[0].strip()
                if line.startswith("cardan ") and "..." not in line:
                    found.append((path.name, line))
    return found


def test_every_command_shown_in_the_docs_parses():
    import shlex

    lines = _cardan_lines()
    assert len(lines) > 20
    for page, line in lines:
        args = cli._parser().parse_args(shlex.split(line)[1:])  # UsageError if not
        assert args.command, (page, line)


def test_every_formulation_is_explained():
    text = (DOCS / "explanation/formulations.md").read_text()
    hand_table = text.split("<!-- generated:", 1)[0]
    for name in cf.FORMULATIONS:
        assert f"| `{name}` |" in hand_table, name


def test_the_backend_how_to_names_what_an_adapter_and_a_backend_declare():
    import dataclasses

    from cardan_forces.solvers import registry

    text = (DOCS / "how-to/backend.md").read_text()
    for module in registry.ADAPTERS:
        adapter = registry._adapter(module)
        assert callable(adapter.backends) and isinstance(adapter.EXTRAS, dict), module
    assert "`EXTRAS`" in text and "`backends()`" in text and "`ADAPTERS`" in text
    declared = {f.name for f in dataclasses.fields(registry.Backend)}
    for name in re.findall(r"^- `(\w+)`", text, flags=re.M):
        assert name in declared or name in ("EXTRAS",), name


PACKAGE_DIRS = ("cardan_forces", "driveline", "formulations", "solvers", "experiments",
                "paper_repro")
QUOTED_TIMING = re.compile(r"\d\s?(us|µs)\b|\d\s*(x|times) (faster|slower|cheaper|dearer)"
                           r"|\d\s?% (faster|slower|cheaper|less time)|\bs of CPU\b"
                           r"|\d\s?ms (a|an|per) (call|step|instant)")


def _prose(path: Path) -> list[tuple[int, str]]:
    """The docstrings and comments of a source file, with their line numbers."""
    import ast
    import io
    import tokenize

    text = path.read_text()
    found = [(tok.start[0], tok.string) for tok in
             tokenize.generate_tokens(io.StringIO(text).readline)
             if tok.type == tokenize.COMMENT]
    for node in ast.walk(ast.parse(text)):
        body = getattr(node, "body", None)
        if isinstance(body, list):
            for first, second in zip(body, body[1:] + [None]):
                for item in (first, second):
                    if (isinstance(item, ast.Expr) and isinstance(item.value, ast.Constant)
                            and isinstance(item.value.value, str)):
                        found.append((item.lineno, item.value.value))
    return found


def test_no_docstring_or_comment_quotes_a_timing():
    """Measured times go stale silently; they belong to the generated benchmarks page."""
    quoted = {f"{path.relative_to(ROOT)}:{line}: {match.group(0)}"
              for folder in PACKAGE_DIRS for path in sorted((ROOT / folder).rglob("*.py"))
              for line, text in _prose(path) for match in [QUOTED_TIMING.search(text)]
              if match}
    assert not quoted, "\n".join(sorted(quoted))


def _sci(value: float) -> str:
    """A power of ten as the pages write it (``1e-6``)."""
    return f"{value:.0e}".replace("e-0", "e-")


def test_the_bench_views_page_states_qpbenchmarks_settings():
    from cardan_forces.solvers.record import ACCEPT
    from cardan_forces.solvers.settings import SETTINGS

    text = " ".join((DOCS / "how-to/bench-views.md").read_text().split())
    assert "`default` (the solver's defaults, judged at 1)" in text
    assert SETTINGS["default"].tolerance == 1.0
    for name in ("low_accuracy", "mid_accuracy", "high_accuracy"):
        assert f"`{name}` {_sci(SETTINGS[name].tolerance)}" in text, name
    assert f"each is at most {_sci(ACCEPT)}" in text


@pytest.mark.slow
def test_the_readme_figure_is_what_its_command_draws_now(tmp_path):
    """docs/fig13.png and its data docs/fig13.csv are what the README's command draws
    with the current code (the same data; the picture at the same size), so the README
    never shows an older drawing. Refresh both by copying that command's output."""
    import matplotlib.image
    from figure_data import assert_same_figure

    assert cli.main(["repro", "--fig", "13", "--no-penalty", "--out", str(tmp_path),
                     "--quiet"]) == 0
    assert_same_figure(tmp_path / "fig13.csv", DOCS / "fig13.csv")
    drawn, shown = (matplotlib.image.imread(p) for p in (tmp_path / "fig13.png",
                                                            DOCS / "fig13.png"))
    assert drawn.shape == shown.shape
