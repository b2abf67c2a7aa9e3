"""The softening study: the softened answer leaves the rigid set by O(R) and reaches the
rigid member as R shrinks; its outputs are written whole."""

import csv

import numpy as np
import pytest
from cardan_forces.experiments import images
from cardan_forces.experiments import regularization as reg


@pytest.fixture(scope="module")
def rows():
    return reg.measure(reg.operator("paper", 5), ladder=(1e-2, 1e-4, 1e-6, 0.0))


def _at(rows, formulation):
    return {r["R"]: r for r in rows if r["formulation"] == formulation}


@pytest.mark.parametrize("formulation", reg.SOFTENED)
def test_softened_answer_leaves_the_rigid_set_by_order_R(rows, formulation):
    at = _at(rows, formulation)
    rigid = [at[R]["rigid_median"] for R in (1e-2, 1e-4, 1e-6)]
    assert rigid[0] > rigid[1] > rigid[2]
    assert 1e-3 <= rigid[2] / rigid[1] <= 1e-1  # the penalty's residual is linear in R
    assert at[0.0]["rigid_worst"] <= 1e-10
    assert at[0.0]["solved_share"] == 1.0


def test_softened_compliance_reaches_the_compliance_member(rows):
    at = _at(rows, "compliance")
    away = [at[R]["compliance_median"] for R in (1e-2, 1e-4, 1e-6, 0.0)]
    assert away == sorted(away, reverse=True)
    assert at[0.0]["compliance_worst"] <= 1e-8


def test_writes_table_section_and_figure(rows, tmp_path, monkeypatch):
    drawn = []

    def keep(fig, stem, formats=("png",)):
        drawn.append(fig)
        return images.save(fig, stem, formats)

    monkeypatch.setattr(reg, "save", keep)
    paths = reg.write(rows, tmp_path)
    (fig,) = drawn
    assert images.print_problems(fig) == []  # the rules of print
    assert {p.name for p in paths} == {"regularization.csv", "regularization.md",
                                       "regularization.png"}
    with open(tmp_path / "regularization.csv") as handle:
        table = list(csv.DictReader(handle))
    assert tuple(table[0]) == reg.COLUMNS and len(table) == len(rows)
    text = (tmp_path / "regularization.md").read_text()
    assert text.count("\n| paper |") == len(rows)
    assert (tmp_path / "regularization.png").stat().st_size > 0


def test_mujoco_answer_is_near_the_rigid_set():
    pytest.importorskip("mujoco")
    found = reg.mujoco_row(reg.operator("paper", 5))
    if found is None:
        pytest.skip("MuJoCo cannot express the scene here")
    assert np.isfinite(found["rigid_median"]) and found["rigid_median"] <= 1e-2


def test_the_engines_cost_per_simulated_second_side_by_side():
    """Each engine's row carries its wall time per simulated second, and the section
    sets the engines side by side in a table of their own (rows built by hand)."""
    rows = [{"scene": "paper", "formulation": name, "R": float("nan"), "instants": 5,
             "time_us": 1e5, "iterations": float("nan"), "solved_share": float("nan"),
             "rigid_median": 1e-5, "rigid_worst": 2e-5, "compliance_median": 1e-3,
             "compliance_worst": 2e-3, "wall_s_per_simulated_s": cost}
            for name, cost in (("MuJoCo (default softness)", 0.5),
                               ("Drake (SAP, step 0.25 ms)", 3.0))]
    text = "\n".join(reg.markdown(rows))
    side = text.split("### The engines side by side")[1]
    assert "| MuJoCo (default softness) | paper | 0.5 |" in side
    assert "| Drake (SAP, step 0.25 ms) | paper | 3 |" in side


@pytest.mark.slow
def test_drake_s_row_is_near_the_rigid_set():
    pytest.importorskip("pydrake")
    found = reg.drake_row(reg.operator("paper", 5))
    assert found is not None and np.isfinite(found["wall_s_per_simulated_s"])
    assert found["rigid_median"] <= 5e-2  # first order in its step: ~1e-2 at 13 rad/s
