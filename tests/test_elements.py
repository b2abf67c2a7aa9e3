"""Typed elements (floating bearings, slip joints), named modes, the release advisor and
the secondary-couple loads against the handbook closed forms."""

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

import numpy as np
import pytest
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import builtin_names, builtin_text, load_scene, scene_from_dict
from cardan_forces.driveline.modes import counts
from cardan_forces.driveline.release import advise, named_modes, released_operator
from cardan_forces.driveline.scene import SceneError
from cardan_forces.experiments import secondary
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.formulations.convex import NotApplicable
from cardan_forces.solvers import solve

from cardan_forces.cli import main


def _op(name, t=0.5):
    return build_operator(simulate(load_scene(name), [t]))


def test_paper_slip_every_radial_bearing_load_is_determinate():
    op = _op("paper-slip")
    d = determinacy(op, 0)
    assert (d.rank, d.nullity) == (35, 6)
    for c in op.of_kind("bearing-locating"):
        radial = [k for k, comp in zip(c.columns, c.components) if comp != "x"]
        assert d.determinate[radial].all(), c.name
    modes = counts(named_modes(simulate(load_scene("paper-slip"), [0.5]), 0, op))
    assert modes == {"end-face pair": 4, "axial split": 2, "closed loop": 0}


def test_paper_modes_are_named_and_count_the_nullity():
    motion = simulate(load_scene("paper"), [0.5])
    modes = named_modes(motion, 0)
    assert counts(modes) == {"end-face pair": 4, "axial split": 2, "closed loop": 1}
    loop = next(m for m in modes if m.kind == "closed loop")
    assert "intermediate" in loop.description and "uj1.pin" in loop.description
    assert loop.release == "add a slip joint in shaft intermediate"
    op = build_operator(motion)
    directions = np.array([m.direction for m in modes]).T
    assert np.abs(op.A[0] @ directions).max() < 1e-9
    assert np.linalg.matrix_rank(directions, tol=1e-9) == 7


def test_propshaft_has_only_end_face_pair_modes():
    motion = simulate(load_scene("propshaft"), [0.3])
    op = build_operator(motion)
    d = determinacy(op, 0)
    assert counts(named_modes(motion, 0, op)) == {"end-face pair": 6, "axial split": 0,
                                                  "closed loop": 0}
    bearing_cols = [k for c in op.of_kind("bearing-locating", "bearing-floating")
                    for k in c.columns]
    assert d.determinate[bearing_cols].all()
    assert d.residual < 1e-10


@pytest.mark.parametrize("name, size", [("paper", 3), ("paper-slip", 2), ("propshaft", 0)])
def test_advisor_releases_are_verified_by_determinacy(name, size):
    motion = simulate(load_scene(name), [0.5])
    advice = advise(motion, 0)
    assert len(advice.releases) == size
    # re-run determinacy on the released scene independently of the advisor
    op = released_operator(motion, advice.releases)
    d = determinacy(op, 0)
    assert d.nullity == len(op.pairs)
    assert d.residual < 1e-10
    for c in op.of_kind("bearing-locating", "bearing-floating"):
        assert d.determinate[list(c.columns)].all()


def test_floating_bearing_has_two_radial_components():
    op = build_operator(simulate(load_scene("propshaft"), [0.1]))
    c = next(c for c in op.contacts if c.name == "bearing.gearbox.front")
    assert c.kind == "bearing-floating" and c.components == ("r1", "r2")
    axis = op.shaft_frames[c.shaft, 2]
    # neither column pushes along the shaft axis
    assert np.abs(op.A[0][6 * c.body: 6 * c.body + 3, list(c.columns)].T @ axis).max() < 1e-12


def _slip(**fields):
    base = {"name": "s", "shaft": "intermediate", "pitch_radius_m": 0.02}
    return {"extends": "paper", "name": "bad", "slip_joints": [{**base, **fields}]}


@pytest.mark.parametrize("raw, words", [
    (_slip(friction_coefficient=-0.1), "must not be negative"),
    (_slip(shaft="input", offset_m=-0.45), "no neighbour"),
    (_slip(shaft="nope"), "no shaft"),
    ({"extends": "paper", "name": "bad", "shafts": [
        {**s, "bearings": [{**b, "kind": "floating"} for b in s["bearings"]]}
        for s in tomllib.loads(builtin_text("paper"))["shafts"]]},
     "no axial support"),
])
def test_bad_elements_are_refused(raw, words):
    with pytest.raises(SceneError, match=words):
        scene_from_dict(raw)


def test_release_leaving_a_mechanism_exits_2(capsys):
    args = ["sets", "paper", "--apply", "float:input.far", "--apply", "float:input.near",
            "--apply", "float:output.far", "--apply", "float:output.near"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith("cardan: error:") and "can slide along their axis" in err


def test_sets_json_lists_modes(capsys):
    assert main(["sets", "paper", "--json"]) == 0
    import json
    report = json.loads(capsys.readouterr().out)
    assert len(report["modes"]) == report["nullity"] == 7
    assert {m["kind"] for m in report["modes"]} == {"end-face pair", "axial split",
                                                    "closed loop"}


def test_paper_method_says_it_does_not_apply():
    for name in ("paper-slip", "propshaft"):
        with pytest.raises(NotApplicable, match="does not apply"):
            FORMULATIONS["paper"](_op(name, 0.1), 0)


def test_slip_friction_bound_is_honoured():
    scene = scene_from_dict({**_slip(offset_m=0.0, friction_coefficient=0.1),
                             "name": "friction-slip"})
    op = build_operator(simulate(scene, [0.5]))
    (f,) = op.slip_friction
    loop = [m for m in named_modes(simulate(scene, [0.5]), 0, op) if m.kind == "closed loop"]
    assert len(loop) == 1 and "friction of slip joint s;" in loop[0].release
    with pytest.raises(NotApplicable):
        FORMULATIONS["min_norm"](op, 0)
    for name, solver in (("positive", "clarabel"), ("min_max", "clarabel")):
        record = solve(FORMULATIONS[name](op, 0), solver)
        assert record.status == "solved"
        x = record.x
        assert abs(x[f.axial]) <= f.ratio_per_m * abs(x[f.torque]) * (1 + 1e-6) + 1e-9


# ---------------------------------------------------------------------------- handbook

TORQUE = 100.0


@pytest.mark.parametrize("arrangement, angles", [("Z", (30.0, 30.0)), ("W", (30.0, 30.0)),
                                                  ("Z", (10.0, 40.0)), ("W", (15.0, 25.0))])
def test_secondary_couple_matches_the_handbook(arrangement, angles):
    scene = secondary.revolution_scene("paper-slip", arrangement, angles, TORQUE, steps=4)
    op = build_operator(simulate(scene))
    loads = secondary.bearing_loads(op)
    shaft = scene.shafts[0]
    a = abs(shaft.bearings[1].offset_m - shaft.bearings[0].offset_m)
    c = shaft.length_m / 2 - shaft.bearings[1].offset_m
    expect = secondary.handbook(TORQUE, *angles, arrangement, a, c, scene.shafts[1].length_m)
    tol = 1e-9 * TORQUE
    # instant 0: input angle 0 deg; instant 1: 90 deg
    assert loads["input.near.normal"][0] == pytest.approx(expect["near_0"], abs=tol)
    assert loads["input.far.normal"][0] == pytest.approx(expect["far_0"], abs=tol)
    assert loads["input.near.normal"][1] == pytest.approx(expect["near_90"], abs=tol)
    assert loads["input.far.normal"][1] == pytest.approx(expect["far_90"], abs=tol)
    x0 = determinacy(op, 0).min_norm
    assert x0[op.index("slip.shear.r2")] == pytest.approx(expect["shear_0"], abs=tol)
    # with the slip joint the in-plane loads are determinate too, and vanish at 0 and 90
    for name, values in loads.items():
        assert np.all(np.isfinite(values)), name
        if name.endswith("in_plane"):
            assert np.abs(values[:2]).max() < tol, name


def test_secondary_writes_csv_and_png(tmp_path):
    secondary.revolutions(out=tmp_path, cases=(("Z", (30.0, 30.0)),))
    assert (tmp_path / "secondary.png").stat().st_size > 0
    text = (tmp_path / "secondary.csv").read_text().splitlines()
    assert text[0] == "case,bearing_load,angle_deg,force_N,source" and len(text) > 100


@pytest.mark.slow
def test_report_on_the_propshaft(tmp_path):
    from cardan_forces.experiments.report import run_report

    paths = run_report("propshaft", tmp_path, instants=3)
    assert all(p.stat().st_size > 0 for p in paths)
    rows = (tmp_path / "report.csv").read_text().splitlines()
    import csv as _csv
    table = list(_csv.DictReader(rows))
    # every bearing load of the propshaft is determinate: the positive answer equals
    # the least-norm value (the point interval), at every instant
    for row in table:
        if row["kind"].startswith("bearing"):
            assert row["determinate"] == "True"
            lo, hi, v = float(row["min_N"]), float(row["max_N"]), float(row["positive_N"])
            assert lo == hi and abs(v - lo) <= 1e-6 * max(1.0, abs(v))
    # ... and the LPs over the whole rigid set agree (one component, independently)
    from cardan_forces.experiments.study import value_range

    op = build_operator(simulate(load_scene("propshaft"), [0.2]))
    j = op.index("bearing.front_prop.centre.r1")
    ends = value_range(op, 0, np.eye(len(op.names))[j])
    assert ends["max"] - ends["min"] <= 1e-6 * max(1.0, abs(ends["max"]))


def test_hard_case_of_another_scene():
    from cardan_forces.experiments.hard import CASES, covered, run_case

    case = next(c for c in CASES if c.name == "unequal-10-40")
    scene = case.scene("propshaft")
    assert [j.articulation_deg for j in scene.joints] == [10.0, 40.0, 40.0]
    runs = run_case(case, ["positive"], ["qpsolvers-daqp"], instants=3, base="propshaft")
    assert covered(runs)


def test_penalty_simulation_refuses_a_slip_joint_with_friction():
    from cardan_forces.driveline.penalty import simulate_penalty

    slip = {"name": "slip", "shaft": "intermediate", "offset_m": 0.0, "pitch_radius_m": 0.02,
            "friction_coefficient": 0.1}
    scene = scene_from_dict({"extends": "paper-slip", "name": "slip-penalty",
                             "effects": ["gravity", "inertia", "penalty_dynamics"],
                             "slip_joints": [slip]})
    with pytest.raises(SceneError, match="frictionless"):
        simulate_penalty(scene, [0.0])


def test_scene_show_lists_kinds_and_slip_joints(capsys):
    assert main(["scene", "show", "propshaft"]) == 0
    out = capsys.readouterr().out
    assert "(floating)" in out and "slip joint spline" in out


@pytest.mark.parametrize("name", ["paper", "propshaft"])
def test_batched_least_norm_is_exact_on_any_scene(name):
    from cardan_forces.formulations.batch import least_norm_batch
    from cardan_forces.solvers import solve_batch

    op = build_operator(simulate(load_scene(name), np.linspace(0.0, 0.5, 21)))
    for formulation in ("min_norm", "positive"):
        record = solve_batch(least_norm_batch(op, formulation), "numpy-batched")
        assert record.residuals["equilibrium"].max() < 1e-11


def test_sets_release_prints_the_advice_and_the_released_table(capsys):
    assert main(["sets", "paper", "--release"]) == 0
    out = capsys.readouterr().out
    assert "release advisor: 3 release(s): add a slip joint in shaft intermediate" in out
    assert "scene paper+released" in out and "rank 35, nullity 4" in out


def test_report_refuses_too_few_instants(capsys):
    assert main(["report", "paper", "--instants", "1"]) == 2
    assert capsys.readouterr().err.startswith("cardan: error: argument --instants")


def test_advisor_recovers_the_propshaft_design_from_an_all_locating_line():
    raw = tomllib.loads(builtin_text("propshaft"))
    raw.pop("slip_joints")
    for shaft in raw["shafts"]:
        for bearing in shaft["bearings"]:
            bearing["kind"] = "locating"
    raw["name"] = "locked-propshaft"
    motion = simulate(scene_from_dict(raw), [0.3])
    before = determinacy(build_operator(motion), 0)
    assert (before.rank, before.nullity) == (41, 10)  # 6 pairs, 2 splits, 2 loops
    advice = advise(motion, 0)
    labels = {r.label for r in advice.releases}
    assert len(labels) == 4 and "slip:rear_prop" in labels
    assert "float:front_prop.centre" in labels
    assert advice.released.nullity == 6


def _line(n: int):
    """An ``n``-shaft line from the paper's: its end shafts, middle shafts of 0.5 m with
    one centre bearing each, every bearing locating, joints at 10 deg."""
    import tomllib

    raw = tomllib.loads(builtin_text("paper"))
    first, mid, last = raw["shafts"]
    mids = [{**mid, "name": f"mid{k}", "length_m": 0.5,
             "bearings": [{"name": "centre", "offset_m": 0.0}]} for k in range(1, n - 1)]
    joints = [{**raw["joints"][0], "name": f"uj{k}", "articulation_deg": 10.0}
              for k in range(1, n)]
    return scene_from_dict({"extends": "paper", "name": f"line{n}",
                            "shafts": [first, *mids, last], "joints": joints})


def test_the_release_search_is_refused_before_any_work_when_too_large(monkeypatch, capsys,
                                                                      tmp_path):
    """Eight shafts, every bearing locating: 18 candidates, thousands of sets; refused
    before a single operator is built (the advisor would otherwise run for minutes)."""
    from cardan_forces.driveline import release

    scene = _line(8)
    assert release.search_size(scene) > release.MAX_RELEASE_SETS
    motion = simulate(scene, [0.3])

    def no_work(*_):
        raise AssertionError("an operator was built")

    monkeypatch.setattr(release, "build_operator", no_work)
    with pytest.raises(release.ReleaseSearchTooLarge, match="at most"):
        release.advise(motion, 0)
    assert all(release.search_size(load_scene(n)) <= release.MAX_RELEASE_SETS
               for n in builtin_names())
