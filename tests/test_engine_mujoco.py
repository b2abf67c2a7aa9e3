"""MuJoCo as a peer engine: its forces against the rigid model's (physics, not numbers).

Tolerances: the engine's constraints are soft (default time constant 2 ms): the line
sags ~1e-5 m into its bearings, so its forces carry a relative error of that order
against the rigid model; the tests allow 1e-4 of the load.
"""

import dataclasses
import sys

import numpy as np
import pytest

pytest.importorskip("mujoco")

from cardan_forces.driveline import engine_mujoco as em  # noqa: E402
from cardan_forces.formulations.convex import NotApplicable  # noqa: E402

import cardan_forces as cf  # noqa: E402

TIMES = np.array([0.0, 0.05, 0.1])  # 0.05 s and later: settled (25 time constants)
SETTLED = slice(1, None)
RTOL = 1e-4


def _operator(scene):
    return cf.build_operator(cf.simulate(scene, TIMES))


@pytest.fixture(scope="module", params=["paper", "paper-slip"])
def engine(request):
    op = _operator(cf.load_scene(request.param))
    return op, em.run(op)


def _load(op, i):
    return np.abs(op.b[i]).max()


def test_determinate_components_agree_with_the_rigid_model(engine):
    op, run = engine
    for i in range(len(TIMES))[SETTLED]:
        det = cf.determinacy(op, i)
        x = run.forces[i, det.determinate]
        assert np.abs(x - det.min_norm[det.determinate]).max() <= RTOL * _load(op, i)


def test_engine_forces_satisfy_the_rigid_equilibrium(engine):
    op, run = engine
    for i in range(len(TIMES))[SETTLED]:
        residual = np.linalg.norm(op.A[i] @ run.forces[i] - op.b[i]) / np.linalg.norm(op.b[i])
        assert residual <= RTOL
    assert run.mapping_residual.max() <= RTOL * _load(op, 1)


def test_engine_follows_the_package_motion(engine):
    op, run = engine
    motion = cf.simulate(op.scene, TIMES)
    assert np.abs(run.q - motion.q).max() <= 1e-6 * max(1.0, np.abs(motion.q).max())


def test_relative_softness_moves_only_what_the_rigid_model_leaves_free():
    """Softer output bearings move the in-plane bearing loads of ``paper`` (the loop's
    self-stress runs through them) and leave those of ``paper-slip`` (determinate).
    """
    softer = em.Softness(scaled=(("output", 4.0),))
    moved = {}
    for name in ("paper", "paper-slip"):
        op = _operator(cf.load_scene(name))
        j = op.index("bearing.input.near.z")
        moved[name] = abs(em.run(op, softer).forces[-1, j] - em.run(op).forces[-1, j])
        det = cf.determinacy(op, len(TIMES) - 1)
        assert det.determinate[j] == (name == "paper-slip")
    scale = _load(_operator(cf.load_scene("paper")), -1)
    assert moved["paper"] > 0.05 * scale
    assert moved["paper-slip"] < RTOL * scale


def test_floating_bearing_carries_no_axial_force():
    scene = cf.load_scene("paper")
    input_shaft = scene.shafts[0]
    far = dataclasses.replace(input_shaft.bearings[0], kind="floating")
    shafts = (dataclasses.replace(input_shaft, bearings=(far, input_shaft.bearings[1])),
              *scene.shafts[1:])
    op = _operator(dataclasses.replace(scene, shafts=shafts))
    run = em.run(op)
    residual = np.linalg.norm(op.A[-1] @ run.forces[-1] - op.b[-1]) / np.linalg.norm(op.b[-1])
    assert residual <= RTOL
    assert run.mapping_residual[SETTLED].max() <= RTOL * _load(op, -1)


def test_slip_joint_with_friction_is_refused_by_name():
    scene = cf.load_scene("paper-slip")
    slip = dataclasses.replace(scene.elements[0], friction_coefficient=0.1)
    with pytest.raises(em.EngineUnsupported, match="slip joint 'slip' has friction"):
        em.check_expressible(dataclasses.replace(scene, elements=(slip,)))


def test_quasi_static_scene_is_refused_before_any_work():
    from cardan_forces.experiments.engine import study

    with pytest.raises(NotApplicable, match="'inertia'"):
        study("propshaft")


def test_missing_engine_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)
    with pytest.raises(em.EngineUnsupported, match=r"\[mujoco\]"):
        em.mujoco_version()


@pytest.fixture(scope="module")
def repro_run(tmp_path_factory):
    from cardan_forces.paper_repro import repro

    out = tmp_path_factory.mktemp("repro_engine")
    report = repro.run_repro(figs=(14,), out=out, quick=True, methods=("positive", "engine"),
                             formats=("png", "svg"), workers=0, progress=lambda _: None)
    return out, report.read_text()


def test_repro_draws_the_engine_inside_the_rigid_band(repro_run):
    """The figure's CSV holds the band and one curve per softness setting; every engine
    load after the settling lies inside the band (the engine's forces are members of the
    rigid set), and the settings put the indeterminate axial load at different members.
    """
    from cardan_forces.experiments.engine import FIGURE_SETTINGS
    from cardan_forces.paper_repro.figures import read_csv

    out, _ = repro_run
    assert (out / "engine.png").exists() and (out / "engine.svg").exists()
    cols = read_csv(out / "engine.csv")
    curves = [k for k in cols if k.startswith("axial_engine")]
    assert len(curves) == len(FIGURE_SETTINGS)
    settled = cols["t"] >= 0.08
    load = max(np.abs(cols[k]).max() for k in cols if "_engine" in k)
    for q in ("near_radial", "far_radial", "axial"):
        lo, hi = cols[f"{q}_set_min"], cols[f"{q}_set_max"]
        checked = settled & ~np.isnan(lo)
        assert checked.any()
        for k in range(len(FIGURE_SETTINGS)):
            v = cols[f"{q}_engine{k}"][checked]
            assert np.all(v >= lo[checked] - RTOL * load)
            assert np.all(v <= hi[checked] + RTOL * load)
    axial = np.array([cols[k][settled] for k in curves])
    assert np.ptp(axial, axis=0).min() > 0.05 * load


def test_repro_report_says_where_the_engine_lies(repro_run):
    _, report = repro_run
    section = report.split("## MuJoCo beside the rigid set")[1]
    assert "`engine.csv`, `engine.png`, `engine.svg`" in section
    for words in ("inside the rigid band", "closest formulation", "per simulated second"):
        assert words in section


def test_repro_runs_the_engine_by_default_where_it_is_installed():
    from cardan_forces.paper_repro import repro

    assert "engine" in repro.default_methods()


@pytest.mark.slow
def test_report_with_the_engine_overlays_members_of_the_rigid_set(tmp_path, capsys):
    """``cardan report --engine`` on ``paper`` over its first 0.1 s (3 instants): the
    engine's column is empty before the settling and after it every value lies in its
    component's interval (the determinate ones on the rigid value); the report's counts
    are those of its own CSV."""
    import csv
    import re

    from cardan_forces.cli import main

    scene = tmp_path / "short.toml"
    assert main(["scene", "dump", "paper"]) == 0
    text = capsys.readouterr().out
    scene.write_text(re.sub(r"stop_s = [0-9.]+", "stop_s = 0.1", text))
    out = tmp_path / "report"
    assert main(["report", str(scene), "--instants", "3", "--engine", "--out", str(out),
                 "--quiet"]) == 0
    rows = list(csv.DictReader((out / "report.csv").read_text().splitlines()))
    load = max(abs(float(r["positive_N"])) for r in rows)
    settled = [r for r in rows if float(r["t_s"]) > 0]
    assert all(r["engine_N"] == "" for r in rows if float(r["t_s"]) == 0)
    for r in settled:
        v = float(r["engine_N"])
        lo = float(r["min_N"]) if r["min_N"] else -np.inf
        hi = float(r["max_N"]) if r["max_N"] else np.inf
        assert lo - RTOL * load <= v <= hi + RTOL * load, r
    free = sum(r["determinate"] == "False" for r in settled)
    md = (out / "report.md").read_text().split("## MuJoCo beside the rigid set")[1]
    assert f"inside their interval: {free} of {free}" in md and "outside: none" in md
