"""The angular-contact bearing kind and the axle-pinion scene: an O pair locates its
shaft, its axial split is a pair complementarity resolves, and independent methods and
element kinds agree on what the rigid model determines."""

import math

import numpy as np
import pytest
from cardan_forces.driveline import penalty
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene, scene_from_dict
from cardan_forces.driveline.modes import counts
from cardan_forces.driveline.release import named_modes
from cardan_forces.driveline.scene import SceneError
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.formulations.convex import contact_laws
from cardan_forces.solvers import solve

from cardan_forces.cli import main

TIMES = [0.25, 0.5, 1.0]
SLIP = [{"name": "spline", "shaft": "intermediate", "offset_m": 0.0, "pitch_radius_m": 0.02}]
TAIL, HEAD = "bearing.pinion.tail.axial", "bearing.pinion.head.axial"


def _pinion(*bearings, **changes):
    """The axle-pinion scene with the pinion's bearings replaced."""
    from cardan_forces.driveline.loading import builtin_text

    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib
    raw = tomllib.loads(builtin_text("axle-pinion"))
    raw["shafts"][2]["bearings"] = list(bearings)
    return scene_from_dict({**raw, "name": "pinion-variant", **changes})


def _angular(name, offset, pushes, angle=15.0, **more):
    return {"name": name, "offset_m": offset, "kind": "angular-contact",
            "contact_angle_deg": angle, "pushes": pushes, **more}


@pytest.fixture(scope="module")
def op():
    return build_operator(simulate(load_scene("axle-pinion"), TIMES))


def test_the_pair_is_a_mode_complementarity_resolves(op):
    """Nullity = the named modes: the paper's four end-face pairs, axial split and
    loop, and one bearing pair moving exactly the two axial pushes."""
    motion = simulate(load_scene("axle-pinion"), [0.5])
    modes = named_modes(motion, 0)
    assert counts(modes) == {"end-face pair": 4, "bearing pair": 1, "axial split": 1,
                             "closed loop": 1}
    assert determinacy(build_operator(motion), 0).nullity == len(modes)
    (pair,) = [m for m in modes if m.kind == "bearing pair"]
    assert set(pair.components) == {TAIL, HEAD}
    assert (op.index(TAIL), op.index(HEAD)) in op.pairs


@pytest.mark.parametrize("formulation", ["positive", "lcp", "compliance",
                                         "compliance_hertz", "min_max"])
def test_every_method_keeps_the_axial_pushes_one_way(op, formulation):
    """Both pushes >= 0 wherever the formulation imposes signs; where it imposes
    complementarity (all but min_max), one of them is zero."""
    for i in range(len(TIMES)):
        record = solve(FORMULATIONS[formulation](op, i), "clarabel" if formulation != "lcp"
                       else "lcp-lemke")
        assert record.status == "solved"
        tail, head = record.x[op.index(TAIL)], record.x[op.index(HEAD)]
        scale = 1e-6 * np.abs(op.b[i]).max()
        assert min(tail, head) >= -scale
        if formulation != "min_max":
            assert min(tail, head) <= scale


def test_a_pair_carries_what_a_locating_and_a_floating_bearing_carry():
    """With the loop released (a spline in the intermediate shaft), the pinion's radial
    loads and its net axial load are determinate; they equal those of the same pinion
    on a locating bearing at the head and a floating one at the tail (other kinds, other
    columns, the same statics)."""
    pair = _pinion(_angular("tail", -0.10, "upstream"), _angular("head", 0.08, "downstream"),
                   slip_joints=SLIP)
    plain = _pinion({"name": "tail", "offset_m": -0.10, "kind": "floating"},
                    {"name": "head", "offset_m": 0.08}, slip_joints=SLIP)
    a, b = (build_operator(simulate(s, TIMES)) for s in (pair, plain))
    for i in range(len(TIMES)):
        da, db = determinacy(a, i), determinacy(b, i)
        la = a.bearing_loads(da.min_norm, shaft=2)
        lb = b.bearing_loads(db.min_norm, shaft=2)
        tol = 1e-9 * np.abs(a.b[i]).max()
        for name in ("tail", "head"):
            columns = [a.index(f"bearing.pinion.{name}.{c}") for c in ("r1", "r2")]
            assert da.determinate[columns].all()
            assert la[f"pinion.{name}"].in_plane[()] == pytest.approx(
                lb[f"pinion.{name}"].in_plane[()], abs=tol)
            assert la[f"pinion.{name}"].normal[()] == pytest.approx(
                lb[f"pinion.{name}"].normal[()], abs=tol)
        net = la["pinion.tail"].axial + la["pinion.head"].axial
        assert net == pytest.approx(lb["pinion.head"].axial, abs=tol)


def test_its_laws_take_the_contact_angle(op):
    """Compliance: radial k, axial k tan^2(alpha); penalty: one axial face, pushing the
    pinion the way the bearing pushes it (its force along the rigid column)."""
    scene = op.scene
    k = scene.contact.bearing_stiffness_N_m
    laws = {tuple(law.columns): law.stiffness for law in contact_laws(op)}
    assert laws[(op.index(HEAD),)] == pytest.approx(k * math.tan(math.radians(15.0)) ** 2)
    model = penalty._Model(scene, penalty.DAMPING_LENGTH_UNIT_M)
    for name in ("tail", "head"):
        link = next(c for c in op.contacts if c.name == f"bearing.pinion.{name}")
        rows = model.parts[op.contacts.index(link)]
        faces = [r for r in rows if not model.c.radial[r]]
        assert len(faces) == 1
        # the face's force on the shaft is along -e (its axis in the shaft's body frame)
        push = -model.start_frames[link.body] @ model.c.e[faces[0]]
        assert push == pytest.approx(op.directions[0, link.column("axial")], abs=1e-12)


@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
def test_penalty_run_touches_one_bearing_of_the_pair_at_a_time():
    """A short penalty run from rest: the pair's pushes are never both on (the pinion
    cannot touch both faces across its axial play) and never pull. As the operator's
    columns they are read from all the bearing's contacts, and a radial contact of a
    pinion tilted by its play leans by ~1e-5 rad: each allowed 1e-4 of the radial load."""
    result = penalty.simulate_penalty(load_scene("axle-pinion"),
                                      np.arange(0.0, 0.1 + 1e-9, 0.005))
    assert result.success
    f = result.forces
    tail, head = f[TAIL], f[HEAD]
    radial = sum(np.hypot(f[f"bearing.pinion.{b}.r1"], f[f"bearing.pinion.{b}.r2"])
                 for b in ("tail", "head"))
    assert np.all(np.minimum(tail, head) <= 1e-4 * radial)
    assert np.all(tail >= -1e-4 * radial) and np.all(head >= -1e-4 * radial)


@pytest.mark.parametrize("bearings, words", [
    ([_angular("tail", -0.1, "upstream"), _angular("head", 0.08, "upstream")],
     "more than one angular-contact bearing pushes upstream"),
    ([_angular("tail", -0.1, "upstream"), _angular("head", 0.08, "downstream", 30.0)],
     "different contact angles"),
    ([_angular("tail", -0.1, "upstream", 90.0), _angular("head", 0.08, "downstream")],
     "contact_angle_deg': 90 deg is outside 5 to 60 deg"),
    ([_angular("tail", -0.1, "sideways"), _angular("head", 0.08, "downstream")],
     "pushes': must be one of"),
    ([{"name": "tail", "offset_m": -0.1, "kind": "angular-contact", "pushes": "upstream"},
      _angular("head", 0.08, "downstream")], "contact_angle_deg': missing"),
    ([_angular("tail", -0.1, "upstream", rating={"type": "ball", "C_N": 1e4, "C0_N": 1e4}),
      _angular("head", 0.08, "downstream")], "rated as one of"),
    ([_angular("tail", -0.1, "upstream", rating={"type": "tapered_roller", "C_N": 1e4,
                                                 "C0_N": 1e4, "contact_angle_deg": 12.0}),
      _angular("head", 0.08, "downstream")], "differs from its rating"),
])
def test_bad_angular_contact_bearings_are_refused(bearings, words):
    with pytest.raises(SceneError, match=words):
        _pinion(*bearings)


def test_commands_take_the_scene(capsys, tmp_path):
    import json

    assert main(["scene", "check", "axle-pinion"]) == 0
    capsys.readouterr()
    assert main(["sets", "axle-pinion", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert "bearing pair" in {m["kind"] for m in report["modes"]}
    assert main(["sets", "axle-pinion", "--release"]) == 0
    assert "release advisor" in capsys.readouterr().out
    dumped = tmp_path / "pinion.toml"
    assert main(["scene", "dump", "axle-pinion"]) == 0
    dumped.write_text(capsys.readouterr().out)
    assert load_scene(dumped).shafts[2].bearings == load_scene("axle-pinion").shafts[2].bearings
