"""The support check: the line must turn with exactly one degree of freedom while its
contacts hold it, decided from the rank of the equilibrium operator."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from cardan_forces.driveline.loading import builtin_names, load_scene, scene_from_dict
from cardan_forces.driveline.scene import SceneError
from cardan_forces.driveline.support import Support, check_support, free_motions, support

ROWS = tuple(f"{body}.{kind}.{axis}" for body in ("a", "b") for kind in ("force", "moment")
             for axis in "xyz")


@pytest.mark.parametrize("name", builtin_names())
def test_builtin_lines_are_held(name):
    assert support(load_scene(name)) == Support(free=1, rows=())


def _paper_with(paper_raw, bearings: list[list[dict]]):
    for shaft, held in zip(paper_raw["shafts"], bearings):
        shaft["bearings"] = held
    return {"extends": "paper", "shafts": paper_raw["shafts"]}


@pytest.mark.parametrize("bearings,free", [
    ([[], [], []], 10),
    ([[{"name": "near", "offset_m": 0.4}], [], []], 7),
])
def test_free_motions_agree_with_grubler_where_nothing_is_redundant(paper_raw, bearings, free):
    """Five bodies (3 shafts, 2 cross-pins: 30 coordinates), four trunnion revolutes
    (5 constraints each), each bearing a ball joint (3): Gruebler's count 30 - 20 - 3 n
    is exact when no constraint is redundant, as here."""
    raw = _paper_with(paper_raw, bearings)
    with pytest.raises(SceneError, match=f"leave {free} free motions"):
        scene_from_dict(raw, "line.toml")


def test_two_bearings_in_one_place_are_one_bearing(paper_raw):
    """Not a count of bearings: two bearings at the same point let the input shaft
    swing about it, as one bearing would."""
    same = [{"name": "far", "offset_m": 0.4}, {"name": "near", "offset_m": 0.4}]
    raw = _paper_with(paper_raw, [same, [], paper_raw["shafts"][2]["bearings"]])
    with pytest.raises(SceneError, match=r"field 'shafts': the line is not held: its "
                                         r"contacts leave 2 free motions.*input \(moves along"):
        scene_from_dict(raw, "line.toml")


def test_a_bearing_on_the_intermediate_shaft_keeps_the_line_held(paper_raw):
    middle = [{"name": "centre", "offset_m": 0.0}]
    raw = _paper_with(paper_raw, [paper_raw["shafts"][0]["bearings"], middle,
                                  paper_raw["shafts"][2]["bearings"]])
    assert support(scene_from_dict(raw)).held


def test_free_motions_of_small_operators():
    """Body ``a`` held in every direction, ``b`` in none: six free motions, all of b's;
    both held: locked (no motion left)."""
    held_a = np.zeros((12, 6))
    held_a[:6] = np.eye(6)
    found = free_motions(held_a, ROWS)
    assert found.free == 6
    assert set(found.rows) == {"b.force.x", "b.force.y", "b.force.z"}
    assert free_motions(np.eye(12), ROWS) == Support(free=0, rows=())
    one = np.eye(12)[:, [0, 1, 2, 3, 4, 6, 7, 8, 9, 10, 11]]  # a turns about x
    assert free_motions(one, ROWS) == Support(free=1, rows=())


def test_a_locked_line_is_refused(monkeypatch, paper):
    monkeypatch.setattr("cardan_forces.driveline.support.support",
                        lambda scene: Support(free=0, rows=()))
    with pytest.raises(SceneError, match="the line is locked: its contacts leave no free "
                                         "motion, so it cannot turn"):
        check_support(paper)


def test_new_kinds_of_contact_columns_are_counted_without_change(paper):
    """The count reads only the operator: a column that restrains nothing new (a copy of
    a bearing's) leaves the line held; a brake (a moment about the input shaft's own
    axis, as a new element kind would add) locks it; a bearing released axially (its x
    column removed, as a floating bearing) keeps it held (the other bearing holds x)."""
    from cardan_forces.driveline.dynamics import simulate
    from cardan_forces.driveline.equilibrium import build_operator

    op = build_operator(simulate(paper, [0.3]))
    A = op.A[0]
    copy = np.column_stack([A, A[:, op.index("bearing.input.near.z")]])
    assert free_motions(copy, op.rows).held
    brake = np.zeros(A.shape[0])
    brake[3:6] = [1.0, 0.0, 0.0]  # input shaft, moment about its axis (global x)
    assert free_motions(np.column_stack([A, brake]), op.rows).free == 0
    floating = np.delete(A, op.index("bearing.input.far.x"), axis=1)
    assert free_motions(floating, op.rows).held
    # every bearing floating axially: the whole line (input and output parallel in Z)
    # slides along x; the closed loop no longer holds it
    axial = [op.index(f"bearing.{s}.{b}.x") for s in ("input", "output") for b in ("near", "far")]
    found = free_motions(np.delete(A, axial, axis=1), op.rows)
    assert found.free == 2
    assert {"input.force.x", "intermediate.force.x", "output.force.x"} <= set(found.rows)


def _friction_held(paper_raw, gravity, torque):
    """The paper line with a spline (friction 0.1) in the output shaft, whose far bearing
    floats: only the spline's friction holds the output's far part along its axis (x)."""
    first, middle, output = paper_raw["shafts"]
    output = {**output, "bearings": [{"name": "near", "offset_m": -0.4},
                                     {"name": "far", "offset_m": 0.4, "kind": "floating"}]}
    return {"extends": "paper", "name": "friction-held", "gravity_m_s2": gravity,
            "torque": {"input": torque, "load": 0.0}, "shafts": [first, middle, output],
            "slip_joints": [{"name": "spline", "shaft": "output", "offset_m": 0.0,
                             "pitch_radius_m": 0.02, "friction_coefficient": 0.1}]}


def test_a_line_whose_spline_friction_must_carry_a_load_without_torque_is_refused(paper_raw):
    """At rest with zero torque the spline's friction bound is zero: gravity along the
    output's axis (x) cannot be carried; without an axial component, or with a torque,
    the line loads."""
    with pytest.raises(SceneError, match="'slip_joints': the line cannot carry its loads"):
        scene_from_dict(_friction_held(paper_raw, [-2.0, 0.0, -9.8], 0.0), "line.toml")
    scene_from_dict(_friction_held(paper_raw, [0.0, 0.0, -9.8], 0.0))
    scene_from_dict(_friction_held(paper_raw, [-2.0, 0.0, -9.8], 10.0))


def test_the_refusal_agrees_with_the_rigid_set_being_empty(paper_raw):
    """Independent check: the interval LPs over the rigid set (friction bounds included)
    find no point for the refused line (every instant alike), and one for the accepted."""
    from cardan_forces.driveline.dynamics import simulate
    from cardan_forces.driveline.equilibrium import build_operator
    from cardan_forces.formulations.sets import range_problems
    from cardan_forces.solvers import solve

    accepted = scene_from_dict(_friction_held(paper_raw, [0.0, 0.0, -9.8], 0.0))
    refused = dataclasses.replace(accepted, gravity_m_s2=(-2.0, 0.0, -9.8))
    for scene, feasible in ((accepted, True), (refused, False)):
        op = build_operator(simulate(scene, [0.0, 2.5]))
        for i in range(2):
            record = solve(range_problems(op, i, np.zeros(len(op.names)))[0], "clarabel")
            assert (record.status == "solved") == feasible


def test_structure_is_every_field_but_the_loads_names_and_grid():
    """The support's cache key holds every scene field but the declared few, so a field
    added to the scene is part of it without anyone listing it."""
    from cardan_forces.driveline.scene import Scene
    from cardan_forces.driveline.support import NOT_STRUCTURE, structure

    fields = {f.name for f in dataclasses.fields(Scene)}
    assert NOT_STRUCTURE <= fields
    paper = load_scene("paper")
    assert {name for name, _ in structure(paper)} == fields - NOT_STRUCTURE
    louder = paper.with_changes(load_torque=dataclasses.replace(paper.load_torque,
                                                                mean_N_m=3.0))
    assert structure(louder) == structure(paper)
    turned = paper.with_changes(arrangement="W")
    assert structure(turned) != structure(paper)
    assert support(turned) == Support(free=1, rows=())
