"""The same answers on any install: a run over time by a formulation's default backend
does not depend on which optional solvers are installed, and solves every instant."""

import os
import re
from pathlib import Path

import numpy as np
import pytest
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import builtin_names, load_scene
from cardan_forces.experiments import study
from cardan_forces.formulations import BASELINE, FORMULATIONS
from cardan_forces.formulations.convex import NotApplicable
from cardan_forces.solvers import Status, available, registry
from figure_data import assert_same_figure


def _core_only(monkeypatch):
    """The registry as on a machine with the core dependencies alone (no extra)."""
    for name, backend in list(available().items()):
        if backend.extra is not None:
            monkeypatch.delitem(registry._CACHE, name)


@pytest.fixture(scope="module")
def paper_op():
    return build_operator(simulate(load_scene("paper"), np.linspace(0.0, 5.0, 201)))


@pytest.mark.parametrize("formulation", [f for f, r in FORMULATIONS.items()
                                         if r.least_norm_batch and r.physical])
def test_a_run_over_time_gives_the_same_forces_without_any_extra(paper_op, monkeypatch,
                                                                 formulation):
    full = study.solve_over_time(paper_op, formulation)
    _core_only(monkeypatch)
    core = study.solve_over_time(paper_op, formulation)
    assert core.solved == full.solved == len(paper_op.t)
    scale = np.abs(full.forces).max()
    assert np.abs(core.forces - full.forces).max() <= 1e-9 * scale


def _every_default_run():
    for scene in builtin_names():
        for name in FORMULATIONS:
            if name != BASELINE:  # a root finder's answer, not an optimum
                yield scene, name


@pytest.mark.slow
@pytest.mark.parametrize("scene,formulation", list(_every_default_run()))
def test_every_default_run_solves_every_instant_of_every_built_in_scene(scene, formulation):
    """With whatever is installed (CI runs it on the core dependencies alone too)."""
    op = build_operator(simulate(load_scene(scene)))
    try:
        history = study.solve_over_time(op, formulation)
    except NotApplicable:  # the formulation needs an effect the scene does not have
        pytest.skip(f"{formulation} does not apply to {scene}")
    bad = [(float(t), s.value) for t, s in zip(history.t, history.statuses)
           if s is not Status.SOLVED]
    assert not bad, f"{history.solver}: {len(bad)} instants not solved, first {bad[:3]}"


@pytest.mark.parametrize("formulation", [f for f in FORMULATIONS if f != BASELINE])
def test_a_single_instant_by_the_core_default_is_solved(paper_op, monkeypatch, formulation):
    """One instant at a time (a budgeted or custom-problem run) on the core dependencies:
    the default backend solves every instant asked for."""
    _core_only(monkeypatch)
    try:
        history = study.solve_over_time(paper_op, formulation, instants=range(0, 201, 40),
                                        budget_s=1e9)
    except NotApplicable:
        pytest.skip(f"{formulation} does not apply to paper")
    assert history.solved == 6, (history.solver, [s.value for s in history.statuses])


FULL_RUN, CORE_RUN = "CARDAN_FORCES_FULL_RUN", "CARDAN_FORCES_CORE_RUN"
"""Folders of one ``cardan repro`` run with every extra and one on the core
dependencies alone (CI makes both, in two environments, and runs the test below)."""


def _verdicts(report: str) -> list[str]:
    """The report's verdicts (its bold words) and the methods it calls no physical
    selection (the lines' numbers may differ in a last printed digit)."""
    return re.findall(r"\*\*(.+?)\*\*", report) + re.findall(
        r"`(\w+)`: both end faces of a pair push", report)


@pytest.mark.skipif(not (os.environ.get(FULL_RUN) and os.environ.get(CORE_RUN)),
                    reason=f"needs {FULL_RUN} and {CORE_RUN}: two repro runs to compare")
def test_the_core_install_draws_the_full_install_s_figures_and_verdicts():
    full, core = Path(os.environ[FULL_RUN]), Path(os.environ[CORE_RUN])
    figures = sorted(p.name for p in core.glob("fig*.csv"))
    assert figures and figures == sorted(p.name for p in full.glob("fig*.csv"))
    for name in figures:
        assert_same_figure(full / name, core / name)
    assert _verdicts((core / "report.md").read_text()) == \
        _verdicts((full / "report.md").read_text())
