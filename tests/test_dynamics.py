"""The reduced equation of motion: energy, torque ratios, uniform output."""

import numpy as np
import pytest
from cardan_forces.driveline import dynamics
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import reduced_inertia, simulate
from cardan_forces.driveline.equilibrium import build_operator
from scipy.integrate import simpson

from cardan_forces.util.compiled import HAVE_NUMBA
from tests.conftest import variant

pytestmark = pytest.mark.compiled  # also run for a generic CPU by .ci/run


@pytest.mark.parametrize("effects", [["inertia"], ["inertia", "gravity", "crosspin_inertia"]])
def test_work_of_the_torques_equals_kinetic_energy(effects):
    scene = variant(effects=effects, time={"stop_s": 1.0, "step_s": 0.0005},
                    initial={"speed_rad_s": 2.0},
                    torque={"load": {"kind": "constant", "value_N_m": 3.0}})
    m = simulate(scene)
    inertia, _ = reduced_inertia(scene, m.kin)
    energy = 0.5 * inertia * m.qd**2
    power = (m.input_torque - m.load_torque * m.kin.ratio[-1]) * m.qd
    work = simpson(power, x=m.t)
    assert work == pytest.approx(energy[-1] - energy[0], rel=1e-7)
    assert energy[-1] > energy[0]  # the mean drive (10 N m) beats the load (3 N m)


def test_crosspin_inertia_slows_the_start():
    bare = simulate(variant(time={"stop_s": 0.5}), [0.5])
    heavy = simulate(variant(effects=["inertia", "crosspin_inertia"], time={"stop_s": 0.5},
                             crosspin={"mass_kg": 2.0, "inertia_kg_m2": [0.05, 0.05, 0.1]}),
                     [0.5])
    assert heavy.qd[0] < bare.qd[0]


def test_equal_angles_z_output_turns_with_input(paper):
    m = simulate(paper, np.linspace(0, 2, 201))
    assert np.allclose(m.omega[2], m.omega[0], rtol=1e-12, atol=1e-12)
    assert np.allclose(m.alpha[2], m.alpha[0], rtol=1e-10, atol=1e-10)
    # the intermediate shaft does not: eq (3) with phi_i = 0 gives 1/cos(30 deg)
    assert m.omega[1][100] != pytest.approx(m.omega[0][100])


@pytest.mark.parametrize("g1,g2", [(30.0, 30.0), (15.0, 40.0)])
def test_torque_ratio_across_each_joint_quasi_static(g1, g2):
    """T_out = T_in dphi_in/dphi_out across a Hooke joint, read from the contact forces."""
    joints = [dict(name=n, articulation_deg=g, hs_m=0.03, rs_m=0.005, rb_m=0.005, ht_m=0.02,
                   hb_m=0.02, rt_m=0.006) for n, g in (("uj1", g1), ("uj2", g2))]
    scene = variant(effects=[], joints=joints, initial={"speed_rad_s": 1.0},
                    time={"stop_s": 3.0})
    m = simulate(scene, np.linspace(0.0, 3.0, 13))
    op = build_operator(m)
    driven_side = [i for i, n in enumerate(op.names) if n.startswith("uj1.F") and
                   n.split(".")[1] in ("F5", "F6", "F7", "F8")]
    rows = slice(6 * 1 + 3, 6 * 1 + 6)  # moment rows of the intermediate shaft
    for i in range(len(m.t)):
        x = determinacy(op, i).min_norm
        torque = op.A[i, rows][:, driven_side] @ x[driven_side] @ m.geometry.axes[1]
        assert torque == pytest.approx(m.input_torque[i] / m.kin.ratio[1][i], rel=1e-9)
        assert m.load_torque[i] == pytest.approx(m.input_torque[i] / m.kin.ratio[2][i])


def _array_path(monkeypatch):
    monkeypatch.setattr(dynamics, "HAVE_NUMBA", False)


@pytest.mark.skipif(not HAVE_NUMBA, reason="numba not installed")
@pytest.mark.parametrize("effects", [["inertia", "gravity"], ["inertia", "crosspin_inertia"]])
def test_compiled_motion_equals_the_array_path(effects, monkeypatch):
    """The compiled one-instant kinematics in the equation of motion gives the array
    path's motion (vectorized kinematics at every stage) to 1e-10, with and without
    cross-pin inertia, on a chain with unequal angles and a yoke phase.
    """
    joints = [dict(name=n, articulation_deg=g, yoke_phase_deg=p, hs_m=0.03, rs_m=0.005,
                   rb_m=0.005, ht_m=0.02, hb_m=0.02, rt_m=0.006)
              for n, g, p in (("uj1", 25.0, 0.0), ("uj2", 40.0, 15.0))]
    scene = variant(effects=effects, joints=joints, time={"stop_s": 2.0})
    t = np.linspace(0.0, 2.0, 101)
    compiled = simulate(scene, t)
    _array_path(monkeypatch)
    array = simulate(scene, t)
    for name in ("q", "qd", "qdd"):
        a, b = getattr(compiled, name), getattr(array, name)
        assert np.abs(a - b).max() <= 1e-10 * np.abs(b).max()


@pytest.mark.skipif(not HAVE_NUMBA, reason="numba not installed")
def test_a_chain_the_compiled_copy_gets_wrong_falls_back(paper, monkeypatch):
    """If the compiled kinematics disagree with the array kinematics (a kind of joint it
    does not know), the equation of motion uses the array path: the same motion as
    with numba absent, not the wrong copy's (whose q'' = 1 would add t^2 / 2 to q)."""
    t = np.linspace(0.0, 0.5, 11)
    consulted = []

    def wrong(t, y, *args):
        consulted.append(t)
        return np.array([y[1], 1.0])

    monkeypatch.setattr(dynamics, "_compiled_rhs", wrong)
    wrong_copy = simulate(paper, t)
    assert consulted, "the compiled copy was never consulted: the test would prove nothing"
    _array_path(monkeypatch)
    array = simulate(paper, t)
    for name in ("q", "qd", "qdd"):
        a, b = getattr(wrong_copy, name), getattr(array, name)
        assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max(), name
    assert not np.allclose(array.qdd, 1.0)
