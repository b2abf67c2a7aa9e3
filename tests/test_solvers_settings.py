"""One home for solver settings and one spelling of statuses in the solvers layer.

Every backend's tolerance parameters, tolerance floor and qpbenchmark profile are
read from ``solvers/settings.py``, and no module under ``solvers/`` but ``record.py``
spells a status value as a string: adapters map their solver's codes to ``Status``.
"""

import ast
from pathlib import Path

import pytest
from cardan_forces.solvers import available, settings
from cardan_forces.solvers.record import Status

SOLVERS = Path(settings.__file__).parent
STATUS_VALUES = {s.value for s in Status}
SOLVER_WORDS = {("qocogen_.py", "NAMES")}
"""Module-level names that hold a solver's own words, some of which spell a status
(the generated QOCO's name of its code 1 is "solved")."""
DECLARED = ("tolerances", "smallest_tol", "qpbenchmark")
"""The fields of a ``Backend`` that the settings module holds the values of."""


def _docstrings(tree: ast.AST) -> set[int]:
    """``id`` of every docstring-like constant: a string expression statement."""
    return {id(node.value) for node in ast.walk(tree)
            if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant)}


def _exempt(tree: ast.AST, module: str) -> set[int]:
    """``id`` of the constants that are a solver's words, not ours: docstrings, keys of a
    dict (a solver's status name mapped to a ``Status``), a word searched for with ``in``
    in a solver's text, and the values of :data:`SOLVER_WORDS`.
    """
    out = _docstrings(tree)
    for node in ast.walk(tree):
        if isinstance(node, ast.Dict):
            out |= {id(key) for key in node.keys if key is not None}
        elif isinstance(node, ast.Compare) and isinstance(node.ops[0], (ast.In, ast.NotIn)):
            out.add(id(node.left))
        elif isinstance(node, ast.Assign) and any(
                isinstance(t, ast.Name) and (module, t.id) in SOLVER_WORDS
                for t in node.targets):
            out |= {id(c) for c in ast.walk(node.value)}
    return out


def status_literals(source: str, module: str = "") -> list[tuple[int, str]]:
    """``(line, value)`` of each string constant in ``source`` that spells a status
    value where a :class:`Status` member belongs.
    """
    tree = ast.parse(source)
    exempt = _exempt(tree, module)
    return sorted((node.lineno, node.value) for node in ast.walk(tree)
                  if isinstance(node, ast.Constant) and node.value in STATUS_VALUES
                  and id(node) not in exempt)


def test_the_status_scan_finds_a_spelled_status_and_spares_a_solvers_words():
    source = '''
def solve():
    """Returns "solved" or "failed"."""
    STATUS = {"solved": Status.SOLVED, "unbounded": Status.UNBOUNDED}
    if "infeasible" in text:
        return Outcome("inaccurate", z)
    return STATUS.get(code, "failed")
'''
    assert status_literals(source) == [(6, "inaccurate"), (7, "failed")]


@pytest.mark.parametrize("path", sorted(p.name for p in SOLVERS.glob("*.py")
                                        if p.name != "record.py"))
def test_no_solvers_module_spells_a_status(path):
    found = status_literals((SOLVERS / path).read_text(), path)
    assert found == [], f"{path}: use Status members, not the strings at {found}"


def _builtin(backend) -> bool:
    function = backend.solve or backend.batch
    return function.__module__.startswith("cardan_forces.solvers.")


def test_every_backend_reads_its_tolerance_names_from_the_settings_module():
    """The very objects of ``settings``: a tuple equal to one there would not do."""
    names = list(settings.TOLERANCES.values())
    profiles = list(settings.PROFILES.values())
    backends = [b for b in available().values() if _builtin(b)]
    assert backends
    for b in backends:
        assert any(b.tolerances is n for n in names), (b.name, b.tolerances)
        assert b.smallest_tol in (0.0, *settings.SMALLEST.values()), b.name
        assert b.qpbenchmark is None or any(b.qpbenchmark is p for p in profiles), b.name


def _literal(node: ast.AST) -> bool:
    return isinstance(node, (ast.Constant, ast.Tuple, ast.List, ast.Dict)) or (
        isinstance(node, ast.Call) and getattr(node.func, "id", "") == "Profile")


@pytest.mark.parametrize("path", sorted(p.name for p in SOLVERS.glob("*.py")
                                        if p.name != "settings.py"))
def test_no_adapter_declares_settings_of_its_own(path):
    """No ``TOLERANCES``, ``SMALLEST`` or ``PROFILES`` table outside the settings
    module, and no literal given to a ``Backend``'s declared settings."""
    tree = ast.parse((SOLVERS / path).read_text())
    tables = [t.id for node in ast.walk(tree) if isinstance(node, (ast.Assign, ast.AnnAssign))
              for t in getattr(node, "targets", [getattr(node, "target", None)])
              if isinstance(t, ast.Name) and t.id in ("TOLERANCES", "SMALLEST", "PROFILES")]
    given = [k.arg for node in ast.walk(tree) if isinstance(node, ast.Call)
             for k in node.keywords if k.arg in DECLARED and _literal(k.value)]
    assert tables == [] and given == [], (path, tables, given)


def test_one_tolerance_reaches_each_solvers_own_names():
    assert settings.solver_options("highs", 1e-13) == dict.fromkeys(
        settings.TOLERANCES["highs"], settings.SMALLEST["highs"])
    assert settings.solver_options("osqp", 1e-7) == {"eps_abs": 1e-7, "eps_rel": 1e-7}
    assert settings.solver_options("quadprog", 1e-7) == {}
    assert settings.solver_options("clarabel", None) == {}
    assert settings.time_limit("highs") == {"time_limit": settings.TIME_LIMIT_S}
    assert settings.time_limit("osqp") == {}
