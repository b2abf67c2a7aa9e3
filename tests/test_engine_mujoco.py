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
from cardan_forces.driveline.loading import builtin_names  # noqa: E402

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


def test_a_quasi_static_scene_is_refused_unless_taken_in_motion():
    """The engine integrates dynamics: a quasi-static scene is refused as it is, taken
    by ``cardan engine`` in motion (:meth:`Scene.in_motion`)."""
    scene = cf.load_scene("propshaft")
    with pytest.raises(em.EngineUnsupported, match="'inertia'"):
        em.check_expressible(scene)
    em.check_expressible(scene.in_motion())


def _in_motion(name):
    """The quasi-static built-in scene ``name`` in motion, its operator every 0.02 s up
    to 0.2 s and its governor (as ``cardan engine`` runs it)."""
    from cardan_forces.driveline.dynamics import reduced_inertia

    times = np.arange(0.0, 0.2 + 1e-9, 0.02)
    scene = cf.load_scene(name).in_motion()
    motion = cf.simulate(scene, times)
    governor = em.Governor(motion.t, motion.q, motion.qd,
                           float(reduced_inertia(scene, motion.kin)[0][0]))
    return cf.build_operator(motion), governor


def _relative_residual(op, run, settled):
    r = np.einsum("tij,tj->ti", op.A, run.forces) - op.b
    return np.abs(r[settled]).max() / np.abs(op.b[settled]).max()


def test_the_governor_holds_a_quasi_static_line_on_the_rigid_motion():
    """A small inertia: without the governor the engine's speed drifts away with the
    energy its soft constraints dissipate (double-cardan reverses within 0.4 s); with it
    the engine follows the rigid set's motion, by a torque small beside the line's."""
    op, governor = _in_motion("double-cardan")
    run = em.run(op, em.Softness(), governor)
    speed = op.scene.initial_speed_rad_s
    assert np.abs(run.qd - governor.qd).max() < 0.01 * speed
    assert 0 < run.governed_N_m < 0.05 * op.scene.input_torque.mean_N_m


def test_the_cv_joints_hinges_turn_the_driven_shaft_at_the_driving_speed():
    """halfshaft's two CV joints as three hinges with a homokinetic coupling
    (:meth:`CV.mjcf_steps`): the hub turns at the side gear's speed at 6 and 10 deg, and
    the joints' wrenches are carried by their four columns (the moment about the
    bisector) within 1 % of the torque; the engine's forces satisfy ``A x = b`` to 1 %."""
    import mujoco

    op, governor = _in_motion("halfshaft")
    model = mujoco.MjModel.from_xml_string(em.build_mjcf(op))
    data = mujoco.MjData(model)
    chain = em._chain(op)
    em._initial_velocity(mujoco, model, data, op, chain)
    apply = em._torques(mujoco, model, op, chain)
    for k in range(800):
        data.xfrc_applied[:] = 0.0
        apply(data, k * model.opt.timestep)
        mujoco.mj_step(model, data)
    spin = {b.name: data.cvel[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, b.name)][:3]
            for b in chain}
    axes = em.rest_geometry(op.scene).axes
    assert spin["hub"] @ axes[-1] == pytest.approx(spin["side_gear"] @ axes[0], rel=1e-3)
    run = em.run(op, em.Softness(), governor)
    torque = op.scene.input_torque.mean_N_m
    assert run.mapping_residual[3:].max() < 0.01 * torque
    assert _relative_residual(op, run, slice(3, None)) < 0.01


def test_the_disc_couplings_springs_carry_the_line_torque():
    """propshaft-disc's disc as six sprung joints (:meth:`Disc.mjcf_steps`): the engine
    runs stably at its step, the disc carries the line's torque (determinate: the input
    over the first joint's ratio, 6 deg, bounds it) and ``A x = b`` holds to 5 % (the
    soft disc bends by degrees, off the rest geometry the rigid model keeps)."""
    op, governor = _in_motion("propshaft-disc")
    run = em.run(op, em.Softness(), governor)
    torque = run.forces[5:, op.names.index("disc.torque")]
    T = op.scene.input_torque.mean_N_m
    assert np.all(np.isfinite(run.forces))
    assert np.all((0.98 * T < torque) & (torque < 1.02 * T / np.cos(np.radians(6.0))))
    assert _relative_residual(op, run, slice(5, None)) < 0.05


def test_the_centring_ball_and_the_gear_mesh_run_in_mujoco():
    """double-cardan's centring ball, closed outside the tree by a carrier, and
    light-truck's hypoid mesh, applied as forces at its point: each engine run finishes
    with forces that satisfy ``A x = b``; the mesh's to 0.1 %, the ball line's (1500 N m
    on a short centre yoke deflects the soft bearings) to 2 % at a stiffer softness."""
    op, governor = _in_motion("light-truck")
    run = em.run(op, em.Softness(), governor)
    assert _relative_residual(op, run, slice(3, None)) < 1e-3
    op, governor = _in_motion("double-cardan")
    run = em.run(op, em.Softness(timeconst_s=0.0005), governor)
    assert np.all(np.isfinite(run.forces[:, op.names.index("ball.r1")]))
    assert _relative_residual(op, run, slice(3, None)) < 0.02


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


@pytest.mark.slow
@pytest.mark.parametrize("name", builtin_names())
def test_cardan_engine_runs_on_every_built_in_scene(name, tmp_path):
    """Every built-in scene, dynamic or quasi-static, with every kind it holds: the
    command writes its report (MuJoCo; Drake where it can)."""
    from cardan_forces.cli import main

    assert main(["engine", name, "--stop", "0.1", "--instants", "3", "--out",
                 str(tmp_path), "--quiet"]) == 0
    assert "Agreement with the rigid model" in (tmp_path / "engine.md").read_text()


def test_the_governors_reference_is_the_hermite_curve_through_the_motion():
    """At the motion's instants the governor pushes by its lag alone; between them the
    reference is the cubic through the angles and speeds (exact for a cubic motion)."""
    t = np.linspace(0.0, 1.0, 6)
    q, qd = 2 * t**3 - t**2 + 3 * t, 6 * t**2 - 2 * t + 3
    governor = em.Governor(t, q, qd, inertia=2.0, time_s=0.1)
    assert governor.torque(t[2], q[2], qd[2]) == pytest.approx(0.0, abs=1e-9)
    x = 0.33
    exact, speed = 2 * x**3 - x**2 + 3 * x, 6 * x**2 - 2 * x + 3
    assert governor.torque(x, exact, speed) == pytest.approx(0.0, abs=1e-9)
    assert governor.torque(x, exact - 0.01, speed) == pytest.approx(2.0 * 0.01 / 0.1**2)
    assert governor.torque(x, exact, speed - 0.5) == pytest.approx(2.0 * 2 * 0.5 / 0.1)
