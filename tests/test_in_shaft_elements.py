"""Elements inside shafts as one list of the scene: any number of cuts per shaft, each
kind reading its own table, the line's bodies and checks following from the kinds."""

import dataclasses

import numpy as np
import pytest
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.elements import shaft_segments
from cardan_forces.driveline.elements.registry import kind_of, scene_elements
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene, scene_from_dict, scene_tables
from cardan_forces.driveline.scene import SceneError

SPLINE = {"pitch_radius_m": 0.02}


def _slips(*offsets, shaft="intermediate"):
    return scene_from_dict({"extends": "paper-slip", "slip_joints": [
        {"name": f"s{k}", "shaft": shaft, "offset_m": o, **SPLINE}
        for k, o in enumerate(offsets)]}, source="<slips>")


def test_two_cuts_make_three_segments_that_span_the_shaft():
    scene = _slips(0.45, 0.0, shaft="input")
    segs = [s for s in shaft_segments(scene) if s.shaft == 0]
    assert [s.name for s in segs] == ["input.upstream", "input.after-s1", "input.downstream"]
    assert [(s.lo_m, s.hi_m) for s in segs] == [(-0.5, 0.0), (0.0, 0.45), (0.45, 0.5)]
    assert sum(s.fraction for s in segs) == pytest.approx(1.0, abs=1e-15)
    assert [e.name for e in scene.elements] == ["s1", "s0"]  # chain order, not file order


def test_a_middle_segment_between_two_splines_is_refused_as_unheld():
    with pytest.raises(SceneError, match="'s0' on shaft 'intermediate': its downstream "
                                         "segment is not held"):
        _slips(-0.2, 0.3)


def test_two_splines_in_one_shaft_each_add_a_body_and_its_columns():
    """Two cuts in the input shaft, a bearing on each of its outer parts and the joint
    at its end: two bodies (12 rows) and two splines' five components each more than
    the paper's line, and its loads are carried (A x = b)."""
    op = build_operator(simulate(_slips(0.45, 0.0, shaft="input"), [0.5]))
    paper = build_operator(simulate(load_scene("paper"), [0.5]))
    assert op.A[0].shape == (paper.A[0].shape[0] + 12, paper.A[0].shape[1] + 10)
    x = determinacy(op, 0).min_norm
    assert np.linalg.norm(op.A[0] @ x - op.b[0]) <= 1e-9 * np.linalg.norm(op.b[0])


def test_two_elements_at_one_place_are_refused_naming_both():
    with pytest.raises(SceneError, match="'s1' and 's0' cut shaft 'intermediate' at one"):
        _slips(0.1, 0.1)


def test_an_element_named_as_a_shaft_is_refused():
    with pytest.raises(SceneError, match="slip joint name 'input' is taken"):
        scene_from_dict({"extends": "paper-slip", "slip_joints": [
            {"name": "input", "shaft": "intermediate", "offset_m": 0.0, **SPLINE}]})


def test_scene_tables_write_each_element_back_to_its_kinds_table():
    scene = load_scene("paper-slip")
    tables = scene_tables(scene)
    for element in scene.elements:
        assert dataclasses.asdict(element) in tables[kind_of(element).table]
    assert scene.with_changes() == scene


def test_every_element_is_walked_once_in_column_order():
    scene = load_scene("propshaft")
    walked = [element for _, element, _, _ in scene_elements(scene)]
    assert len(walked) == sum(len(s.bearings) for s in scene.shafts) + \
        len(scene.elements) + len(scene.joints)
    op = build_operator(simulate(scene, [0.1]))
    owners = [link.element for link in op.contacts]
    assert owners == sorted(owners, key=owners.index)  # each element's links together


def test_a_joint_of_an_unknown_kind_is_refused_with_the_kinds():
    with pytest.raises(SceneError, match=r"joints\[0\].kind': must be one of cardan"):
        scene_from_dict({"extends": "paper", "joints": [
            {**dataclasses.asdict(load_scene("paper").joints[0]), "kind": "tripod"},
            dataclasses.asdict(load_scene("paper").joints[1])]})


@pytest.mark.parametrize("shaft,offset,side", [("output", 0.45, "downstream"),
                                               ("input", -0.45, "upstream")])
def test_a_cut_beyond_the_end_shafts_bearings_is_refused(shaft, offset, side):
    """The line's ends have no joint: a segment past the last bearing there is unheld."""
    with pytest.raises(SceneError, match=f"'s0' on shaft '{shaft}': its {side} segment"):
        _slips(offset, shaft=shaft)
