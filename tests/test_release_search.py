"""The release search at one instant: the operator of a motion cut to one instant is
that instant's, and the advice on a whole motion is the advice on that instant alone
(what ``cardan sets --release`` computes). Every release applies to every built-in
scene or says the validation's reason."""

import numpy as np
import pytest
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import builtin_names, load_scene
from cardan_forces.driveline.release import advise, at_instant, named_modes


@pytest.mark.parametrize("name", ["paper", "propshaft"])
def test_a_motion_cut_to_one_instant_builds_that_instants_operator(name):
    motion = simulate(load_scene(name))
    whole = build_operator(motion)
    for i in (0, len(motion.t) // 3, len(motion.t) - 1):
        one = build_operator(at_instant(motion, i))
        assert one.t == pytest.approx([motion.t[i]])
        assert np.array_equal(one.A[0], whole.A[i]) and np.array_equal(one.b[0], whole.b[i])


def test_advice_on_a_whole_motion_is_the_advice_at_its_instant():
    scene = load_scene("paper")
    motion = simulate(scene, np.linspace(0.0, 0.4, 9))
    whole = advise(motion, 4)
    alone = advise(simulate(scene, [motion.t[4]]), 0)
    assert whole.releases == alone.releases and whole.alternatives == alone.alternatives
    assert whole.released.rank == alone.released.rank
    assert len(whole.operator.t) == len(motion.t)  # the released line over every instant
    assert [m.release for m in named_modes(motion, 4)] == \
        [m.release for m in named_modes(simulate(scene, [motion.t[4]]), 0)]


@pytest.mark.parametrize("name", ["paper", pytest.param("paper-slip", marks=pytest.mark.slow)])
def test_the_sets_the_search_keeps_are_those_that_validate_whole(name):
    """Every release set that passes the search's checks is kept exactly when the
    released scene validates whole (the cheaper check validates each release once)."""
    from itertools import combinations

    from cardan_forces.driveline import release
    scene = load_scene(name)
    one = simulate(scene, [0.3])
    passed = [combo for size in range(4) for combo in combinations(release.candidates(scene),
                                                                      size)
              if release._try(one, combo) is not None]
    assert len(passed) > 5
    for combo in passed:
        assert release._valid_set(scene, combo) == (release._validated(scene, combo)
                                                    is not None), combo


def _every_release(scene):
    """The advisor's candidates and ``float:`` on every bearing (of any kind: a release
    typed on the command line may name one the advisor does not offer)."""
    from cardan_forces.driveline.release import candidates, parse_release

    labels = [r.label for r in candidates(scene)] + [
        f"float:{s.name}.{b.name}" for s in scene.shafts for b in s.bearings]
    return [parse_release(label, scene) for label in dict.fromkeys(labels)]


@pytest.mark.parametrize("name", builtin_names())
def test_every_release_applies_or_says_the_validations_reason(name):
    """Applied alone, each release gives a valid scene (a bearing made floating keeps
    no field of its former kind) or is refused with the validation's own message,
    which on the built-in scenes is a part of the line left unheld."""
    import dataclasses

    from cardan_forces.driveline.release import _variant, released_scene
    from cardan_forces.driveline.scene import Bearing, SceneError

    scene = load_scene(name)
    for release in _every_release(scene):
        try:
            released = released_scene(scene, [release])
        except SceneError as err:
            variant = _variant(scene, [release])
            with pytest.raises(SceneError) as own:
                scene.with_changes(shafts=variant.shafts, elements=variant.elements)
            assert str(err) == f"releases {release.label} do not apply: {own.value}"
            assert "not held" in str(err) or "no axial support" in str(err), str(err)
            continue
        if release.bearing:
            shaft = next(s for s in released.shafts if s.name == release.shaft)
            bearing = next(b for b in shaft.bearings if b.name == release.bearing)
            assert type(bearing) is Bearing and bearing.kind == "floating"
            old = next(b for s in scene.shafts for b in s.bearings
                       if s.name == release.shaft and b.name == release.bearing)
            assert dataclasses.replace(bearing, kind=old.kind) == Bearing(
                old.name, old.offset_m, old.kind, old.rating)


def test_a_float_release_on_an_angular_contact_bearing_applies(capsys):
    from cardan_forces.cli import main

    assert main(["sets", "axle-pinion", "--apply", "float:pinion.tail"]) == 0
    assert "axle-pinion+released" in capsys.readouterr().out
