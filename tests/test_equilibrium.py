"""The equilibrium operator: consistency, weight, effects, redundancy."""

import dataclasses

import numpy as np
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.scene import EFFECTS
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.conftest import variant

LINEAR_EFFECTS = ("gravity", "inertia", "crosspin_inertia")


@st.composite
def scenes(draw):
    joint = lambda name, g, phase: dict(  # noqa: E731
        name=name, articulation_deg=g, yoke_phase_deg=phase, hs_m=draw(st.floats(0.01, 0.05)),
        rs_m=0.005, rb_m=0.0052, ht_m=0.02, hb_m=0.021, rt_m=0.006)
    shaft = lambda name, bearings: dict(  # noqa: E731
        name=name, length_m=draw(st.floats(0.3, 2.0)), mass_kg=draw(st.floats(1.0, 300.0)),
        inertia_kg_m2=[draw(st.floats(1.0, 2.0))] * 3, bearings=bearings)
    gravity = draw(st.lists(st.floats(-10, 10), min_size=3, max_size=3))
    effects = draw(st.sets(st.sampled_from(LINEAR_EFFECTS), min_size=0))
    if "inertia" not in effects:
        effects.discard("crosspin_inertia")
    return variant(
        arrangement=draw(st.sampled_from("ZW")),
        effects=sorted(effects),
        gravity_m_s2=gravity,
        shafts=[shaft("input", [{"name": "far", "offset_m": -0.1}, {"name": "near",
                                                                      "offset_m": 0.1}]),
                shaft("intermediate", []),
                shaft("output", [{"name": "near", "offset_m": -0.1},
                                 {"name": "far", "offset_m": 0.12}])],
        joints=[joint("uj1", draw(st.floats(0.0, 80.0)), draw(st.floats(-90, 90))),
                joint("uj2", draw(st.floats(0.0, 80.0)), draw(st.floats(-90, 90)))],
        torque={"input": {"kind": "harmonic", "mean_N_m": draw(st.floats(-50, 50)),
                          "amplitude_N_m": draw(st.floats(-20, 20)), "frequency_hz": 2.0}},
        initial={"speed_rad_s": draw(st.floats(-5.0, 5.0))},
        time={"stop_s": 0.4, "step_s": 0.01},
    )


@settings(max_examples=20, deadline=None, derandomize=True)
@given(scene=scenes(), instants=st.lists(st.floats(0.0, 0.4), min_size=1, max_size=3))
def test_min_norm_residual_at_random_instants_of_random_scenes(scene, instants):
    op = build_operator(simulate(scene, instants))
    for i in range(len(instants)):
        d = determinacy(op, i)
        assert d.residual <= 1e-10
        # every solution carries the weight: bearing forces sum to minus the total gravity
        x = d.min_norm + d.null_basis @ np.linspace(-1e3, 1e3, d.nullity)
        bearings = np.array([n.startswith("bearing.") for n in op.names])
        total = np.zeros(3)
        for axis, k in zip("xyz", range(3)):
            total[k] = x[bearings & np.array([n.endswith(f".{axis}") for n in op.names])].sum()
        mass = sum(s.mass_kg for s in scene.shafts)
        if scene.has("crosspin_inertia"):
            mass += len(scene.joints) * scene.crosspin.mass_kg
        g = np.array(scene.gravity_m_s2) if scene.has("gravity") else np.zeros(3)
        assert np.allclose(total, -mass * g, atol=1e-8 * max(1.0, np.abs(d.min_norm).max()))


def test_vertical_bearing_forces_carry_the_weight(paper):
    op = build_operator(simulate(paper, [0.0, 0.7, 2.5]))
    vertical = [i for i, n in enumerate(op.names) if n.startswith("bearing.") and n.endswith(".z")]
    weight = 9.8 * sum(s.mass_kg for s in paper.shafts)
    for i in range(3):
        d = determinacy(op, i)
        for x in (d.min_norm, d.min_norm + 500.0 * d.null_basis.sum(axis=1)):
            assert np.isclose(x[vertical].sum(), weight, rtol=1e-12)


def test_switching_an_effect_off_removes_exactly_its_term(paper):
    scene = dataclasses.replace(paper, effects=frozenset(LINEAR_EFFECTS))
    motion = simulate(scene, [0.3, 1.1])
    full = build_operator(motion)
    assert set(full.terms) == {"applied", *LINEAR_EFFECTS}
    for effect in LINEAR_EFFECTS:
        reduced = dataclasses.replace(scene, effects=scene.effects - {effect})
        op = build_operator(dataclasses.replace(motion, scene=reduced))
        assert effect not in op.terms
        assert np.array_equal(op.A, full.A)
        removed = full.terms[effect]
        if effect == "crosspin_inertia":  # massless cross-pins weigh nothing either
            removed = removed + full.terms["gravity"] - op.terms["gravity"]
            assert np.allclose(op.terms["gravity"][:, 6 * len(scene.shafts):], 0)
        assert np.allclose(full.b - op.b, removed, rtol=0, atol=1e-12)
    # the gravity term is the weight of each body on its force rows, nothing else
    expected = np.zeros_like(full.b[0])
    for k, shaft in enumerate(scene.shafts):
        expected[6 * k: 6 * k + 3] = -shaft.mass_kg * np.array(scene.gravity_m_s2)
    for j in range(len(scene.joints)):
        row = 6 * (len(scene.shafts) + j)
        expected[row: row + 3] = -scene.crosspin.mass_kg * np.array(scene.gravity_m_s2)
    assert np.allclose(full.terms["gravity"][0], expected)
    # the inertia term only acts about the shaft axes
    assert np.allclose(full.terms["inertia"][:, :3], 0)


def test_effects_listed_in_one_place():
    assert set(LINEAR_EFFECTS) <= set(EFFECTS)


def test_paper_redundancy_structure(paper):
    """Nullity 7 = 2 axial bearing splits + 4 end-face pair splits + 1 closed loop."""
    op = build_operator(simulate(paper, [0.5]))
    d = determinacy(op, 0)
    assert (d.rank, d.nullity) == (29, 7)
    A = op.A[0]
    idx = op.index
    splits = []
    for shaft in ("input", "output"):
        v = np.zeros(len(op.names))
        v[idx(f"bearing.{shaft}.far.x")], v[idx(f"bearing.{shaft}.near.x")] = 1.0, -1.0
        splits.append(v)
    for joint in ("uj1", "uj2"):
        for a, b in (("F3", "F4"), ("F7", "F8")):
            v = np.zeros(len(op.names))
            v[idx(f"{joint}.{a}")] = v[idx(f"{joint}.{b}")] = 1.0
            splits.append(v)
    splits = np.array(splits).T
    assert np.allclose(A @ splits, 0, atol=1e-12)
    # the seventh direction is the loop's self-stress: it changes no out-of-plane force
    loop = d.null_basis - splits @ np.linalg.lstsq(splits, d.null_basis, rcond=None)[0]
    assert np.linalg.matrix_rank(loop, tol=1e-8) == 1
    out_of_plane = [idx(f"bearing.{s}.{b}.y") for s in ("input", "output")
                    for b in ("near", "far")]
    assert np.all(d.determinate[out_of_plane])
    # ... but it does change the joint forces: the paper's "unique joint forces" claim
    # does not hold for the rigid model (see README)
    joint_cols = [i for i, n in enumerate(op.names) if n.startswith("uj")]
    assert np.abs(loop[joint_cols]).max() > 0.05
