"""The scene reference's limits are the loader's: a field the loader reads within a
physical range (a ``Range`` of ``driveline/scene.py``) shows that range, the one the
loader refuses beyond; the others their kind's ``LIMITS``. Every built-in scene is on
the page that explains them.
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest
from cardan_forces.driveline.loading import builtin_names, scene_from_dict
from cardan_forces.driveline.scene import (
    CONTACT_ANGLE_DEG,
    MAX_ARTICULATION_DEG,
    SPLINE_PITCH_RADIUS_M,
    Range,
    SceneError,
)

DOCS = Path(__file__).resolve().parents[1] / "docs"


@pytest.fixture(scope="module")
def gen():
    spec = importlib.util.spec_from_file_location("gen_reference", DOCS / "gen_reference.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def rows(gen) -> dict[tuple[str, str], str]:
    """The page's table of every key of a scene file: ``(table, key) -> limit``."""
    found = {}
    for line in gen.scene_markdown().splitlines():
        cells = [c.strip() for c in line.strip("|").split(" | ")]
        if len(cells) == 5 and cells[0].startswith("`") and cells[1].startswith("`"):
            found[(cells[0].strip("`"), cells[1].strip("`"))] = cells[4]
    return found


ARTICULATION = Range(-MAX_ARTICULATION_DEG, MAX_ARTICULATION_DEG, "deg")


@pytest.mark.parametrize("where, key, allowed", [
    ("joints[]", "articulation_deg", ARTICULATION),
    ("tolerances", "articulation_deg", Range(0.0, MAX_ARTICULATION_DEG, "deg")),
    ("shafts[].bearings[]", "contact_angle_deg", CONTACT_ANGLE_DEG),
    ("shafts[].bearings[].rating", "contact_angle_deg", CONTACT_ANGLE_DEG),
    ("slip_joints[]", "pitch_radius_m", SPLINE_PITCH_RADIUS_M),
])
def test_a_field_read_within_a_range_shows_it(rows, where, key, allowed):
    assert rows[(where, key)] == f"{allowed.least:g} to {allowed.most:g} {allowed.unit}"


def test_every_range_shown_is_one_the_loader_reads_with(gen, rows):
    """No limit on the page is a range the loader does not hold: each ``A to B UNIT``
    shown is a :class:`Range` it read a key within, at that key."""
    reads = gen._record_reads()
    for (where, key), limit in rows.items():
        if " to " in limit:
            assert str(reads[(where, key)]["within"]) == limit, (where, key)


@pytest.mark.parametrize("angle, refused", [
    (MAX_ARTICULATION_DEG, False), (-MAX_ARTICULATION_DEG, False),
    (MAX_ARTICULATION_DEG + 0.5, True), (-MAX_ARTICULATION_DEG - 0.5, True)])
def test_the_loader_refuses_a_joint_angle_beyond_the_limit_shown(paper_raw, angle, refused):
    joints = paper_raw["joints"]
    joints[0]["articulation_deg"] = angle
    if refused:
        with pytest.raises(SceneError, match=f"is outside {re.escape(str(ARTICULATION))}"):
            scene_from_dict({"extends": "paper", "joints": joints})
    else:
        scene_from_dict({"extends": "paper", "joints": joints})


def test_every_built_in_scene_is_on_the_page_that_explains_them(gen):
    """Each one of ``cardan scene list`` is named in the rigid model's section on them
    (the determinacy table or its prose), and those left out of the table have
    ``paper``'s rigid structure, as the section says."""
    page = (DOCS / "explanation" / "rigid-model.md").read_text()
    section = page.split("## The built-in scenes", 1)[1].split("\n## ", 1)[0]
    section = section.replace("<!-- generated: determinacy -->", gen.determinacy_markdown())
    for name in builtin_names():
        assert f"`{name}`" in section, name
    others = [n for n in builtin_names() if n not in gen.SCENES]
    rows = gen.determinacy_rows(scenes=("paper", *others))
    assert others and all({**r, "scene": "paper"} == rows[0] for r in rows[1:])
