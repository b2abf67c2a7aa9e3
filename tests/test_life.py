"""ISO 281 bearing life (``cardan life``): the standard's formulas by hand, the interval
over the rigid set around every selection, a point where the radial loads are
determinate, an open worst case named with the release that bounds it, strict JSON."""

import importlib.util
import json
import math

import numpy as np
import pytest
from cardan_forces.driveline import bearing_life as iso
from cardan_forces.driveline import penalty
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.driveline.scene import BearingRating
from cardan_forces.experiments import life, life_runs
from cardan_forces.experiments.images import problems
from cardan_forces.experiments.study import solve_over_time

from cardan_forces.cli import main

INSTANTS = 5
SIMULATED = (life_runs.PENALTY, life_runs.ENGINE)


@pytest.fixture(scope="module")
def propshaft():
    return life.study("propshaft", INSTANTS)


@pytest.fixture(scope="module")
def paper():
    return life.study("paper", INSTANTS)


def _strict(text: str):
    """JSON that has no NaN or Infinity (json.loads would take them otherwise)."""
    def refuse(name):
        raise ValueError(f"non-strict JSON constant {name}")
    return json.loads(text, parse_constant=refuse)


def _by_hand(rating: BearingRating, fr: np.ndarray, fa: np.ndarray) -> np.ndarray:
    """``P`` written out for the types propshaft rates, ISO 281's factors as printed:
    its deep-groove ball bearings carry less than 0.014 C0 axially (Table 3's first row:
    e 0.19, X 0.56, Y 2.30), its cylindrical roller ones (floating) none."""
    fa = np.abs(fa)
    if rating.type == "ball":
        assert fa.max() < 0.014 * rating.C0_N
        e, x, y = 0.19, 0.56, 2.30
    else:
        assert rating.type == "cylindrical_roller"
        assert fa.max() < 1e-9 * fr.max()  # floating: radial only
        return fr
    return np.where(fa / fr > e, x * fr + y * fa, fr)


def test_l10_is_iso_281_by_hand_on_determinate_loads(propshaft):
    """propshaft's bearing loads are determinate: the positive selection's L10 equals
    (C/Pm)^p with Pm the revolution-weighted p-mean of P, every step written here from
    the operator's bearing loads and the motion's speeds."""
    scene = load_scene("propshaft")
    t = np.linspace(scene.time.start_s, scene.time.stop_s, INSTANTS)
    motion = simulate(scene, t)
    op = build_operator(motion)
    forces = solve_over_time(op, "positive").forces
    ratings = {f"{s.name}.{b.name}": b.rating for s in scene.shafts for b in s.bearings}
    weights = np.full(INSTANTS, t[1] - t[0])
    weights[[0, -1]] /= 2
    found = {e["bearing"]: e for e in propshaft["bearings"]}
    assert set(found) == set(ratings)
    for name, load in op.bearing_loads(forces).items():
        rating = ratings[name]
        p = _by_hand(rating, load.radial, load.axial)
        revs = np.abs(motion.omega[load.shaft]) * weights / (2 * math.pi)
        power = 10 / 3 if rating.type.endswith("roller") else 3.0
        pm = (np.sum(p ** power * revs) / revs.sum()) ** (1 / power)
        l10 = (rating.C_N / pm) ** power
        hours = l10 * 1e6 / (revs.sum() / (t[-1] - t[0])) / 3600
        entry = found[name]["selections"]["positive"]
        assert entry["P_N"] == pytest.approx(p, rel=1e-9)
        assert entry["L10_Mrev"] == pytest.approx(l10, rel=1e-9)
        assert entry["L10_h"] == pytest.approx(hours, rel=1e-9)


def test_iso_tables_rows_and_switch():
    """Table 3's rows are met exactly, interpolated between them, and P switches at e."""
    ball = BearingRating(type="ball", C_N=30e3, C0_N=20e3)
    x, y, e = iso.factors(ball, np.array([0.056 * 20e3, 0.07 * 20e3]))
    assert (x[0], y[0], e[0]) == pytest.approx((0.56, 1.71, 0.26))
    assert (y[1], e[1]) == pytest.approx(((1.71 + 1.55) / 2, (0.26 + 0.28) / 2))
    angular = BearingRating(type="angular_contact_ball", C_N=1.0, C0_N=1.0,
                            contact_angle_deg=27.5)
    assert [v[0] for v in iso.factors(angular, np.zeros(1))] == pytest.approx(
        [(0.41 + 0.39) / 2, (0.87 + 0.76) / 2, (0.68 + 0.80) / 2])
    taper = BearingRating(type="tapered_roller", C_N=1.0, C0_N=1.0, contact_angle_deg=15.0)
    e = 1.5 * math.tan(math.radians(15.0))
    below, above = iso.equivalent_load(taper, [1000.0, 1000.0], [0.99 * e * 1000, 2 * e * 1000])
    assert below == 1000.0
    assert above == pytest.approx(400 + 0.4 / math.tan(math.radians(15)) * 2 * e * 1000)
    assert iso.rating_life(taper, 0.0) == math.inf


def test_every_selection_lies_in_the_set_interval(propshaft, paper):
    """Each rigid selection's P at each instant lies between the set's least and
    greatest (to 1e-6); MuJoCo's, an engine's soft equilibrium, within 1e-3 of its load
    at every instant after its settling."""
    assert "mujoco" in paper["selections"] or importlib.util.find_spec("mujoco") is None
    for answer in (propshaft, paper):
        for entry in answer["bearings"]:
            lo = np.asarray(entry["interval"]["P_min_N"])
            hi = np.asarray(entry["interval"]["P_max_N"])
            for name, sel in entry["selections"].items():
                p = np.asarray(sel["P_N"])
                kept = np.isfinite(p) if name in SIMULATED else np.ones(len(p), bool)
                assert kept[1:].all(), (entry["bearing"], name)  # only the settling is out
                slack = (1e-3 if name in SIMULATED else 1e-6) * max(1.0, np.nanmax(p))
                assert np.all(p[kept] >= lo[kept] - slack), (entry["bearing"], name)
                assert np.all(p[kept] <= hi[kept] + slack), (entry["bearing"], name)


def test_propshaft_radial_life_interval_is_a_point(propshaft):
    """Radial loads determinate, no axial spread: every life interval is one value."""
    assert not propshaft["open"]
    for entry in propshaft["bearings"]:
        interval = entry["interval"]
        assert interval["radial_determinate"]
        assert interval["P_max_N"] == pytest.approx(interval["P_min_N"], rel=1e-9)
        worst, best = interval["L10_h"]
        assert worst == pytest.approx(best, rel=1e-8)
        assert entry["selections"]["compliance"]["L10_h"] == pytest.approx(worst, rel=1e-6)


def test_paper_worst_case_is_open_and_the_release_bounds_it(paper):
    """paper's closed loop leaves the in-plane loads open above: no finite worst case,
    the advisor's release named, and on the released line every bearing's radial and
    axial load bounded."""
    assert paper["open"] and paper["open_reason"] == life.OPEN
    assert all(e["interval"]["open"] and e["interval"]["L10_h"][0] == 0.0
               for e in paper["bearings"])
    assert not problems(life.figure(paper))  # the print rules, the open bars labelled
    labels = paper["release"]["labels"]
    assert any(label.startswith("slip:") for label in labels)
    from cardan_forces.driveline.release import advise

    scene = load_scene("paper")
    motion = simulate(scene, np.linspace(scene.time.start_s, scene.time.stop_s, 3))
    advice = advise(motion, 1)
    assert [r.label for r in advice.releases] == labels
    released = advice.operator
    for entry in life.envelope_at(released, 1, life.rated(released)):
        assert math.isfinite(entry["fr"][1]) and math.isfinite(entry["fa"][1])


def test_life_json_is_strict_and_files_are_written(tmp_path, capsys):
    assert main(["life", "paper-slip", "--instants", "3", "--json", "--quiet"]) == 0
    answer = _strict(capsys.readouterr().out)
    assert answer["scene"] == "paper-slip" and len(answer["bearings"]) == 4
    assert answer["not_run"]["penalty"].startswith("not run")
    assert main(["life", "propshaft", "--instants", "3", "--out", str(tmp_path), "--quiet",
                 "--format", "png,svg"]) == 0
    written = capsys.readouterr().out.split()
    assert {p.rsplit(".", 1)[-1] for p in written} == {"csv", "md", "png", "svg"}


def test_life_bad_input_is_one_message(capsys):
    assert main(["life", "paper", "--instants", "1"]) == 2
    assert main(["life", "no-such-scene"]) == 2
    err = capsys.readouterr().err
    assert err.count("cardan: error:") == 2 and "Traceback" not in err


def _short(name: str, stop_s: float = 1.0, instants: int = 6):
    """``name``'s operator over its first ``stop_s`` seconds."""
    scene = load_scene(name)
    return build_operator(simulate(scene, np.linspace(scene.time.start_s, stop_s, instants)))


def test_stretch_means_are_exact_on_a_line():
    """A linear signal's trapezoid mean over an instant's stretch (half way to each
    neighbour, the ends' halved) is its value at the stretch's centre."""
    t = np.array([0.0, 0.2, 0.4, 0.7])
    m = life_runs.substeps(t, 0.04)
    assert m % 2 == 0 and np.diff(life_runs.dense_times(t, m)).max() <= 0.04 + 1e-12
    dense = life_runs.dense_times(t, m)
    assert np.allclose(dense[::m], t)
    means = life_runs.stretch_means(np.column_stack([3.0 - 2.0 * dense]), dense, len(t),
                                    m)[:, 0]
    edges = np.concatenate([t[:1], (t[1:] + t[:-1]) / 2, t[-1:]])
    centres = (edges[1:] + edges[:-1]) / 2
    assert means == pytest.approx(3.0 - 2.0 * centres, rel=1e-12)


@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
def test_penalty_average_carries_the_determinate_radial_loads():
    """paper-slip's radial bearing loads are determinate: the released line's penalty
    simulation, averaged over each instant's stretch, carries them to 3 % once past its
    first stretch (the start from centred clearances, where the line settles). Measured:
    within 1 %."""
    op = _short("paper-slip")
    history, words = life_runs.penalty_history(op)
    assert history is not None, words
    for i in range(1, len(op.t)):
        for (contact, _), entry in zip(life.rated(op), life.envelope_at(op, i, life.rated(op))):
            assert entry["radial_determinate"]
            fr = life.loads(op, contact, history.forces[i:i + 1])[0][0]
            assert fr == pytest.approx(entry["fr"][0], rel=0.03), (contact.element, i)


def test_mujoco_carries_the_determinate_radial_loads():
    """MuJoCo's forces after its settling carry paper-slip's determinate radial loads to
    its soft constraints' equilibrium error (a few 1e-5 of the load, by its own RK4
    step); 1e-3 asked."""
    pytest.importorskip("mujoco")
    op = _short("paper-slip")
    history, words = life_runs.engine_history(op)
    assert history is not None, words
    assert np.isnan(history.forces[0]).all() and history.solved == len(op.t) - 1
    for i in range(1, len(op.t)):
        for (contact, _), entry in zip(life.rated(op), life.envelope_at(op, i, life.rated(op))):
            fr = life.loads(op, contact, history.forces[i:i + 1])[0][0]
            assert fr == pytest.approx(entry["fr"][0], rel=1e-3), (contact.element, i)


def test_a_simulation_that_cannot_run_says_why(capsys):
    """propshaft is quasi-static: neither simulation runs, each says why, exit 0."""
    assert main(["life", "propshaft", "--instants", "3", "--penalty", "--json",
                 "--quiet"]) == 0
    answer = _strict(capsys.readouterr().out)
    assert set(answer["selections"]) == set(life.SELECTIONS)
    assert "'inertia' effect" in answer["not_run"]["penalty"]
    assert answer["not_run"]["mujoco"].startswith("not run: ")
    assert main(["life", "paper-slip", "--instants", "3", "--no-engine", "--json",
                 "--quiet"]) == 0
    assert _strict(capsys.readouterr().out)["not_run"]["mujoco"] == life.NOT_ASKED["mujoco"]


def test_axle_pinion_tapered_pair_by_its_catalogue_factors():
    """The pinion's tapered roller pair, rated with its maker's X, Y, e: P = X Fr + Y
    |Fa| where |Fa| > e Fr, else Fr, with Fr and Fa the operator's bearing loads; one
    of the pair takes the axial load (the O pair pushes one way each), and its L10 is
    (C / Pm)^(10/3)."""
    answer = life.study("axle-pinion", 3, engine=False)
    scene = load_scene("axle-pinion")
    t = np.linspace(scene.time.start_s, scene.time.stop_s, 3)
    op = build_operator(simulate(scene, t))
    forces = solve_over_time(op, "positive").forces
    found = {e["bearing"]: e for e in answer["bearings"]}
    axial = 0
    for name, load in op.bearing_loads(forces).items():
        if not name.startswith("pinion."):
            continue
        rating = found[name]
        x, y, e = rating["rating"]["X_Y_e"]
        fr, fa = load.radial, np.abs(load.axial)
        p = np.where(fa > e * fr, x * fr + y * fa, fr)
        entry = rating["selections"]["positive"]
        assert entry["P_N"] == pytest.approx(p, rel=1e-9)
        assert entry["Fa_N"] == pytest.approx(load.axial, abs=1e-9 * fr.max())
        assert entry["L10_Mrev"] == pytest.approx(
            (rating["rating"]["C_N"] / entry["Pm_N"]) ** (10 / 3), rel=1e-12)
        axial += entry["axial_instants"]
    assert axial > 0


def test_light_loads_are_said_to_make_the_long_lives(propshaft):
    """peak_P_over_C is the greatest P of any selection over C; life.md says the loads
    are light only where every bearing's is at most 5 % of C."""
    for entry in propshaft["bearings"]:
        peak = max(np.nanmax(s["P_N"]) for s in entry["selections"].values())
        assert entry["peak_P_over_C"] == pytest.approx(peak / entry["rating"]["C_N"])
    assert max(e["peak_P_over_C"] for e in propshaft["bearings"]) <= life.LIGHT_LOAD
    assert "lightly loaded" in life.markdown(propshaft)
    heavy = {**propshaft, "bearings": [{**e, "peak_P_over_C": 0.2}
                                       for e in propshaft["bearings"]]}
    text = life.markdown(heavy)
    assert "is 20 % of C" in text and "lightly loaded" not in text
