"""The Python API refuses a wrong argument as the command line does: one of the
package's own exceptions (``ArgumentError``, a ``ValueError``; ``ArgumentTypeError``
also a ``TypeError``; ``UnknownChoice`` also a ``KeyError``), naming the argument and
what it allows, before any work; never an IndexError or AttributeError from inside.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import cardan_forces as cf


@pytest.fixture(scope="module")
def scene():
    return cf.load_scene("paper")


@pytest.fixture(scope="module")
def motion(scene):
    return cf.simulate(scene, [0.5, 0.6])


@pytest.fixture(scope="module")
def op(motion):
    return cf.build_operator(motion)


OUT_OF_RANGE = {
    "intervals": (lambda m, op: cf.intervals(op, 1001), "i = 1001"),
    "determinacy": (lambda m, op: cf.determinacy(op, 5000), "i = 5000"),
    "negative": (lambda m, op: cf.determinacy(op, -1), "i = -1"),
    "build_formulation": (lambda m, op: cf.build_formulation("positive", op, 5000), "i = 5000"),
    "named_modes": (lambda m, op: cf.named_modes(m, 1001), "i = 1001"),
    "advise": (lambda m, op: cf.advise(m, 2), "i = 2"),
    "interval_history": (lambda m, op: cf.interval_history(op, [0, 5000]), "instants[1] = 5000"),
    "solve_over_time": (lambda m, op: cf.solve_over_time(op, "positive", instants=[7]),
                        "instants[0] = 7"),
    "no instants": (lambda m, op: cf.solve_over_time(op, "positive", instants=[]),
                    "at least one instant"),
    "tol": (lambda m, op: cf.solve_over_time(op, "positive", tol=-1e-9), "tol = -1e-09"),
    "budget": (lambda m, op: cf.solve_over_time(op, "positive", budget_s=math.nan),
               "budget_s = nan"),
}
"""Values outside what an argument allows: ArgumentError (a ValueError) naming it."""


@pytest.mark.parametrize("case", OUT_OF_RANGE.values(), ids=OUT_OF_RANGE)
def test_a_value_out_of_range_is_refused_naming_the_argument(case, motion, op):
    call, said = case
    with pytest.raises(cf.ArgumentError) as refused:
        call(motion, op)
    assert isinstance(refused.value, ValueError) and not isinstance(refused.value, IndexError)
    assert said in str(refused.value)
    if said.startswith(("i =", "instants[")):
        assert "0..1" in str(refused.value)  # the allowed range: this motion's two instants


WRONG_TYPE = {
    "float instant": (lambda m, op: cf.intervals(op, 100.0), "i must be an int"),
    "str instant": (lambda m, op: cf.intervals(op, "100"), "i must be an int"),
    "bool instant": (lambda m, op: cf.determinacy(op, True), "i must be an int"),
    "str instants": (lambda m, op: cf.interval_history(op, "01"), "instants must be"),
    "scene name for a motion": (lambda m, op: cf.build_operator("paper"),
                                "cf.simulate(cf.load_scene('paper'))"),
    "motion for an operator": (lambda m, op: cf.determinacy(m, 0), "op must be an Operator"),
    "operator for a motion": (lambda m, op: cf.named_modes(op, 0), "motion must be a Motion"),
    "scene name for a scene": (lambda m, op: cf.simulate("paper"), "scene must be a Scene"),
    "int release": (lambda m, op: cf.apply_releases(m, [42]), "releases[0] must be"),
    "one label": (lambda m, op: cf.apply_releases(m, "slip:intermediate"), "a list of"),
    "solver": (lambda m, op: cf.solve_over_time(op, "positive", 42), "solver must be"),
    "formulation": (lambda m, op: cf.build_formulation(None, op, 0), "formulation must be"),
    "str times": (lambda m, op: cf.simulate(m.scene, ["soon"]), "times must be numbers"),
}
"""Arguments of the wrong type: ArgumentTypeError (a TypeError too) naming them."""


@pytest.mark.parametrize("case", WRONG_TYPE.values(), ids=WRONG_TYPE)
def test_a_value_of_the_wrong_type_is_refused_naming_the_argument(case, motion, op):
    call, said = case
    with pytest.raises(cf.ArgumentTypeError) as refused:
        call(motion, op)
    assert isinstance(refused.value, TypeError) and isinstance(refused.value, cf.ArgumentError)
    assert said in str(refused.value)


@pytest.mark.parametrize("call", [
    lambda op: cf.solve_over_time(op, "nosuch"),
    lambda op: cf.build_formulation("nosuch", op, 0),
])
def test_an_unknown_formulation_lists_the_known_ones(call, op):
    with pytest.raises(cf.UnknownChoice) as refused:
        call(op)
    assert isinstance(refused.value, KeyError)
    text = str(refused.value)
    assert text.startswith("unknown formulation 'nosuch'")  # not quoted as KeyError's
    assert all(name in text for name in cf.FORMULATIONS)


@pytest.mark.parametrize("times", [[math.nan], [0.5, math.inf], [-1.0], []],
                         ids=["nan", "inf", "before the start", "none"])
def test_simulate_refuses_times_it_cannot_integrate_to(scene, times):
    with pytest.raises(cf.ArgumentError, match="times"):
        cf.simulate(scene, times)


def test_a_nan_tolerance_is_refused(scene):
    with pytest.raises(cf.ArgumentError, match="rtol"):
        cf.simulate(scene, [0.5], rtol=math.nan)


def test_an_unknown_release_label_is_the_scene_s_error(motion):
    with pytest.raises(cf.SceneError, match="slip:nosuch"):
        cf.apply_releases(motion, ["slip:nosuch"])


def test_the_range_s_ends_and_numpy_integers_are_accepted(op, motion):
    """The checks refuse no valid call: the first and last instant, as NumPy integers,
    answer as plain ints do (the operator's rows at that instant)."""
    last = cf.determinacy(op, np.int64(len(op.t) - 1))
    assert last.t == op.t[-1] and last.rank == cf.determinacy(op, 1).rank
    assert cf.determinacy(op, np.intp(0)).t == op.t[0]
    history = cf.interval_history(op, np.array([1, 0]))
    assert list(history.t) == [op.t[1], op.t[0]]
    assert len(cf.named_modes(motion, len(motion.t) - 1)) == last.nullity
    released = cf.apply_releases(motion, ("slip:intermediate",))  # a tuple is a list too
    assert cf.determinacy(cf.build_operator(released), 0).nullity < last.nullity


@pytest.mark.parametrize("call", [
    lambda op: cf.solve_over_time(op, "positive", "nosuch"),
    lambda op: cf.intervals(op, 0, solver="nosuch"),
    lambda op: cf.solve(cf.build_formulation("positive", op, 0), "nosuch"),
])
def test_an_unknown_solver_lists_the_installed_ones(call, op):
    with pytest.raises(cf.SolverNotFound) as refused:
        call(op)
    assert isinstance(refused.value, KeyError)
    text = str(refused.value)
    assert text.startswith("unknown backend 'nosuch'") and "clarabel" in text
