"""``cardan compile`` compiles what a first run would: every module that defines numba
kernels is in one of its families, and each family's warm-up compiles (or loads) the
kernels a run calls."""

import argparse
import importlib
import pkgutil
from pathlib import Path

import pytest

try:
    import tomllib
except ImportError:  # Python 3.10
    import tomli as tomllib

from cardan_forces.commands import compile as compile_command


def _package_modules():
    """Every module of the installed package (its subpackages as pyproject lists them)."""
    config = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())
    for package in config["tool"]["setuptools"]["packages"]:
        for info in pkgutil.iter_modules(importlib.import_module(package).__path__):
            yield importlib.import_module(f"{package}.{info.name}")


def _defines_kernels(module) -> bool:
    from numba.core.dispatcher import Dispatcher

    return any(isinstance(v, Dispatcher) and v.py_func.__module__ == module.__name__
               for v in vars(module).values())


def test_every_module_with_numba_kernels_is_in_a_family():
    """The compile list covers every module that defines a numba kernel, so that no
    kernel family is left for a first run to compile."""
    pytest.importorskip("numba")
    listed = {f"cardan_forces.{m}" for f in compile_command.FAMILIES for m in f.modules}
    kernels = {m.__name__ for m in _package_modules() if _defines_kernels(m)}
    assert {"cardan_forces.solvers._newton_kernels",
            "cardan_forces.driveline.penalty_contact"} <= kernels  # the walk finds them
    assert kernels - listed == set()
    assert listed - kernels == set()  # and names no module without kernels


def test_compile_warms_every_family_in_order_and_names_the_caches(monkeypatch, capsys):
    pytest.importorskip("numba")
    from cardan_forces.experiments import progress

    monkeypatch.setitem(progress._STATE, "quiet", False)  # as a run without --quiet
    calls = []
    families = tuple(compile_command.Family(f.what, f.modules,
                                            lambda what=f.what: calls.append(what))
                     for f in compile_command.FAMILIES)
    monkeypatch.setattr(compile_command, "FAMILIES", families)
    assert compile_command.run(argparse.Namespace()) == 0
    assert calls == [f.what for f in families]
    last = capsys.readouterr().err.strip().splitlines()[-1]
    folders = compile_command.cache_folders()
    assert f"({len(families)})" in last and all(folder in last for folder in folders)
    assert len(folders) == 2  # driveline's and solvers' (or NUMBA_CACHE_DIR's own two)


@pytest.mark.compiled
def test_the_batched_and_newton_warm_ups_compile_their_entries():
    """The warm-ups a run would otherwise do first (the penalty simulation's is left to
    the repro's tests: minutes cold)."""
    pytest.importorskip("numba")
    from cardan_forces.solvers import _batched_kernels, _newton_kernels

    by_module = {f.modules[0]: f for f in compile_command.FAMILIES}
    by_module["solvers._batched_kernels"].warm()
    by_module["solvers._newton_kernels"].warm()
    assert _batched_kernels.least_norm.signatures  # compiled (or loaded) by the batch
    assert _newton_kernels.newton.signatures
