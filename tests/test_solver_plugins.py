"""Backends of other packages: :func:`register` and the entry-point group
``cardan_forces.solvers``, with a distribution made in a temporary folder (on
``sys.path`` only, installed nowhere).
"""

from __future__ import annotations

import dataclasses
import json
import sys
import textwrap
from importlib import metadata

import numpy as np
import pytest
from cardan_forces.formulations.batch import least_norm_batch
from cardan_forces.formulations.problems import LS, QP
from cardan_forces.solvers import InvalidBackend, Status, plugins, registry, solve

import cardan_forces as cf
from cardan_forces import build_formulation, build_operator, load_scene, simulate
from cardan_forces.cli import main

PLUGIN = '''
import numpy as np
from cardan_forces.formulations.problems import LS
from cardan_forces.solvers import Backend, Outcome


def lstsq(problem, tol=None, initvals=None):
    """Least norm by numpy.linalg.lstsq (unweighted problems only)."""
    z = np.linalg.lstsq(np.asarray(problem.A, float), np.asarray(problem.b, float),
                        rcond=None)[0]
    return Outcome("solved", z)


def singular(problem, tol=None, initvals=None):
    raise np.linalg.LinAlgError("Singular matrix")


def backends():
    return [Backend(name="plugin-lstsq", family="plugin", distributions=("fakeplugin",),
                    accepts=(LS,), solve=lstsq),
            Backend(name="plugin-singular", family="plugin", distributions=("fakeplugin",),
                    accepts=(LS,), solve=singular)]


TAKEN = Backend(name="numpy-kkt", family="plugin", distributions=(), accepts=(LS,),
                solve=lstsq)
'''

ENTRY_POINTS = """
[cardan_forces.solvers]
lstsq = fake_cardan_plugin:backends
missing = fake_cardan_plugin_absent:backends
taken = fake_cardan_plugin:TAKEN
"""


@pytest.fixture
def plugin(tmp_path, monkeypatch):
    """A distribution ``fakeplugin`` with three entry points (one good, one whose module
    does not exist, one whose name is taken), and a registry that loads afresh; the
    registry is as before afterwards.
    """
    (tmp_path / "fake_cardan_plugin.py").write_text(PLUGIN)
    info = tmp_path / "fakeplugin-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: fakeplugin\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(textwrap.dedent(ENTRY_POINTS))
    monkeypatch.syspath_prepend(str(tmp_path))
    yield from _fresh_registry()


REGISTRY = (registry._CACHE, registry._KNOWN, registry._PLUGIN_ERRORS, plugins.ORIGINS)
"""What the registry holds of loaded and registered backends."""


def _fresh_registry():
    """Empty the registry (it loads afresh on first use); as before afterwards."""
    saved = [dict(d) for d in REGISTRY]
    for d in REGISTRY:
        d.clear()
    yield
    for d, old in zip(REGISTRY, saved):
        d.clear()
        d.update(old)


@pytest.fixture(scope="module")
def op():
    return build_operator(simulate(load_scene("paper"), [0.5]))


def test_an_entry_point_backend_solves_and_is_judged_by_the_package(plugin, op):
    problem = build_formulation("min_norm", op, 0)
    theirs, ours = solve(problem, "plugin-lstsq"), solve(problem, "numpy-kkt")
    assert theirs.status is Status.SOLVED and theirs.residuals["equilibrium"] < 1e-10
    # lstsq's least norm is the SVD's: the same member of the rigid set
    assert np.allclose(theirs.x, ours.x, atol=1e-8 * np.abs(ours.x).max())
    failed = solve(problem, "plugin-singular")  # the plugin named by its distribution
    assert failed.status is Status.FAILED
    assert failed.message == "plugin fakeplugin (lstsq): LinAlgError: Singular matrix"


def test_broken_plugins_are_reported_not_fatal(plugin, capsys):
    assert main(["solvers"]) == 0
    captured = capsys.readouterr()
    assert any(line.split()[0] == "plugin-lstsq" and line.endswith("(plugin fakeplugin (lstsq))")
               for line in captured.out.splitlines())
    assert "fakeplugin 1.0" in captured.out
    errors = registry.plugin_errors()
    assert {k.split()[0] for k in errors} == {"missing", "taken"}
    assert "ModuleNotFoundError" in errors[next(k for k in errors if k.startswith("missing"))]
    assert "already registered" in errors[next(k for k in errors if k.startswith("taken"))]
    assert captured.err.count("not loaded") == 2
    assert registry.get("numpy-kkt").family != "plugin"  # the package's own kept its name


def test_solvers_json_stays_json_with_a_broken_plugin(plugin, capsys):
    assert main(["solvers", "--json"]) == 0
    names = [b["name"] for b in json.loads(capsys.readouterr().out)]
    assert "plugin-lstsq" in names


def test_register_at_run_time(plugin, op):
    mine = registry.get("plugin-lstsq")
    own = registry.Backend(name="my-lstsq", family="mine", distributions=(),
                           accepts=mine.accepts, solve=mine.solve)
    assert registry.register(own) is own and registry.register(own) is own
    assert "my-lstsq" in registry.backends_for(build_formulation("min_norm", op, 0))
    with pytest.raises(ValueError, match="already registered"):
        registry.register(registry.Backend(name="my-lstsq", family="mine", distributions=(),
                                           accepts=mine.accepts, solve=mine.solve))
    with pytest.raises(TypeError):
        registry.register("my-lstsq")


BROKEN = '''
import sys

import numpy as np
from cardan_forces.formulations.batch import LeastNormBatch
from cardan_forces.formulations.problems import LS
from cardan_forces.solvers import Backend, Outcome
from cardan_forces.solvers.record import BatchOutcome

print("a plugin that talks while it loads")


def lstsq(problem, tol=None, initvals=None):
    z = np.linalg.lstsq(np.asarray(problem.A, float), np.asarray(problem.b, float),
                        rcond=None)[0]
    return Outcome("solved", z)


def explode(*args, **kwargs):
    raise RuntimeError("the plugin's own bug")


def exit_now():
    sys.exit(3)


def made(name, **fields):
    return Backend(**{"name": name, "family": "broken", "distributions": ("fakebroken",),
                      "accepts": (LS,), "solve": lstsq, **fields})


GOOD = made("broken-good")
STRING_ACCEPTS = made("string-accepts", accepts=("QP",))
NO_DISTRIBUTIONS = made("no-distributions", distributions=None)
NO_NAME = made(None)
MIXED = [made("mixed-good"), made("", supports="yes")]
SUPPORTS_RAISES = made("supports-raises", supports=explode)
SOLVE_RAISES = made("solve-raises", solve=explode)
DICT_ANSWER = made("dict-answer", solve=lambda problem, **kw: {"z": [0.0]})
INT_ANSWER = made("int-answer", solve=lambda problem, **kw: 3)
RAGGED_ANSWER = made("ragged-answer",
                     solve=lambda problem, **kw: Outcome("solved", [[1.0], [2.0, 3.0]]))
SHORT_ANSWER = made("short-answer", solve=lambda problem, **kw: Outcome("solved", np.zeros(3)))
SOLVE_EXITS = made("solve-exits", solve=lambda problem, **kw: exit_now())
ODD_STATUS = made("odd-status", solve=lambda problem, **kw: Outcome(["solved"], None))
BATCH_INT = made("batch-int", solve=None, batch=lambda batch, **kw: 7,
                 batch_accepts=(LeastNormBatch,))
BATCH_SCALAR = made("batch-scalar", solve=None, batch_accepts=(LeastNormBatch,),
                    batch=lambda batch, **kw: BatchOutcome("solved", np.zeros(3), None, 0, 0, 0))
NOT_A_BACKEND = "lstsq"
'''

EXITS_ON_IMPORT = "import sys\nsys.exit(3)\n"

BROKEN_POINTS = {
    "good": "GOOD", "string_accepts": "STRING_ACCEPTS", "no_distributions": "NO_DISTRIBUTIONS",
    "no_name": "NO_NAME", "mixed": "MIXED", "supports_raises": "SUPPORTS_RAISES",
    "solve_raises": "SOLVE_RAISES", "dict_answer": "DICT_ANSWER", "int_answer": "INT_ANSWER",
    "ragged_answer": "RAGGED_ANSWER", "odd_status": "ODD_STATUS", "batch_int": "BATCH_INT",
    "batch_scalar": "BATCH_SCALAR",
    "not_a_backend": "NOT_A_BACKEND", "solve_exits": "SOLVE_EXITS",
    "short_answer": "SHORT_ANSWER",
    "exit_call": "exit_now",
}
"""Entry points of the broken plugin: name -> attribute of its module."""
REFUSED = {"string_accepts": "accepts", "no_distributions": "distributions",
           "no_name": "name", "mixed": "supports", "not_a_backend": "gives str",
           "exit_call": "SystemExit: 3", "exits_on_import": "SystemExit: 3"}
"""The entry points that register nothing (or not all they give), with what their
:func:`plugin_errors` entry must name."""
FAILING = ("supports-raises", "solve-raises", "dict-answer", "int-answer", "ragged-answer",
           "odd-status", "solve-exits", "short-answer")
"""Registered backends whose every solve is a failed record."""


def _points():
    group = registry.ENTRY_POINTS
    points = [metadata.EntryPoint(name, f"fake_broken_plugin:{attr}", group)
              for name, attr in BROKEN_POINTS.items()]
    return points + [metadata.EntryPoint("exits_on_import", "fake_exiting_plugin:GOOD", group)]


@pytest.fixture
def broken(tmp_path, monkeypatch):
    """Installed entry points of a plugin with every fault class, and one that exits
    while it is imported; a registry that loads them afresh, as before afterwards.
    """
    (tmp_path / "fake_broken_plugin.py").write_text(BROKEN)
    (tmp_path / "fake_exiting_plugin.py").write_text(EXITS_ON_IMPORT)
    monkeypatch.syspath_prepend(str(tmp_path))
    real = metadata.entry_points

    def entry_points(**selection):  # other groups (other packages' plugins) as installed
        return _points() if selection == {"group": registry.ENTRY_POINTS} else real(**selection)

    monkeypatch.setattr(metadata, "entry_points", entry_points)
    yield from _fresh_registry()
    sys.modules.pop("fake_broken_plugin", None)  # imported afresh (and heard) each time


def _backend(**fields):
    return registry.Backend(**{"name": "mine", "family": "mine", "distributions": (),
                               "accepts": (LS,), "solve": lambda p, **kw: None, **fields})


@pytest.mark.parametrize(("fields", "named"), [
    ({"accepts": ("QP",)}, "accepts"), ({"accepts": QP}, "accepts"),
    ({"accepts": (dict,)}, "accepts"), ({"distributions": None}, "distributions"),
    ({"distributions": ("",)}, "distributions"), ({"name": None}, "name"),
    ({"name": ""}, "name"), ({"name": "two words"}, "name"), ({"family": 3}, "family"),
    ({"solve": "clarabel"}, "solve"), ({"supports": None}, "supports"),
    ({"solve": None}, "neither solve nor batch"), ({"accepts": ()}, "accepts names no"),
    ({"tolerances": "eps"}, "tolerances"), ({"smallest_tol": float("nan")}, "smallest_tol"),
    ({"warm_start": "yes"}, "warm_start"), ({"batch_accepts": (LS,)}, "batch_accepts"),
])
def test_a_backend_is_validated_when_registered_with_the_field_named(fields, named):
    before = registry.available()
    with pytest.raises(InvalidBackend, match=named) as refused:
        cf.register(_backend(**fields))
    assert "takes" not in str(refused.value)  # not "takes ['QP'], not QP"
    assert isinstance(refused.value, TypeError) and isinstance(refused.value, ValueError)
    assert registry.available() == before


def test_the_package_s_own_backends_pass_the_validation():
    for backend in registry.available().values():
        plugins.validate(backend)


def test_a_plugin_that_breaks_at_import_or_declaration_leaves_the_rest_registered(broken):
    names = registry.available()
    assert {"broken-good", "mixed-good", *FAILING, "batch-int"} <= set(names)
    assert names["numpy-kkt"].family != "broken"
    errors = {k.split()[0]: why for k, why in registry.plugin_errors().items()}
    assert set(errors) == set(REFUSED)
    for point, named in REFUSED.items():
        assert named in errors[point], (point, errors[point])


def test_a_keyboard_interrupt_while_loading_a_plugin_is_not_swallowed(tmp_path, monkeypatch):
    (tmp_path / "fake_interrupting_plugin.py").write_text("raise KeyboardInterrupt\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    point = metadata.EntryPoint("stop", "fake_interrupting_plugin:X", registry.ENTRY_POINTS)
    with pytest.raises(KeyboardInterrupt):
        registry._load_plugins([point])


def test_cardan_solvers_lists_every_valid_backend_despite_broken_plugins(broken, capsys):
    assert main(["solvers", "--json"]) == 0
    captured = capsys.readouterr()
    listed = {b["name"]: b for b in json.loads(captured.out)}  # the plugin's print: stderr
    assert {"numpy-kkt", "broken-good", *FAILING} <= set(listed)
    assert listed["broken-good"]["origin"] == "plugin entry point good"
    assert listed["numpy-kkt"]["origin"] is None  # the package's own
    assert "a plugin that talks" in captured.err
    assert captured.err.count("not loaded") == len(REFUSED)


def test_cardan_solve_gives_each_broken_backend_a_failed_row_and_runs_the_rest(broken, capsys):
    assert main(["solve", "--json", "--formulation", "min_norm"]) == 0
    rows = {r["solver"]: r for r in json.loads(capsys.readouterr().out)}
    assert rows["numpy-kkt"]["status"] == "solved"
    assert rows["broken-good"]["status"] == "solved"
    for name in FAILING:
        assert rows[name]["status"] == "failed", name
        point = name.replace("-", "_")  # the plugin's name (no distribution: its entry point)
        assert rows[name]["message"].startswith(f"plugin entry point {point}: "), name
    assert "the plugin's own bug" in rows["supports-raises"]["message"]
    assert "returned dict" in rows["dict-answer"]["message"]
    assert "returned int" in rows["int-answer"]["message"]


@pytest.mark.slow  # every formulation by every backend; the broken plugins' failed rows stay
# held in the default run by the --json test above, their refusals by the loading tests
def test_cardan_solve_prints_the_whole_table_with_broken_backends(broken, capsys):
    assert main(["solve"]) == 0
    captured = capsys.readouterr()
    lines = captured.out.splitlines()
    assert captured.err.count("cardan solve: plugin") == len(REFUSED)  # and why not
    for name in FAILING:
        assert any(line.split()[1:3] == [name, "failed"] for line in lines[2:]), name


@pytest.mark.parametrize(("name", "said"), [("batch-int", "returned int"),
                                          ("batch-scalar", "must have 1 rows")])
def test_a_batched_plugin_that_answers_nonsense_is_a_failed_batch(broken, op, name, said):
    batch = least_norm_batch(op, "min_norm", [0])
    assert name in registry.batch_backends(batch)
    record = registry.solve_batch(batch, name)
    assert list(record.status) == ["failed"]
    assert record.message[0].startswith(f"plugin entry point {name.replace('-', '_')}: ")
    assert said in record.message[0]


def test_cardan_bench_runs_beside_broken_plugins(broken, tmp_path, capsys):
    assert main(["bench", "--quick", "--json", "--formulation", "min_norm", "--solver",
                 "numpy-kkt", "--solver", "int-answer", "--solver", "supports-raises",
                 "--solver", "batch-int", "--out", str(tmp_path)]) == 0
    rows = {r["solver"]: r for r in json.loads(capsys.readouterr().out)["throughput"]}
    assert rows["numpy-kkt"]["success_rate"] == 1.0
    for name in ("int-answer", "supports-raises", "batch-int"):  # a row each, all failed
        assert rows[name]["success_rate"] == 0.0 and rows[name]["instants"] > 0, name


def test_a_plugin_s_answers_the_checks_refuse_fail_with_its_name(broken, op):
    """A z of the wrong length passes the first look and fails in the check pass: the
    failed records still name the plugin."""
    history = cf.solve_over_time(op, "min_norm", "short-answer")
    assert set(history.statuses) == {Status.FAILED}
    assert history.records[0].message.startswith("plugin entry point short_answer: ")


def test_an_answer_the_check_pass_cannot_read_fails_alone(broken, monkeypatch):
    """Where the check pass over all instants raises on one plugin answer, the others
    keep their judged records and that one is a failed record saying why."""
    three = cf.build_operator(simulate(load_scene("paper"), [0.5, 0.6, 0.7]))
    real = registry.finalize_all

    def fragile(problems, solver, outcomes, **kw):
        if solver == "numpy-kkt" or any(o.message == "unreadable" for o in outcomes):
            raise FloatingPointError("cannot read this answer")
        return real(problems, solver, outcomes, **kw)

    good, marks = registry.get("broken-good"), iter(["", "unreadable", ""])
    cf.register(dataclasses.replace(good, name="second-unreadable", solve=lambda p, **kw: (
        dataclasses.replace(good.solve(p, **kw), message=next(marks)))))
    monkeypatch.setattr(registry, "finalize_all", fragile)
    history = cf.solve_over_time(three, "min_norm", "second-unreadable")
    assert [str(s) for s in history.statuses] == ["solved", "failed", "solved"]
    assert "answer could not be checked: FloatingPointError" in history.records[1].message
    assert history.records[1].message.startswith("registered from ")
    with pytest.raises(FloatingPointError):  # the package's own backends: not hidden
        cf.solve_over_time(three, "min_norm", "numpy-kkt", instants=[1])
