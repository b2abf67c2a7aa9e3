"""The Python API gives what the command line gives: every component's interval, a
released line, a formulation's history over time with each record's instant.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import cardan_forces as cf
from cardan_forces.cli import main

T = [0.25, 0.5, 0.75]


@pytest.fixture(scope="module")
def motion():
    return cf.simulate(cf.load_scene("paper"), T)


def test_intervals_are_what_cardan_sets_prints_and_hold_the_positive_answer(motion, capsys):
    op = cf.build_operator(motion)
    sets = cf.intervals(op, 1)
    assert main(["sets", "paper", "--t", "0.5", "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)["components"]
    assert list(sets) == list(printed) == list(op.names)
    record = cf.solve(cf.build_formulation("positive", op, 1), "clarabel")
    slack = 1e-6 * np.abs(record.x).max()
    for j, (name, entry) in enumerate(sets.items()):
        for end in ("min", "max"):
            assert (entry[end] is None) == (printed[name][end] is None), name
            if entry[end] is not None:
                assert entry[end] == pytest.approx(printed[name][end], rel=1e-6, abs=1e-6)
        lo = -np.inf if entry["min"] is None else entry["min"]
        hi = np.inf if entry["max"] is None else entry["max"]
        assert lo - slack <= record.x[j] <= hi + slack, name  # a member of the set


def test_applying_the_advisors_releases_leaves_only_end_face_pairs(motion):
    advice = cf.advise(motion, 1)
    released = cf.apply_releases(motion, [r.label for r in advice.releases])
    op = cf.build_operator(released)
    kinds = {m.kind for m in cf.named_modes(released, 1, op)}
    assert kinds == {"end-face pair"}
    assert cf.determinacy(op, 1).nullity == 4  # the paper's four trunnion pairs
    assert released.scene.name != motion.scene.name and np.array_equal(released.t, motion.t)
    same = cf.apply_releases(motion, advice.releases)  # Release objects as well as labels
    assert same.scene == released.scene
    with pytest.raises(cf.SceneError):
        cf.apply_releases(motion, ["float:input.nowhere"])


def test_a_history_holds_equilibrium_at_each_record_s_own_instant(motion):
    op = cf.build_operator(motion)
    history = cf.solve_over_time(op, "positive")
    assert isinstance(history, cf.History) and history.forces.shape == (len(T), len(op.names))
    assert [r.t for r in history.records] == pytest.approx(T)
    n = len(op.names)
    for k, record in enumerate(history.records):
        i = int(np.argmin(np.abs(op.t - record.t)))  # the record's own instant ...
        A, b = op.A[i][:, :n], op.b[i]
        # ... is the one whose equilibrium its forces satisfy
        assert np.linalg.norm(A @ history.forces[k] - b) <= 1e-6 * np.linalg.norm(b)
    single = cf.solve(cf.build_formulation("positive", op, 0), "clarabel")
    assert single.t is None  # one solve does not know when it is


def test_interval_history_brackets_the_history(motion):
    op = cf.build_operator(motion)
    sets, history = cf.interval_history(op), cf.solve_over_time(op, "min_norm")
    determinate = sets.determinate
    assert np.allclose(sets.min[determinate], history.forces[determinate], rtol=1e-6,
                       atol=1e-6)
