"""ISO 281 bearing life (``cardan life``): the standard's formulas by hand, the interval
over the rigid set around every selection, a point where the radial loads are
determinate, an open worst case named with the release that bounds it, strict JSON; over
a duty cycle, Palmgren-Miner against its closed form, hours at the spectrum's mean speed
only, ISO 281:2007's modified life per bin, the run's spectrum options refused in one
line."""

import csv
import dataclasses
import importlib.util
import json
import math
from pathlib import Path

import numpy as np
import pytest
from cardan_forces.driveline import bearing_life as iso
from cardan_forces.driveline import penalty
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import builtin_text, load_scene
from cardan_forces.driveline.scene import BearingRating
from cardan_forces.experiments import images, life_duty, life_report, life_runs, life_study
from cardan_forces.experiments.environment import json_text
from cardan_forces.experiments.study import solve_over_time

from cardan_forces.cli import main

INSTANTS = 5
SIMULATED = (life_runs.PENALTY, life_runs.ENGINE)


@pytest.fixture(scope="module")
def propshaft():
    return life_study.study("propshaft", INSTANTS)


@pytest.fixture(scope="module")
def paper():
    return life_study.study("paper", INSTANTS)


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
    the operator's bearing loads and the motion's speeds. A window is a start-up: no
    hours, and the reason says so."""
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
        entry = found[name]["selections"]["positive"]
        assert entry["P_N"] == pytest.approx(p, rel=1e-9)
        assert entry["L10_Mrev"] == pytest.approx(l10, rel=1e-9)
        assert math.isnan(entry["L10_h"]) and entry["hours_reason"] == life_duty.NO_HOURS


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
        worst, best = interval["L10_Mrev"]
        assert worst == pytest.approx(best, rel=1e-8)
        assert entry["selections"]["compliance"]["L10_Mrev"] == pytest.approx(worst, rel=1e-6)


def test_paper_worst_case_is_open_and_the_release_bounds_it(paper):
    """paper's closed loop leaves the in-plane loads open above: no finite worst case,
    the advisor's release named, and on the released line every bearing's radial and
    axial load bounded."""
    assert paper["open"] and paper["open_reason"] == life_study.OPEN
    assert all(e["interval"]["open"] and e["interval"]["L10_Mrev"][0] == 0.0
               for e in paper["bearings"])
    with images.styled():
        fig = life_report.figure(paper)
    assert images.print_problems(fig) == []  # the print rules, the open ends labelled
    labels = paper["release"]["labels"]
    assert any(label.startswith("slip:") for label in labels)
    from cardan_forces.driveline.release import advise

    scene = load_scene("paper")
    motion = simulate(scene, np.linspace(scene.time.start_s, scene.time.stop_s, 3))
    advice = advise(motion, 1)
    assert [r.label for r in advice.releases] == labels
    released = advice.operator
    for entry in life_study.envelope_at(released, 1, life_study.rated(released)):
        assert math.isfinite(entry["fr"][1]) and math.isfinite(entry["fa"][1])


def test_life_json_is_strict_and_files_are_written(tmp_path, capsys, empty_pictures):
    assert main(["life", "paper-slip", "--instants", "3", "--json", "--quiet"]) == 0
    answer = _strict(capsys.readouterr().out)
    assert answer["scene"] == "paper-slip" and len(answer["bearings"]) == 4
    assert answer["not_run"]["penalty"].startswith("not run")
    assert main(["life", "propshaft", "--instants", "3", "--out", str(tmp_path), "--quiet",
                 "--format", "png,svg"]) == 0
    assert capsys.readouterr().out == ""  # the files are named on stderr, not --quiet
    assert {p.suffix for p in tmp_path.iterdir()} == {".csv", ".md", ".png", ".svg"}


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
        for (contact, _), entry in zip(life_study.rated(op),
                                       life_study.envelope_at(op, i, life_study.rated(op))):
            assert entry["radial_determinate"]
            fr = life_study.loads(op, contact, history.forces[i:i + 1])[0][0]
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
        for (contact, _), entry in zip(life_study.rated(op),
                                       life_study.envelope_at(op, i, life_study.rated(op))):
            fr = life_study.loads(op, contact, history.forces[i:i + 1])[0][0]
            assert fr == pytest.approx(entry["fr"][0], rel=1e-3), (contact.element, i)


def test_a_simulation_that_cannot_run_says_why(capsys):
    """propshaft is quasi-static: neither simulation runs, each says why, exit 0."""
    assert main(["life", "propshaft", "--instants", "3", "--penalty", "--json",
                 "--quiet"]) == 0
    answer = _strict(capsys.readouterr().out)
    assert set(answer["selections"]) == set(life_study.SELECTIONS)
    assert "'inertia' effect" in answer["not_run"]["penalty"]
    assert answer["not_run"]["mujoco"].startswith("not run: ")
    assert main(["life", "paper-slip", "--instants", "3", "--no-engine", "--json",
                 "--quiet"]) == 0
    assert _strict(capsys.readouterr().out)["not_run"]["mujoco"] == life_study.NOT_ASKED["mujoco"]


def test_axle_pinion_tapered_pair_by_its_catalogue_factors():
    """The pinion's tapered roller pair, rated with its maker's X, Y, e: P = X Fr + Y
    |Fa| where |Fa| > e Fr, else Fr, with Fr and Fa the operator's bearing loads; one
    of the pair takes the axial load (the O pair pushes one way each), and its L10 is
    (C / Pm)^(10/3)."""
    answer = life_study.study("axle-pinion", 3, engine=False)
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
    assert max(e["peak_P_over_C"] for e in propshaft["bearings"]) <= life_report.LIGHT_LOAD
    assert "lightly loaded" in life_report.markdown(propshaft)
    heavy = {**propshaft, "bearings": [{**e, "peak_P_over_C": 0.2}
                                       for e in propshaft["bearings"]]}
    text = life_report.markdown(heavy)
    assert "is 20 % of C" in text and "lightly loaded" not in text


def _lives(answer: dict):
    """Every life of an answer: ``(where, Pm, L10 Mrev, reason, L10 h, its reason)`` per
    bearing and selection, and the set's worst and best."""
    for e in answer["bearings"]:
        for name, s in e["selections"].items():
            yield ((e["bearing"], name), s["Pm_N"], s["L10_Mrev"], s["reason"], s["L10_h"],
                   s["hours_reason"] or s["reason"])
        i = e["interval"]
        for k, end in enumerate(("set worst", "set best")):
            yield ((e["bearing"], end), i["Pm_N"][1 - k], i["L10_Mrev"][k], i["reason"][k],
                   i["L10_h"][k], i["hours_reason"] or i["reason"][k])


def _has_reason_iff_not_finite(answer: dict) -> int:
    """Every life has a reason exactly where one of its numbers is not finite, and its
    hours one where they are not; how many lives have one."""
    found = 0
    for where, pm, l10, reason, hours, hours_reason in _lives(answer):
        finite = math.isfinite(pm) and math.isfinite(l10)
        assert finite == (reason is None), (where, pm, l10, reason)
        assert math.isfinite(hours) == (hours_reason is None), (where, hours)
        found += reason is not None
    return found


RATING = BearingRating(type="ball", C_N=30e3, C0_N=20e3)


@pytest.mark.parametrize("p, revs, keep, words", [
    ([100.0, 200.0, 300.0], [0.0, 0.0, 0.0], None, "speed 0"),
    ([100.0, math.nan, 300.0], [1.0, 2.0, 1.0], None, "not known at 1 of the 3"),
    ([100.0, math.inf, 300.0], [1.0, 2.0, 1.0], None, "unbounded"),
    ([0.0, 0.0, 0.0], [1.0, 2.0, 1.0], None, "no load"),
    ([math.nan, math.nan, 300.0], [1.0, 2.0, 0.0], [False, False, True], "none of the"),
])
def test_each_way_a_life_has_no_value_carries_its_reason(p, revs, keep, words):
    """A still shaft, an unknown load, an unbounded one, no load, no instant kept while
    the shaft turns: each leaves Pm or L10 without a finite value, and each says why; a
    load history with a value has no reason."""
    keep = None if keep is None else np.array(keep)
    found = life_study.life(RATING, np.array(p), np.array(revs), keep)
    assert not all(math.isfinite(found[k]) for k in ("Pm_N", "L10_Mrev"))
    assert words in found["reason"]
    fine = life_study.life(RATING, np.array([100.0, 0.0, 300.0]), np.array(revs) + 1.0)
    assert fine["reason"] is None and math.isfinite(fine["L10_Mrev"])


def test_every_life_of_an_answer_without_a_value_says_why(propshaft, paper):
    """In the answers, over every selection and the set's ends: a reason exactly where a
    number is not finite (paper's open worst cases have one each)."""
    assert _has_reason_iff_not_finite(propshaft) == 0
    assert _has_reason_iff_not_finite(paper) == len(paper["bearings"])


def _altered(monkeypatch, name: str, change):
    """study's rigid selection ``name`` with its forces passed through ``change``."""
    solve = life_study.solve_over_time

    def altered(op, formulation, *args, **kwargs):
        history = solve(op, formulation, *args, **kwargs)
        if formulation != name:
            return history
        return dataclasses.replace(history, forces=change(history.forces.copy()))
    monkeypatch.setattr(life_study, "solve_over_time", altered)


def test_unsolved_and_unloaded_lives_say_why_in_json_and_report(monkeypatch):
    """A rigid selection not solved at an instant and one carrying no load: null lives in
    the JSON, each with its reason, and life.md lists them."""
    def unsolved(forces):
        forces[1] = np.nan
        return forces
    _altered(monkeypatch, "positive", unsolved)
    answer = life_study.study("propshaft", 3, engine=False)
    assert _has_reason_iff_not_finite(answer) == len(answer["bearings"])
    for entry in _strict(json_text(answer))["bearings"]:
        positive = entry["selections"]["positive"]
        assert positive["L10_Mrev"] is None and "not known at 1 of the 3" in positive["reason"]
    assert life_report.markdown(answer).count("positive: no value: P is not known at 1 of the 3") \
        == len(answer["bearings"])
    monkeypatch.undo()
    _altered(monkeypatch, "compliance", lambda forces: 0.0 * forces)
    answer = life_study.study("propshaft", 3, engine=False)
    assert _has_reason_iff_not_finite(answer) == len(answer["bearings"])
    assert "compliance: unbounded: the bearing carries no load" in life_report.markdown(answer)


def test_a_scene_whose_shafts_do_not_turn_is_refused(tmp_path, capsys):
    """ISO 281 counts a life in revolutions: a scene at speed 0 under balanced torques
    has none, and is refused with one line, exit code 2, before any solve."""
    text = builtin_text("propshaft")
    assert "speed_rad_s = 10.0" in text
    still = tmp_path / "still.toml"
    still.write_text(text.replace("speed_rad_s = 10.0", "speed_rad_s = 0.0"))
    for extra in ([], ["--json"]):
        assert main(["life", str(still), "--instants", "3", "--quiet", *extra]) == 2
        out, err = capsys.readouterr()
        assert out == "" and err.count("\n") == 1 and "speed 0" in err, err


def _stand_in(factor: float):
    """A penalty selection of the positive forces times ``factor``: a model whose loads
    lie off the rigid set by a known share."""
    def run(op, progress=None):
        h = solve_over_time(op, "positive")
        return dataclasses.replace(h, formulation=life_runs.PENALTY,
                                   forces=factor * h.forces), "a stand-in"
    return run


@pytest.mark.parametrize("factor, inside", [(0.97, False), (1.03, False),
                                            (1.0 + 1e-6, True)])
def test_whether_a_life_lies_in_the_set_is_computed(monkeypatch, factor, inside):
    """propshaft's set is a point (determinate loads) and its P is homogeneous in the
    forces: loads 3 % off it put the life outside, by 3 % of Pm and on the right side;
    1e-6 off, within the tolerance, inside. The report says which, and what the
    penalty selection is (a different model), never that it is a member of the set."""
    monkeypatch.setattr(life_study, "penalty_history", _stand_in(factor))
    answer = life_study.study("propshaft", 3, penalty=True, engine=False)
    for entry in answer["bearings"]:
        check = entry["selections"]["penalty"]["in_set"]
        assert check["inside"] is inside, (entry["bearing"], check)
        assert check["Pm_beyond"] == pytest.approx(0.0 if inside else factor - 1, rel=1e-6)
        assert all(entry["selections"][n]["in_set"]["inside"] for n in life_study.SELECTIONS)
    text = life_report.markdown(answer)
    penalty_line = next(line for line in text.splitlines() if line.startswith("- penalty:"))
    assert life_study.MODELS["penalty"] in penalty_line and "member" not in penalty_line
    assert ("Inside at every bearing" in penalty_line) is inside
    assert text.count("(outside the set)") == (0 if inside else len(answer["bearings"]))


def test_in_set_tolerance_sides_and_missing_values():
    """Within IN_SET_TOL of the load scale is inside; beyond it, the signed share of the
    nearer end; an open greatest end holds any Pm above the least; a side without a
    value is not compared, and says so."""
    tol = life_study.IN_SET_TOL
    assert life_study.in_set(100.0 + 0.5 * tol * 1000, (90.0, 100.0), 1000.0)["inside"]
    above = life_study.in_set(100.0 + 2 * tol * 1000, (90.0, 100.0), 1000.0)
    assert above["inside"] is False and above["Pm_beyond"] == pytest.approx(2 * tol * 10)
    below = life_study.in_set(81.0, (90.0, 100.0), 1000.0)
    assert below["inside"] is False and below["Pm_beyond"] == pytest.approx(-0.1)
    assert life_study.in_set(1e9, (90.0, math.inf), 1000.0)["inside"]
    for pm, ends in ((math.nan, (90.0, 100.0)), (95.0, (math.nan, 100.0))):
        missing = life_study.in_set(pm, ends, 1000.0)
        assert missing["inside"] is None and missing["why"].startswith("not compared")


def test_every_empty_csv_cell_says_why(paper, tmp_path):
    """life.csv: a note exactly where P is empty (paper's open greatest P)."""
    path = tmp_path / "life.csv"
    life_report.write_csv(paper, path)
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    assert any(r["P_N"] == "" for r in rows)
    assert all((r["P_N"] == "") == bool(r["note"]) for r in rows)


@pytest.mark.parametrize("out", ["", " "])
def test_an_empty_out_is_refused(out, tmp_path, monkeypatch, capsys):
    """An empty or blank --out would write into the current folder: one line, exit 2,
    nothing written."""
    monkeypatch.chdir(tmp_path)
    assert main(["life", "propshaft", "--instants", "2", "--out", out, "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("cardan: error:") == 1 and "--out" in err and "Traceback" not in err
    assert not any(tmp_path.iterdir())


def test_the_how_to_states_the_in_set_tolerance_and_the_models():
    """docs/how-to/life.md gives the tolerance the answer uses, and says the penalty
    average is a different model that may lie outside the set."""
    text = " ".join((Path(__file__).parents[1] / "docs/how-to/life.md").read_text().split())
    assert f"`in_set_tol` ({life_study.IN_SET_TOL:g})" in text
    assert "not a member of the rigid set: its life may lie outside" in text
    assert "every member of the rigid solution set" not in text


# ---------------------------------------------------------------- duty cycles

TWO_BINS = """
[[duty_cycle]]
torque_N_m = 10.0
speed_rpm = 600.0
share = 0.25

[[duty_cycle]]
torque_N_m = 4.0
speed_rpm = 2400.0
share = 0.75
"""
"""A two-bin spectrum at the paper line's torque: a quarter of the time at 600 r/min."""

TAPER_ISO = ", C_u_N = 4800.0, mean_diameter_m = 0.046, viscosity_mm2_s = 20.0, " \
    "contamination = 0.5 }"
"""ISO 281:2007's inputs of the axle pinion's tapered rollers (an SKF 30206's C_u and
mean diameter; an oil of 20 mm^2/s at its running temperature, normal cleanliness)."""

BALL_ISO = "C0_N = 38000.0\nC_u_N = 1600.0\nmean_diameter_m = 0.08\nviscosity_mm2_s = " \
    "20.0\ncontamination = 0.5\n"
"""The same for propshaft's SKF 6310 (C_u 1.6 kN, mean diameter 80 mm)."""


def _scene_file(folder: Path, name: str, text: str) -> str:
    path = folder / f"{name}.toml"
    path.write_text(text)
    return str(path)


@pytest.fixture(scope="module")
def duty_scenes(tmp_path_factory):
    """axle-pinion with its pinion's ISO 281:2007 inputs and TWO_BINS; propshaft with its
    SKF 6310s' and one bin at its own torque and 600 r/min."""
    folder = tmp_path_factory.mktemp("duty")
    pinion = builtin_text("axle-pinion")
    assert pinion.count("e = 0.37 }") == 2
    propshaft = builtin_text("propshaft")
    assert propshaft.count("C0_N = 38000.0\n") == 2
    one = "\n[[duty_cycle]]\ntorque_N_m = 2500.0\nspeed_rpm = 600.0\nshare = 1.0\n"
    return {"pinion": _scene_file(folder, "pinion", pinion.replace("e = 0.37 }",
                                                                   "e = 0.37" + TAPER_ISO)
                                  + TWO_BINS),
            "propshaft": _scene_file(folder, "propshaft", propshaft.replace(
                "C0_N = 38000.0\n", BALL_ISO) + one),
            "folder": folder}


@pytest.fixture(scope="module")
def spectrum(duty_scenes):
    return life_study.study(duty_scenes["pinion"], 3)


def test_bins_combine_by_palmgren_miner_with_hours_at_the_mean_speed(spectrum):
    """Each bearing's L10 = 1 / sum(u_i / L10_i) with u_i = t_i n_i / sum t_j n_j from its
    shaft's speed in each bin, its Pm ISO 281's p-mean over the bins' revolutions, its
    hours L10 1e6 / (60 n_m) at the time-weighted mean speed, written out here."""
    assert spectrum["duty_cycle"]["mean_speed_rpm"] == pytest.approx(0.25 * 600 + 0.75 * 2400)
    shares = [0.25, 0.75]
    for e in spectrum["bearings"]:
        speeds = e["speed_rpm"]
        assert speeds == pytest.approx([600.0, 2400.0], rel=1e-3)  # a Cardan line's mean
        mean = shares[0] * speeds[0] + shares[1] * speeds[1]
        u = [shares[k] * speeds[k] / mean for k in (0, 1)]
        assert e["revolution_shares"] == pytest.approx(u, rel=1e-12)
        power = e["rating"]["p"]
        for name, sel in e["selections"].items():
            per_bin = [b["selections"][name] for b in e["bins"]]
            l10 = 1 / (u[0] / per_bin[0]["L10_Mrev"] + u[1] / per_bin[1]["L10_Mrev"])
            pm = (u[0] * per_bin[0]["Pm_N"] ** power + u[1] * per_bin[1]["Pm_N"] ** power
                  ) ** (1 / power)
            assert sel["L10_Mrev"] == pytest.approx(l10, rel=1e-10), (e["bearing"], name)
            assert sel["Pm_N"] == pytest.approx(pm, rel=1e-12)
            assert sel["L10_h"] == pytest.approx(l10 * 1e6 / (60 * mean), rel=1e-12)


def test_every_rigid_selection_lies_in_the_set_per_bin_and_combined(spectrum):
    """Per bin and over the spectrum, each rigid selection's Pm lies between the set's
    (in_set, computed) and its L10 between the set's worst and best."""
    assert set(spectrum["selections"]) == set(life_study.SELECTIONS)
    for e in spectrum["bearings"]:
        for where in (*e["bins"], e):
            worst, best = where["interval"]["L10_Mrev"]
            for name, sel in where["selections"].items():
                assert sel["in_set"]["inside"], (e["bearing"], name)
                assert worst * (1 - 1e-6) <= sel["L10_Mrev"] <= best * (1 + 1e-6)


def test_modified_life_per_bin_and_combined(spectrum):
    """a_ISO per bin from that bin's Pm and the shaft's speed (ISO 281:2007, through
    bearing_life), L_nm = 1 / sum(u_i / L_nm,i), in hours at the mean speed; a bearing
    whose rating lacks the inputs says so instead."""
    rated_iso = 0
    for e in spectrum["bearings"]:
        rating = BearingRating(**{k: v for k, v in e["rating"].items()
                                  if k not in ("p", "X_Y_e")},
                               **dict(zip("XYe", e["rating"]["X_Y_e"]))
                               if isinstance(e["rating"]["X_Y_e"], list) else {})
        u, mean = e["revolution_shares"], e["mean_speed_rpm"]
        for name, sel in e["selections"].items():
            if rating.C_u_N is None:
                assert sel["L_nm_Mrev"] is None or math.isnan(sel["L_nm_Mrev"])
                assert "no ISO 281:2007 inputs" in sel["modified_reason"]
                continue
            rated_iso += 1
            bins = [b["selections"][name] for b in e["bins"]]
            for b, n in zip(bins, e["speed_rpm"]):
                a_iso, kappa, _ = iso.life_modification_factor(rating, b["Pm_N"], n)
                assert (b["a_ISO"], b["kappa"]) == pytest.approx((a_iso, kappa))
                assert b["L_nm_Mrev"] == pytest.approx(a_iso * b["L10_Mrev"])
            l_nm = 1 / sum(ui / b["L_nm_Mrev"] for ui, b in zip(u, bins))
            assert sel["L_nm_Mrev"] == pytest.approx(l_nm, rel=1e-12)
            assert sel["L_nm_h"] == pytest.approx(l_nm * 1e6 / (60 * mean), rel=1e-12)
            assert sel["a_ISO"] == [b["a_ISO"] for b in bins]
    assert rated_iso == 2 * len(life_study.SELECTIONS)


def test_a_spectrum_s_report_warns_and_says_why(spectrum):
    """Simulations not run (in words), the minimum-load warning naming the bearing and
    its bins, the light-load sentence kept, strict JSON, a figure in hours."""
    assert set(spectrum["not_run"]) == set(SIMULATED)
    assert all("quasi-static" in why for why in spectrum["not_run"].values())
    text = life_report.markdown(spectrum)
    below = [e for e in spectrum["bearings"] if e["minimum_load"]["below"]]
    assert below and all(e["minimum_load"]["bins"] == [1, 2] for e in below)
    for e in below:
        assert f"**{e['bearing']}** in bin(s) 1, 2" in text
    assert "0,02 C on roller bearings" in text and "lightly loaded" in text
    assert "input.far, input.near, L_nm: bins 1, 2: no ISO 281:2007 inputs" in text
    assert _strict(json_text(spectrum))["bearings"][0]["kappa"] == [None, None]
    with images.styled():
        fig = life_report.figure(spectrum)
    assert "[h]" in fig.axes[0].get_xlabel() and images.print_problems(fig) == []


def test_one_bin_is_a_speed_rpm_run(duty_scenes, capsys):
    """A scene's one bin at its own torque and 600 r/min rates as --speed-rpm 600 does,
    to the digit; --reliability 99 scales L_nm by ISO 281:2007's a1 = 0.25."""
    scene = duty_scenes["propshaft"]
    runs = {}
    for extra in ([], ["--speed-rpm", "600"], ["--speed-rpm", "600", "--reliability", "99"]):
        assert main(["life", scene, "--instants", "3", "--json", "--quiet", *extra]) == 0
        runs[" ".join(extra)] = _strict(capsys.readouterr().out)
    own, speed, sure = runs.values()
    assert own["duty_cycle"]["source"] == "the scene's [[duty_cycle]]"
    assert speed["duty_cycle"]["source"].startswith("--speed-rpm 600")
    assert sure["duty_cycle"]["a1"] == 0.25
    for a, b, c in zip(own["bearings"], speed["bearings"], sure["bearings"]):
        for name, sel in a["selections"].items():
            for key in ("Pm_N", "L10_Mrev", "L10_h", "L_nm_Mrev"):
                assert sel[key] == b["selections"][name][key], (a["bearing"], name, key)
            if sel["L_nm_Mrev"] is not None:
                assert c["selections"][name]["L_nm_Mrev"] == pytest.approx(
                    0.25 * sel["L_nm_Mrev"], rel=1e-12)


def test_a_window_gives_no_hours_and_says_why(propshaft):
    """Without a duty cycle every life's hours and modified life are null, each with its
    reason beside it."""
    answer = _strict(json_text(propshaft))
    assert answer["duty_cycle"] is None and answer["hours_reason"] == life_duty.NO_HOURS
    for e in answer["bearings"]:
        for lives in (*e["selections"].values(), e["interval"]):
            assert lives["L10_h"] in (None, [None, None])
            assert lives["hours_reason"] == life_duty.NO_HOURS
            assert lives["modified_reason"] == life_duty.NO_SPEED


@pytest.mark.parametrize("text, words", [
    (None, "cannot be read"),
    ("[[duty_cycle]\n", "not valid TOML"),
    ("name = 'x'\n" + TWO_BINS, "holds name"),
    ("", "no [[duty_cycle]] bin"),
    (TWO_BINS.replace("share = 0.75", "share = -0.75"), "duty_cycle[1].share"),
    (TWO_BINS.replace("share = 0.75", "share = 0.5"), "sum to 0.75"),
    (TWO_BINS.replace("speed_rpm = 600.0", "speed = 600.0"), "unknown key"),
])
def test_a_bad_duty_cycle_file_is_one_line(text, words, tmp_path, capsys):
    path = tmp_path / "duty.toml"
    if text is not None:
        path.write_text(text)
    assert main(["life", "propshaft", "--duty-cycle", str(path), "--json"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and words in err and str(path) in err, err


@pytest.mark.parametrize("extra, words", [
    (["--duty-cycle", "x.toml", "--speed-rpm", "600"], "not allowed with argument"),
    (["--speed-rpm", "0"], "expected a speed"),
    (["--speed-rpm", "nan"], "expected a finite number"),
    (["--reliability", "80"], "80 % is outside 90 to"),
    (["--reliability", "99.99"], "Table 12"),
    (["--reliability", "high"], "expected a finite number"),
])
def test_bad_spectrum_options_are_one_line(extra, words, capsys):
    assert main(["life", "propshaft", "--json", *extra]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and words in err, err
