"""Each formulation's name is spelled once, in the formulation registry, and each
element kind's in its own module: the package's source holds no string equal to such a
name elsewhere, except where the same word names something else (a built-in scene, a
scene effect, a solver family) or is a scene's default.
"""

import ast
from pathlib import Path

import pytest
from cardan_forces.driveline.elements.base import LINK_KINDS, RELEASES
from cardan_forces.driveline.elements.registry import BEARING_KINDS, IN_SHAFT_KINDS, JOINT_KINDS
from cardan_forces.formulations import BASELINE, FORMULATIONS, SELECTION

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("cardan_forces", "driveline", "experiments", "formulations", "paper_repro",
            "solvers")
REGISTRY = Path("formulations/registry.py")

SCENE = "the built-in scene 'paper' (a default scene), not the formulation"
EFFECT = "a scene effect of that word, not the formulation"
ALLOWED = {
    **{(Path(p), "paper"): SCENE for p in (
        "driveline/loading.py", "experiments/bench.py", "experiments/engine.py",
        "experiments/export.py", "experiments/hard.py", "experiments/regularization.py",
        "experiments/report.py", "experiments/sweep.py", "paper_repro/repro.py",
        "cardan_forces/commands/compile.py", "cardan_forces/commands/repro.py",
        "cardan_forces/commands/sets.py", "cardan_forces/commands/solve.py")},
    **{(Path(p), "friction"): EFFECT for p in (
        "driveline/scene.py", "driveline/loading.py", "driveline/engine_mujoco.py",
        "formulations/convex.py")},
    (Path("driveline/scene.py"), "compliance"): EFFECT,
    (Path("driveline/determinacy.py"), "min_norm"): "the key of the least-norm answer in "
                                                    "the determinacy's JSON",
    (Path("solvers/lcp_.py"), "lcp"): "the solver family of the LCP backends",
    (Path("solvers/numpy_batched_.py"), "lcp"): "the batched least norm's LCP stage",
    (Path("solvers/judge.py"), "lcp"): "the kind of dual an LCP problem's record holds",
    **{(Path("experiments/export.py"), n): "export's default set, keyed by name"
       for n in ("min_norm", "positive", "compliance")},
}
"""``(file, name) -> why`` that string there is not the formulation."""

POLICY = {Path("experiments/bench_targets.py"): "the bench's targets per formulation",
          Path("paper_repro/methods.py"): "the paper figures' choices of formulations"}
"""Files of a command's policy tables keyed by the registry's names (the definitions
stay in the registry; :func:`test_policy_tables_name_registry_formulations`)."""

KIND_NAMES = {*BEARING_KINDS, *JOINT_KINDS, *(k.name for k in IN_SHAFT_KINDS),
              *(k.table for k in IN_SHAFT_KINDS), *LINK_KINDS, *RELEASES}
"""The element kinds' names: a bearing's or a joint's ``kind`` in a scene, an in-shaft
kind's name and table, the links' kinds, the releases'."""
ELEMENTS = Path("driveline/elements")
KIND_DEFAULTS = {Path("driveline/scene.py"), Path("driveline/loading.py")}
"""Where a bearing's and a joint's kind are defaulted (``locating``, ``cardan``: a
scene's defaults, not a switch)."""


def _spelled(names) -> set[tuple[Path, str, int]]:
    """Every string constant of the package equal to one of ``names``, with its line."""
    found = set()
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            where = path.relative_to(ROOT)
            for node in ast.walk(ast.parse(path.read_text(), str(where))):
                if isinstance(node, ast.Constant) and node.value in names:
                    found.add((where, node.value, node.lineno))
    return found


@pytest.fixture(scope="module")
def spelled():
    return _spelled(FORMULATIONS)


def test_no_formulation_name_outside_the_registry(spelled):
    stray = sorted((str(p), name, line) for p, name, line in spelled
                   if p != REGISTRY and (p, name) not in ALLOWED and p not in POLICY)
    assert stray == []


def test_policy_tables_name_registry_formulations():
    """A renamed formulation fails here, not silently out of a command's policy."""
    from cardan_forces.experiments import bench_targets, export
    from cardan_forces.paper_repro import methods

    named = {*bench_targets.TARGETS, *export.QP_FORMULATIONS, *methods.METHODS,
             *methods.COMPLIANCE_VS_PENALTY, *methods.JOB_COST}
    assert named <= set(FORMULATIONS)


def test_the_scan_sees_the_registry(spelled):
    """The scan finds the registry's own names (it would miss nothing by reading none)."""
    mine = {name for p, name, _ in spelled if p == REGISTRY}
    assert mine == set(FORMULATIONS)
    assert {BASELINE, SELECTION} <= mine


def test_allowed_spellings_still_exist(spelled):
    """An allowance with no spelling left goes (the list stays what the source holds)."""
    assert set(ALLOWED) <= {(p, name) for p, name, _ in spelled}


KIND_ALLOWED = {(Path("cardan_forces/cli.py"), "cardan"): "the program's name"}
"""``(file, name) -> why`` that string there is not the element kind."""


def test_no_element_kind_name_outside_its_module():
    spelled = _spelled(KIND_NAMES)
    stray = sorted((str(p), name, line) for p, name, line in spelled
                   if ELEMENTS not in p.parents and p not in KIND_DEFAULTS
                   and (p, name) not in KIND_ALLOWED)
    assert stray == []
    assert set(BEARING_KINDS) <= {name for p, name, _ in spelled if ELEMENTS in p.parents}


def test_problems_carry_the_record_name(paper):
    """The registry stamps its own name on every problem its builders make."""
    from cardan_forces.driveline.dynamics import simulate
    from cardan_forces.driveline.equilibrium import build_operator
    from cardan_forces.formulations.convex import NotApplicable

    op = build_operator(simulate(paper, [0.5]))
    refused = set()
    for name, record in FORMULATIONS.items():
        try:
            assert record(op, 0).formulation == name
        except NotApplicable:
            refused.add(name)
    assert refused == {"friction"}  # the paper's scene has no friction
