"""Backends of other packages: :func:`register` and the entry-point group
``cardan_forces.solvers``, with a distribution made in a temporary folder (on
``sys.path`` only, installed nowhere).
"""

from __future__ import annotations

import json
import textwrap

import numpy as np
import pytest
from cardan_forces.solvers import Status, plugins, registry, solve

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


def backends():
    return [Backend(name="plugin-lstsq", family="plugin", distributions=("fakeplugin",),
                    accepts=(LS,), solve=lstsq)]


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


def test_broken_plugins_are_reported_not_fatal(plugin, capsys):
    assert main(["solvers"]) == 0
    captured = capsys.readouterr()
    assert any(line.split()[0] == "plugin-lstsq" for line in captured.out.splitlines())
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
