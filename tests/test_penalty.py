"""The penalty-contact simulation (paper eqs. 75-78) against the rigid model."""

import dataclasses

import numpy as np
import pytest
from cardan_forces.driveline import penalty, penalty_jacobian, penalty_linear
from cardan_forces.driveline.contact import hertz_stiffness
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.driveline.penalty import contact_law, simulate_penalty
from scipy.integrate import cumulative_trapezoid

pytestmark = pytest.mark.compiled  # also run for a generic CPU by .ci/run

STOP_S = 0.2
LATE_S = 0.1  # after the play has closed (~0.07 s from rest) and the first impacts


@pytest.fixture(scope="module")
def scene():
    return load_scene("paper-penalty")


@pytest.fixture(scope="module")
def run(scene):
    marks = []
    result = simulate_penalty(scene, np.arange(0.0, STOP_S + 1e-9, 0.005), progress=marks.append)
    return result, marks


@pytest.fixture(scope="module")
def rigid(scene, run):
    return build_operator(simulate(scene, run[0].t))


def test_refuses_a_scene_without_the_effect(paper):
    with pytest.raises(ValueError, match="penalty_dynamics"):
        simulate_penalty(paper, [0.0, 0.01])


def test_contact_law_eqs_75_78():
    k, n, c, d_max = 1e10, 1.5, 1e7, 1e-5
    assert contact_law(-1e-6, -5.0, k, n, c, d_max) == 0.0
    assert contact_law(2e-5, 0.0, k, n, c, d_max) == pytest.approx(k * 2e-5**1.5)
    assert contact_law(2e-5, 1e-3, k, n, c, d_max) == pytest.approx(k * 2e-5**1.5 + c * 1e-3)
    # the cubic step is half way at half depth; a contact never pulls
    half = contact_law(5e-6, 1e-3, k, n, c, d_max) - k * 5e-6**1.5
    assert half == pytest.approx(0.5 * c * 1e-3)
    assert contact_law(1e-6, -1.0, k, n, c, d_max) == 0.0


def test_contact_parameters_match_the_paper_by_hand(scene):
    """The joints' Hertz stiffness and damping from the paper's printed numbers, worked
    by hand: E = 2.07e11 Pa, nu = 0.29 (material), rs = 4.75 mm and rb = 5.00 mm (Table
    2), eqs. 76-77 with the same steel on both sides: s = (1 - 0.29^2) / 2.07e11 =
    4.4246e-12 1/Pa, K = 4 / (3 * 2s) * sqrt(4.75 * 5.00 / 0.25 * 1e-3 m) = 1.5067e11 *
    0.30822 = 4.644e10 N/m^1.5. Damping (eq. 78 and the text after it): c_max = 1 % of
    K read in ADAMS's N, mm, s, i.e. 0.01 * K [N/mm^1.5] N s/mm, at full depth d_max =
    0.01 mm; the exponent is 1.5 (steel). 2 joints x F1-F8 and 4 bearings x 3 forces.
    """
    model = penalty._Model(scene, penalty.DAMPING_LENGTH_UNIT_M)
    contacts = model.c
    joint, bearing = contacts.exponent == 1.5, contacts.exponent == 1.0
    assert joint.sum() == 16 and bearing.sum() == 12
    assert np.allclose(contacts.stiffness[joint], 4.644e10, rtol=2e-4)
    k_mm = 4.644e10 * 1e-3**1.5  # N/mm^1.5
    assert np.allclose(contacts.c_max[joint], 0.01 * k_mm * 1e3, rtol=2e-4)  # N s/mm -> /m
    assert model.d_max == pytest.approx(1e-5)
    # at 0.01 mm and at rest a pin in its bore carries K d^1.5 = 1468.6 N
    assert contact_law(1e-5, 0.0, contacts.stiffness[joint][0], 1.5, contacts.c_max[joint][0],
                       model.d_max) == pytest.approx(1468.6, rel=2e-4)


def test_hertz_stiffness_scales_with_the_effective_modulus_and_radius(scene):
    """Hertz line contact of a pin in a bore: K grows with E / (1 - nu^2) and with the
    square root of the effective radius R1 R2 / (R2 - R1), so doubling E doubles K,
    scaling both radii (and the play) by 4 doubles it, and a tighter play stiffens it."""
    joint, material = scene.joints[0], scene.material
    k = hertz_stiffness(scene, joint)

    def with_material(**changes):
        return dataclasses.replace(scene, material=dataclasses.replace(material, **changes))

    doubled_e = with_material(youngs_modulus_Pa=2 * material.youngs_modulus_Pa)
    assert hertz_stiffness(doubled_e, joint) == pytest.approx(2 * k, rel=1e-12)
    rubbery = with_material(poisson_ratio=0.5)
    assert hertz_stiffness(rubbery, joint) == pytest.approx(
        k * (1 - 0.29**2) / (1 - 0.5**2), rel=1e-12)
    bigger = dataclasses.replace(joint, rs_m=4 * joint.rs_m, rb_m=4 * joint.rb_m)
    assert hertz_stiffness(scene, bigger) == pytest.approx(2 * k, rel=1e-12)
    tighter = dataclasses.replace(joint, rs_m=joint.rb_m - 0.1e-3)
    assert hertz_stiffness(scene, tighter) > 1.5 * k


def _pressed_state(model, seed):
    """A seeded random state with contacts pressed: shafts 15 um and pins 0.8 mm down,
    small random displacements, every body moving.
    """
    rng = np.random.default_rng(seed)
    nb = model.n_bodies
    y = model.initial_state()
    y[:3 * nb] += 2e-6 * rng.standard_normal(3 * nb)
    y[3 * nb:7 * nb] *= 1.0 + 1e-3 * rng.standard_normal(4 * nb)  # any norm is allowed
    y[7 * nb:] += 1e-3 * rng.standard_normal(6 * nb)
    y[2:15:3] += [-1.5e-5] * 3 + [-8e-4] * 2  # vertical displacements of the 5 bodies
    assert np.sum(model.contacts(model.bodies(y[:, None]))[1] > 0) >= 8
    return y


def _close(a, b, rel):
    """Each entry of ``a`` within ``rel`` of the larger of the largest entries in its row
    and in its column of ``b`` (rows and columns carry units).
    """
    scale = np.maximum(np.abs(b).max(axis=1)[:, None], np.abs(b).max(axis=0)[None, :])
    return np.all(np.abs(a - b) <= rel * scale)


@pytest.fixture(scope="module")
def model(scene):
    return penalty._Model(scene, penalty.DAMPING_LENGTH_UNIT_M)


def test_jacobian_colouring_is_exact(model):
    """The coloured complex-step Jacobian (one vectorized call) equals the column-by-
    column complex step to round-off, and a central difference to its truncation.
    """
    y = _pressed_state(model, 0)
    _, step = model.tolerances(1e-8)
    n = len(y)
    columns = [(model.rhs(0.0, (y + 1j * h * np.eye(n)[i])[:, None])[:, 0]).imag / h
               for i, h in enumerate(step)]
    exact = np.array(columns).T
    jac = model.jacobian(0.0, y, step)
    assert _close(jac, exact, 1e-12)
    h = 1e-9 * np.where(np.arange(n) < 7 * model.n_bodies, 1.0, 1e3)
    central = np.array([(model.rhs(0.0, (y + h[i] * np.eye(n)[i])[:, None])[:, 0]
                         - model.rhs(0.0, (y - h[i] * np.eye(n)[i])[:, None])[:, 0]) / (2 * h[i])
                        for i in range(n)]).T
    assert np.abs(jac - central).max() <= 1e-4 * np.abs(jac).max()


@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
@pytest.mark.parametrize("seed", range(5))
def test_compiled_kernels_equal_the_numpy_model(model, seed):
    """Right-hand side and Jacobian of the compiled kernels against the NumPy model at
    seeded random states with contacts pressed: contact forces and linear accelerations
    equal to 1e-12. Angular accelerations and the Jacobian to 1e-11: their contact
    points are offsets of ~0.1 mm taken between positions of ~1 m (global coordinates),
    so both implementations lose about four digits there, each in its own order of sums.
    """
    y = _pressed_state(model, seed)
    t = 0.05 * seed
    compiled, reference = model.rhs_compiled(t, y), model.rhs(t, y[:, None])[:, 0]
    nb = model.n_bodies  # blocks: x', q', v', w' (each its own unit)
    for rows, rel in zip(np.split(np.arange(13 * nb), [3 * nb, 7 * nb, 10 * nb]),
                         (1e-12, 1e-12, 1e-12, 1e-11)):
        assert np.abs(compiled - reference)[rows].max() <= rel * np.abs(reference[rows]).max()
    _, step = model.tolerances(1e-8)
    assert _close(model.jacobian_compiled(t, y), model.jacobian(t, y, step), 1e-11)
    depth, push, force, _, _, _ = penalty.kernels.contact_forces(y, model.arrays)
    d, f, on_a, _, _ = model.contacts(model.bodies(y[:, None]))
    assert np.allclose(depth, d[:, 0], rtol=0, atol=1e-15)
    assert np.abs(push - f[:, 0]).max() <= 1e-12 * np.abs(f).max()
    assert np.abs(force - on_a[:, :, 0].T).max() <= 1e-12 * np.abs(on_a).max()


@pytest.mark.slow  # the NumPy model over the whole run; its formulas stay held in the
# default run by test_compiled_integration_follows_the_numpy_reference
@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
def test_compiled_run_has_the_statistics_of_the_numpy_run(scene, run):
    """The same short run with the NumPy model: the released line rattles chaotically
    (a round-off difference changes the sequence of impacts), so only averages after the
    play has closed compare: shaft speeds to 3 %, the bearings' vertical load (the
    weight) to 1 %, the torque-carrying radial force on joint 1 to 10 %.
    """
    compiled = run[0]
    assert compiled.kernel == "numba"
    reference = simulate_penalty(scene, compiled.t, kernel="numpy")  # the fallback path
    assert reference.kernel == "numpy" and reference.method == "LSODA" and reference.success
    late = compiled.t >= LATE_S
    speeds = [r.omega[:, late].mean(axis=1) for r in (compiled, reference)]
    assert np.allclose(*speeds, rtol=0.03)
    vertical = [sum(f for name, f in r.forces.items() if name.endswith(".z"))[late].mean()
                for r in (compiled, reference)]
    assert vertical[0] == pytest.approx(vertical[1], rel=0.01)
    radial = [r.forces["uj1.F1.e2"][late].mean() for r in (compiled, reference)]
    assert radial[0] == pytest.approx(radial[1], rel=0.1)


@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
def test_compiled_integration_follows_the_numpy_reference(scene):
    """Before the rattling starts (the input turns through the play until ~0.07 s), the
    compiled BDF on the compiled kernels and SciPy's LSODA on the NumPy model integrate
    one smooth motion, each to local errors below ``atol`` = 1e-8 m: the shaft speeds
    agree to 1e-4 of their size and the deepest penetration (~2 um, the shafts settled
    in their bearings) to 3e-7 m, a few tens of ``atol`` over 0.05 s.
    """
    t = np.linspace(0.0, 0.05, 21)
    compiled = simulate_penalty(scene, t)
    reference = simulate_penalty(scene, t, method="LSODA", kernel="numpy")
    assert compiled.method == penalty.COMPILED and compiled.success and reference.success
    assert (compiled.integrator, reference.integrator) == ("numba-BDF", "scipy-LSODA")
    assert np.abs(compiled.omega - reference.omega).max() <= 1e-4 * np.abs(reference.omega).max()
    assert np.abs(compiled.penetration - reference.penetration).max() <= 3e-7
    assert compiled.nsteps > 0 and compiled.nfev >= compiled.nsteps


@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
@pytest.mark.parametrize("name", ["paper-slip", "propshaft"])
def test_compiled_jacobian_is_exact_on_slip_joints_and_floating_bearings(name):
    """On the lines with a spline and floating bearings, at a state 20 ms into a run
    (shafts settled in their bearings, the spline and pins loaded): the compiled
    Jacobian equals the NumPy model's complex-step Jacobian to 1e-7 of each entry's
    row and column scale; nothing is missing, whatever contacts are in touch. A missing
    or wrong term is of order one there; round-off reaches 1e-9 where a contact sits
    within femtometres of touching (the state depends on the integration before it).
    """
    model = penalty._Model(_released(name), penalty.DAMPING_LENGTH_UNIT_M)
    kernels, args = penalty.kernels, model.arrays
    y0, (atol, step) = model.initial_state(), model.tolerances(1e-8)
    out = np.full((1, len(y0)), np.nan)
    run = kernels.start(0.0, y0, 0.02, atol, 1e-10, args)
    kernels.advance(run, 0.02, 0.02, atol, 1e-10, args, np.array([0.02]), out)
    y = out[0]
    assert np.sum(model.contacts(model.bodies(y[:, None]))[1] > 0) >= 8
    assert _close(model.jacobian_compiled(0.02, y), model.jacobian(0.02, y, step), 1e-7)


@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
def test_bodies_without_a_shared_contact_do_not_couple(model):
    """The Newton solve skips the blocks of bodies that share no contact
    (:func:`penalty_jacobian._linked`): in the NumPy model's complex-step Jacobian at a
    pressed state, a body's accelerations do not move with such a body's states, and
    do with every linked one's (every body touches one here).
    """
    y = _pressed_state(model, 3)
    _, step = model.tolerances(1e-8)
    jac = model.jacobian(0.0, y, step)
    nb = model.n_bodies
    linked = penalty_jacobian._linked(nb, model.arrays.topology)

    def states(j):  # displacement, quaternion, velocity, rate of body j
        return np.r_[3 * j:3 * j + 3, 3 * nb + 4 * j:3 * nb + 4 * j + 4,
                     7 * nb + 3 * j:7 * nb + 3 * j + 3, 10 * nb + 3 * j:10 * nb + 3 * j + 3]

    for k in range(nb):
        rows = np.r_[7 * nb + 3 * k:7 * nb + 3 * k + 3, 10 * nb + 3 * k:10 * nb + 3 * k + 3]
        for j in range(nb):
            block = jac[np.ix_(rows, states(j))]
            assert np.any(block != 0.0) == linked[k, j], (k, j)


@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
@pytest.mark.parametrize("c", [1e-7, 1e-5, 1e-3])
@pytest.mark.parametrize("by_blocks", [True, False])
def test_structured_newton_solve_equals_a_dense_solve(model, c, by_blocks):
    """The integrator solves ``(I - c J) x = b`` by eliminating the displacement and
    quaternion rows first (a 30 x 30 system instead of 65 x 65), factored block by block
    along the chain of bodies (``by_blocks``) or by ``getrf`` (bodies that form no
    chain): a backward error ``|M x - b| / (|M| |x|)`` at round-off, as a dense
    solve's, and the same ``x`` to 1e-8 of its size (the matrix is ill-conditioned:
    ``J`` spans 1e-3 ... 1e10), for values of ``c`` (the step over the formula's
    coefficient) across those it takes.
    """
    y = _pressed_state(model, 1)
    jac = model.jacobian_compiled(0.0, y)
    n, nb = len(y), model.n_bodies
    factors = penalty_linear.new_factors(penalty_jacobian._linked(nb, model.arrays.topology))
    assert len(factors.chain.order) == nb  # paper's bodies form a chain
    if not by_blocks:
        chain = factors.chain
        factors = factors._replace(chain=chain._replace(order=chain.order[:0]))
    assert penalty_linear._factor(jac, c, factors) == 0
    b = np.random.default_rng(2).standard_normal(n)
    x = b.copy()
    penalty_linear._solve(jac, c, factors, x, np.zeros(n), np.zeros(n))
    matrix = np.eye(n) - c * jac
    dense = np.linalg.solve(matrix, b)
    assert np.abs(matrix @ x - b).max() <= 1e-13 * np.abs(matrix).max() * np.abs(x).max()
    assert np.abs(x - dense).max() <= 1e-8 * np.abs(dense).max()


@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
@pytest.mark.parametrize(("edges", "chains"), [
    ([(0, 3), (3, 1), (1, 4), (4, 2)], True),  # shaft, pin, shaft, pin, shaft
    ([(0, 1), (2, 3)], True),  # two chains, and a body on its own
    ([(0, 1), (1, 2), (2, 0)], False),  # a loop
    ([(0, 1), (0, 2), (0, 3)], False),  # a body with three neighbours
])
def test_chain_order_puts_linked_bodies_side_by_side(edges, chains):
    """The order of the block factorization (:func:`penalty_linear._chain_order`) has
    every pair of linked bodies next to each other (so the reduced matrix is block
    tridiagonal), every body once; where the links form no chain there is no order
    (the factorization falls back to ``getrf``).
    """
    linked = np.eye(5, dtype=bool)
    for a, b in edges:
        linked[a, b] = linked[b, a] = True
    order = penalty_linear._chain_order(linked)
    if not chains:
        assert len(order) == 0
        return
    assert sorted(order) == list(range(5))
    place = np.argsort(order)
    assert all(abs(place[a] - place[b]) == 1 for a, b in edges)


@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
def test_compiled_code_is_loaded_once_and_kept_out_of_the_rate(scene, run):
    """The compiled integrator is loaded (or compiled) before the simulation's clocks
    start, once per process: a second simulation reports no loading, and the report's
    sentence states it apart.
    """
    again = simulate_penalty(scene, [0.0, 0.001])
    assert again.compile_s == 0.0
    assert "per simulated second" in again.cost_text()
    assert np.isnan(again.rhs_s)  # the compiled loop does not time its calls one by one


def test_unknown_kernel_or_method_is_refused(scene):
    with pytest.raises(ValueError, match="kernel"):
        simulate_penalty(scene, [0.0, 0.01], kernel="fortran")
    with pytest.raises(ValueError, match="method"):
        simulate_penalty(scene, [0.0, 0.01], method="Euler")
    with pytest.raises(ValueError, match="compiled kernels"):
        simulate_penalty(scene, [0.0, 0.01], method=penalty.COMPILED, kernel="numpy")


def test_runs_to_the_end_with_progress(run):
    result, marks = run
    assert result.success, result.message
    assert marks == pytest.approx([0.1, 0.2])
    assert result.nfev > 0 and result.wall_s > 0
    assert np.all(np.isfinite(result.omega))


def test_forces_have_the_operators_names(run, rigid):
    assert tuple(run[0].forces) == rigid.names


def test_starts_centred_in_the_clearances(run, scene):
    result = run[0]
    assert result.penetration[0] == pytest.approx(-scene.contact.bearing_clearance_m)
    assert all(abs(f[0]) == 0.0 for f in result.forces.values())
    assert 0 < result.penetration[-1] < 1e-5  # micrometres once loaded


def test_angles_follow_the_rigid_model_within_the_play(run, scene):
    """From rest the input turns through the radial play before it meets the rest of the
    line: each shaft's angle leaves the rigid model's by at most the play of the whole
    line, 2 (rb - rs) / hs per joint (the trunnions at +-hs move oppositely), and by
    more than a tenth of it (the play is really there).
    """
    result = run[0]
    motion = simulate(scene, result.t)
    turned = lambda w: cumulative_trapezoid(w, result.t, initial=0.0, axis=1)  # noqa: E731
    lag = np.abs(turned(result.omega) - turned(motion.omega))
    play = sum(2.0 * j.radial_clearance_m / j.hs_m for j in scene.joints)
    assert 0.1 * play < lag.max() < play


def test_forces_satisfy_the_rigid_equilibrium(run, rigid):
    """``||A x - b|| / ||b||`` of the rigid operator at the same instants: what is left is
    the inertia of the clearance motion and the displaced geometry.
    """
    result = run[0]
    x = np.array([result.forces[name] for name in rigid.names]).T
    residual = np.linalg.norm(np.einsum("tij,tj->ti", rigid.A, x) - rigid.b, axis=1)
    relative = residual / np.linalg.norm(rigid.b, axis=1)
    late = result.t >= LATE_S
    assert np.median(relative[late]) < 2e-2
    assert np.max(relative[late]) < 0.2


def test_bearings_carry_the_weight_on_average(run, scene):
    result = run[0]
    vertical = sum(f for name, f in result.forces.items()
                   if name.startswith("bearing.") and name.endswith(".z"))
    weight = -scene.gravity_m_s2[2] * (sum(s.mass_kg for s in scene.shafts)
                                      + len(scene.joints) * scene.crosspin.mass_kg)
    late = result.t >= LATE_S
    assert np.mean(vertical[late]) == pytest.approx(weight, rel=0.02)


def test_end_faces_are_complementary(run, scene):
    forces = run[0].forces
    for joint in scene.joints:
        for a, b in (("F3", "F4"), ("F7", "F8")):
            pair = np.array([forces[f"{joint.name}.{a}"], forces[f"{joint.name}.{b}"]])
            assert np.all(pair >= 0.0)
            assert np.all(pair.min(axis=0) == 0.0)


@pytest.mark.parametrize("kernel", ["numba", "numpy"])
def test_a_failed_integration_is_a_status(scene, monkeypatch, kernel):
    if kernel == "numba" and not penalty.kernels.HAVE_NUMBA:
        pytest.skip("numba not installed")
    monkeypatch.setattr(penalty, "hertz_stiffness", lambda *args: np.nan)
    result = simulate_penalty(scene, [0.0, 0.1], kernel=kernel)  # contact after ~5 ms
    assert result.status == -1 and not result.success
    assert result.message
    assert np.all(np.isnan(result.omega[:, 1:]))


@pytest.mark.slow
def test_one_second_against_the_rigid_model(scene):
    """After the play has closed (t >= 0.5 s): speeds within a few percent, equilibrium
    up to the clearance motion's inertia, and the components the rigid model determines
    (out-of-plane bearing forces, the radial forces normal to the intermediate shaft's
    trunnions, the net end-face push of its yokes) equal to its values on average.
    """
    result = simulate_penalty(scene, np.arange(0.0, 1.0 + 1e-9, 0.005))
    assert result.success, result.message
    late = np.flatnonzero(result.t >= 0.5)
    motion = simulate(scene, result.t)
    op = build_operator(motion)
    assert np.all(np.abs(result.omega[:, late] / motion.omega[:, late] - 1.0) < 0.05)
    x = np.array([result.forces[name] for name in op.names]).T
    residual = np.linalg.norm(np.einsum("tij,tj->ti", op.A, x) - op.b, axis=1)
    assert np.median(residual[late] / np.linalg.norm(op.b[late], axis=1)) < 3e-2
    sets = [determinacy(op, i) for i in late]
    rigid = np.array([d.min_norm for d in sets])
    determinate = sets[0].determinate
    assert determinate.sum() == 8
    gap = np.abs(x[late].mean(axis=0) - rigid.mean(axis=0))
    assert np.all(gap[determinate] < 10.0)  # N; joint loads ~150 N, weight 2660 N
    for joint, push, pull in (("uj1", "F8", "F7"), ("uj2", "F4", "F3")):
        net = op.index(f"{joint}.{push}"), op.index(f"{joint}.{pull}")
        assert abs(np.mean(x[late, net[0]] - x[late, net[1]])
                   - np.mean(rigid[:, net[0]] - rigid[:, net[1]])) < 5.0


def _released(name: str):
    from cardan_forces.driveline.loading import scene_from_dict

    return scene_from_dict({"extends": name, "name": f"{name}-released",
                            "effects": ["gravity", "inertia", "penalty_dynamics"]})


@pytest.mark.parametrize(("name", "stop", "tolerance"),
                         [("paper-slip", 0.2, 0.02), ("propshaft", 0.1, 0.02)])
def test_slip_joints_and_floating_bearings_against_the_rigid_model(name, stop, tolerance):
    """The penalty model takes every element the operator takes (a slip joint's spline,
    floating bearings): a short run from rest succeeds; its forces, in the operator's
    columns, satisfy the rigid equilibrium up to what the compliance leaves (the
    clearance motion's inertia and the displaced geometry: ``||A x - b||`` under 1 %
    of the contact forces' own size ``||A|| ||x||``); and over the second half, the loads
    the rigid model determines equal its values on average within ``tolerance`` of the
    largest of them (``paper-slip``: the bearings only, its joints still rattle in the
    play after 0.2 s).
    """
    scene = _released(name)
    result = simulate_penalty(scene, np.arange(0.0, stop + 1e-9, 0.005))
    assert result.success, result.message
    op = build_operator(simulate(scene, result.t))
    assert tuple(result.forces) == op.names
    x = np.array([result.forces[n] for n in op.names]).T
    late = np.flatnonzero(result.t >= stop / 2)
    residual = np.linalg.norm(np.einsum("tij,tj->ti", op.A, x) - op.b, axis=1)
    scale = np.linalg.norm(op.A, axis=(1, 2)) * np.linalg.norm(x, axis=1)
    assert np.median(residual[late] / scale[late]) < 0.01
    sets = [determinacy(op, i) for i in late]
    determinate = np.logical_and.reduce([d.determinate for d in sets])
    if name == "paper-slip":
        determinate &= np.isin(np.arange(len(op.names)),
                               [c for link in op.bearings() for c in link.columns])
    assert determinate.any()
    rigid = np.array([d.min_norm for d in sets])[:, determinate].mean(axis=0)
    gap = np.abs(x[late][:, determinate].mean(axis=0) - rigid)
    assert gap.max() < tolerance * np.abs(rigid).max()
