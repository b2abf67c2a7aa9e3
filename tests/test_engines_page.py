"""The engines' page states the stored run and what the code computes: its tables and
notes between the ``engine-members`` markers are what ``docs/engine_members.py``
renders from ``docs/data/engine_members.json``; the stored run covers every built-in
scene both engines express and checks what the issue asks (every engine force in the
rigid set, MuJoCo's member predicted within 1 %); the words the derivation states about
``paper`` (the Delassus ratios, the tree's velocities) are the code's.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

DOCS = Path(__file__).resolve().parent.parent / "docs"


@pytest.fixture(scope="module")
def script():
    spec = importlib.util.spec_from_file_location("engine_members",
                                                  DOCS / "engine_members.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def data(script):
    return json.loads(script.DATA.read_text())


def test_the_page_shows_the_stored_run(script, data):
    """Regenerate with ``python docs/engine_members.py --page``."""
    page = script.PAGE.read_text()
    assert page.count(script.BEGIN) == 1 and page.count(script.END) == 1
    assert script.generated_part(page) == script.markdown(data)


def test_the_run_says_where_and_when(data):
    for key in ("command", "date", "machine", "versions", "cardan_forces"):
        assert data[key], key
    assert "MuJoCo" in data["versions"] and "Drake" in data["versions"]


def test_every_scene_both_engines_express_is_run(script, data):
    pytest.importorskip("mujoco")
    pytest.importorskip("pydrake")
    found = script.expressed()
    assert [s["scene"] for s in data["scenes"]] == [n for n, why in found.items() if not why]
    assert all(found[n] for n in data["refused"] if n in found)


def test_the_stored_run_holds_what_the_issue_asks(script, data):
    """Both engines on every scene, no settled force outside its rigid interval,
    MuJoCo's predicted member within 1 % of its simulation everywhere, and Drake's on
    ``paper`` at the finest step (the page says so)."""
    for scene in data["scenes"]:
        assert {r["engine"] for r in scene["runs"]} == {"MuJoCo", "Drake"}
        for r in scene["runs"]:
            assert all(i["outside"] == 0 for i in r["instants"] if i["settled"])
            if r["engine"] == "MuJoCo":
                assert script.matches(r), (scene["scene"], r["setting"])
    paper = next(s for s in data["scenes"] if s["scene"] == script.EVERY_STEP)
    finest = min((r for r in paper["runs"] if r["engine"] == "Drake"),
                 key=lambda r: r["step_s"])
    assert finest["step_s"] == script.FINEST and script.matches(finest)


def test_the_words_about_paper_are_the_code_s():
    """Drake's tree on ``paper``: the input shaft a free root of six velocities, four
    hinges; the output bearings' Delassus estimates about four and eleven and a half times
    the input's; MuJoCo's ``A_hat`` of every bearing equal."""
    pytest.importorskip("mujoco")
    pytest.importorskip("pydrake")
    import pydrake.all as drake
    from cardan_forces.driveline import engine_drake
    from cardan_forces.driveline.engine_mujoco import Softness
    from cardan_forces.experiments.engine_member import compliances_mujoco

    import cardan_forces as cf

    page = (DOCS / "explanation" / "engines.md").read_text()
    scene = cf.load_scene("paper")
    op = cf.build_operator(cf.simulate(scene, scene.time.instants()[:2]))
    plant = drake.MultibodyPlant(0.0)
    drake.Parser(plant).AddModelsFromString(engine_drake.drake_mjcf(op), "xml")
    plant.Finalize()
    dofs = sorted(plant.get_joint(j).num_velocities() for j in plant.GetJointIndices())
    assert dofs.count(6) == 1 and dofs.count(1) == 4
    assert "six velocities" in page and "four hinges" in page
    w, = engine_drake.delassus_estimates(op, [scene.initial_angle_rad])
    ratios = [w[f"bearing.output.{s}"] / w[f"bearing.input.{s}"] for s in ("near", "far")]
    assert (np.round(2 * np.array(ratios)) / 2).tolist() == [4.0, 11.5]
    a_hat = list(compliances_mujoco(op, Softness()).values())
    assert np.ptp(a_hat) <= 1e-12 * max(a_hat) and "every `A_hat` is equal" in page
    assert "about\nfour and eleven and a half times" in page
