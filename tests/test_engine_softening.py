"""The softening study: the predicted member as a curve through the simulated points
(MuJoCo's time-constant ratio; Drake's step), the figure read back against the rules of
print, and every number it draws in its CSV."""

import csv

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

pytest.importorskip("mujoco")

from cardan_forces.experiments import engine, engine_softening, images  # noqa: E402

RTOL = 1e-3  # of the largest load: the engines' own residual is ~1e-5


def _on_curve(found):
    """Each simulated value against the prediction at its abscissa (log-interpolated)."""
    load = max(abs(r["value_N"]) for r in found)
    for r in (r for r in found if r["source"] == "simulated"):
        curve = sorted((c["x"], c["value_N"]) for c in found if c["source"] == "predicted"
                       and c["engine"] == r["engine"] and c["load"] == r["load"])
        xs, ys = map(np.array, zip(*curve))
        assert abs(np.interp(np.log(r["x"]), np.log(xs), ys) - r["value_N"]) <= RTOL * load, r


@pytest.fixture(scope="module")
def mujoco_study():
    settings = [s for s in engine.SETTINGS if s.label in engine.FIGURE_SETTINGS]
    return engine.study("paper", stop_s=0.1, instants=3, settings=settings)


def test_mujoco_s_points_lie_on_its_predicted_curve(mujoco_study):
    found = engine_softening.rows(mujoco_study)
    assert {r["x"] for r in found if r["source"] == "simulated"} == {0.25, 1.0, 4.0}
    _on_curve(found)


def test_the_softening_figure_keeps_the_rules_of_print_and_its_csv_holds_it(
        mujoco_study, tmp_path, monkeypatch):
    kept = []
    monkeypatch.setattr(engine_softening, "save",
                        lambda fig, stem, formats=("png",): kept.append(fig) or [])
    paths = engine_softening.write(mujoco_study, tmp_path)
    fig, = kept
    assert images.print_problems(fig) == []
    rows = list(csv.DictReader(paths[0].read_text().splitlines()))
    drawn = sorted(float(y) for ax in fig.axes for line in ax.lines for y in line.get_ydata())
    held = sorted(float(r["value_N"]) for r in rows)
    assert np.allclose(drawn, held, rtol=1e-6, atol=1e-6)
    plt.close(fig)


@pytest.mark.slow
def test_drake_s_points_lie_on_its_flat_prediction():
    pytest.importorskip("pydrake")
    result = engine.study("paper", stop_s=0.1, instants=3, settings=engine.SETTINGS[:1],
                          engines=("mujoco", "drake"))
    found = engine_softening.rows(result)
    assert {r["engine"] for r in found} == {"MuJoCo", "Drake"}
    _on_curve(found)
