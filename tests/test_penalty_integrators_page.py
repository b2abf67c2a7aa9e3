"""The penalty model's page states the stored comparison of its integrators: the table
and the decision between the markers of ``docs/explanation/physical.md`` are what
``docs/penalty_integrators.py`` renders from ``docs/data/penalty_integrators.json``, the
stored run covers every built-in scene (a quasi-static one as its dynamic counterpart,
said so on the page) with the compiled BDF, SciPy's integrators where the run says,
and the decision follows the rule the script states. Timings are not held.
"""

from __future__ import annotations

import copy
import importlib.util
import json
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parent.parent / "docs"


@pytest.fixture(scope="module")
def script():
    spec = importlib.util.spec_from_file_location("penalty_integrators",
                                                  DOCS / "penalty_integrators.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def data(script):
    return json.loads(script.DATA.read_text())


def test_the_page_shows_the_stored_run(script, data):
    """Regenerate with ``python docs/penalty_integrators.py --page``."""
    page = script.PAGE.read_text()
    assert page.count(script.BEGIN) == 1 and page.count(script.END) == 1
    assert script.generated_part(page) == script.markdown(data)


def test_the_run_says_where_and_when(data):
    for key in ("command", "date", "machine", "versions", "cardan_forces", "measure"):
        assert data[key], key
    assert "numba" in data["versions"] and "scipy" in data["versions"]


def test_every_scene_the_penalty_simulation_takes_is_measured(script, data):
    """The scenes it refuses (kinds it has no model for; none today) are the run's
    record, not held: a new built-in scene it refuses changes nothing measured.
    """
    assert [s["scene"] for s in data["scenes"]] == list(script.penalty_scenes())
    assert [s["from"] for s in data["scenes"]] == list(script.penalty_scenes().values())


def test_every_built_in_scene_has_a_compiled_bdf_row(script, data):
    """Quasi-static scenes included, through their dynamic counterparts: each built-in
    scene's released line is a measured scene with the compiled BDF's rows.
    """
    from cardan_forces.driveline.loading import builtin_names

    assert data["refused"] == []
    measured = {s["scene"]: s for s in data["scenes"]}
    for name in builtin_names():
        scene = measured[script.released_line(name).name]
        assert set(script.ALWAYS) <= set(scene["integrators"]), name
        assert scene["quasi_static"] == script.quasi_static(scene["from"])


def test_the_compiled_bdf_finished_every_run(script, data):
    for scene in data["scenes"]:
        row = scene["integrators"][script.COMPILED]
        assert row["failures"] == 0, (scene["scene"], row["messages"])
    assert "The compiled BDF finished all" in script.decision(data)


def test_the_page_says_which_rows_are_a_quasi_static_scenes_counterpart(script, data):
    table = [line for line in script.markdown(data).splitlines() if line.startswith("| ")]
    assert any(s["quasi_static"] for s in data["scenes"])
    assert any(not s["quasi_static"] for s in data["scenes"])
    for scene in data["scenes"]:
        rows = [line for line in table if line.startswith(f"| {scene['scene']} |")]
        assert len(rows) == len(scene["integrators"])
        for line in rows:
            said = "quasi-static" in line and "inertia added" in line
            assert said == scene["quasi_static"], line


def test_scipy_runs_where_the_run_says(script, data):
    assert data["scipy_on"] in script.SCIPY_ON
    assert f"--scipy-on {data['scipy_on']}" in data["command"]
    for scene in data["scenes"]:
        assert scene["scipy"] == script.scipy_runs_on(scene["from"], data["scipy_on"])
    assert script.compared(data), "SciPy's integrators ran on some scene"


def test_each_integrator_is_repeated_and_the_smaller_cpu_time_kept(script, data):
    for scene in data["scenes"]:
        runs = script.RUNS if scene["scipy"] else script.ALWAYS
        assert list(scene["integrators"]) == [r for r in script.RUNS if r in runs]
        for name, row in scene["integrators"].items():
            assert (row["method"], row["atol_m"]) == script.RUNS[name]
            assert row["runs"] >= 2 and len(row["cpu_s"]) == row["runs"]
            assert row["cpu_per_simulated_s"] == pytest.approx(
                min(row["cpu_s"]) / scene["simulated_s"])
            assert 0 <= row["failures"] <= row["runs"]
            if name != script.COMPILED:
                compiled = scene["integrators"][script.COMPILED]["cpu_per_simulated_s"]
                assert row["ratio"] == pytest.approx(row["cpu_per_simulated_s"] / compiled)
                assert set(row["agreement"]) == {"largest_force_N", "sampled", "averaged"}


def _with_ratios(script, data, ratios: dict, failures: dict | None = None) -> dict:
    """``data`` with each SciPy integrator at its ratio to the compiled BDF (and its
    failures) on every scene it ran on, the compiled BDF failing nowhere.
    """
    changed = copy.deepcopy(data)
    for scene in script.compared(changed):
        rows = scene["integrators"]
        rows[script.COMPILED]["failures"] = 0
        for method, ratio in ratios.items():
            rows[method]["ratio"] = ratio
            rows[method]["failures"] = (failures or {}).get(method, 0)
    return changed


def test_the_rule_keeps_the_simpler_within_its_factor(script, data):
    k = script.KEEP_WITHIN
    near = script.decision(_with_ratios(script, data, {"LSODA": 0.9 * k, "BDF": 2 * k,
                                                       "Radau": 3 * k}))
    assert "SciPy's LSODA" in near and "is enough" in near
    far = {"LSODA": 1.1 * k, "BDF": 2 * k, "Radau": 3 * k}
    assert "keep the compiled BDF" in script.decision(_with_ratios(script, data, far))
    failing = {"LSODA": 0.5, "BDF": 5.0, "Radau": 5.0}
    assert "keep the compiled BDF" in script.decision(
        _with_ratios(script, data, failing, {"LSODA": 1}))


def test_the_stored_decision_is_the_rule_applied(script, data):
    table = script.summary(data)
    simpler = [m for m in script.SCIPY if table[m]["high"] <= script.KEEP_WITHIN
               and table[m]["failures"] <= table[m]["compiled_failures"]]
    said = script.decision(data)
    assert ("keep the compiled BDF" in said) == (not simpler)
    page = script.PAGE.read_text()
    prose = page.replace(script.generated_part(page), "")
    verdict = "keeps the compiled BDF" if not simpler else f"SciPy's {simpler[0]}"
    assert verdict in prose, "the page's reasoning states the stored decision"
