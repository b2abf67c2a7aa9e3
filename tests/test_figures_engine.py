"""``cardan engine``'s figure read back from what it drew: the rigid set behind the
engine's curves (as ``cardan repro`` draws it), the print rules, the legend off the data,
nothing drawn within the engine's settling, its title's count of settings."""

from __future__ import annotations

from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from cardan_forces.driveline.dynamics import simulate  # noqa: E402
from cardan_forces.driveline.equilibrium import build_operator  # noqa: E402
from cardan_forces.driveline.loading import load_scene  # noqa: E402
from cardan_forces.experiments import engine, images  # noqa: E402
from cardan_forces.experiments.engine_loads import load_of, load_rows  # noqa: E402


@pytest.fixture
def drawn(monkeypatch):
    kept = []
    monkeypatch.setattr(engine, "save", lambda fig, stem, formats=("png",): kept.append(fig)
                        or [])
    yield kept
    for fig in kept:
        plt.close(fig)


def _result(t):
    """An engine study of constructed forces on ``paper``'s operator over ``t``."""
    op = build_operator(simulate(load_scene("paper"), t))
    rng = np.random.default_rng(0)
    runs = {s.label: SimpleNamespace(softness=s, forces=100.0 * rng.standard_normal(
        (len(t), len(op.names)))) for s in engine.SETTINGS}
    return SimpleNamespace(op=op, runs=runs, sampled=np.array([0, 10, 20]))


def test_the_engine_figure_draws_the_rigid_set_behind_its_curves(tmp_path, drawn):
    result = _result(np.linspace(0.0, 0.2, 21))
    op = result.op
    engine.draw(result, tmp_path / "engine")
    fig, = drawn
    assert images.print_problems(fig) == []
    assert op.scene.name in fig.get_suptitle()
    start = engine.settle_s(result.runs)
    shown = result.sampled[op.t[result.sampled] >= start]
    for ax, c in zip(fig.axes, load_rows(op).values()):
        band = engine._band(op, c, shown)
        notes = " ".join(t.get_text() for t in ax.texts)
        assert "rigid set:" in notes  # every panel says what its set is
        low, high = ax.get_ylim()
        finite = band[np.isfinite(band)]
        held = finite[finite >= low]  # a bound far below the loads is marked on the edge
        assert np.all(held <= high) and ("below the axis" in notes or held.size == finite.size)
        if np.isinf(band).all():
            assert "open above and below (any value)" in notes
        assert ax.get_xlabel() == "time t [s]" and ax.get_ylabel() == "force [N]"


def test_the_engine_figure_counts_its_settings_and_draws_after_the_settling(tmp_path, drawn):
    """The title counts the settings drawn and those run (three of nine, not "three"),
    and no curve is drawn within the engine's settling, which the statistics leave out;
    the radial loads are magnitudes, as in ``cardan repro``'s MuJoCo figure."""
    result = _result(np.linspace(0.0, 0.2, 21))
    engine.draw(result, tmp_path / "engine")
    fig, = drawn
    start = engine.settle_s(result.runs)
    title = fig.get_suptitle()
    assert f"{len(engine.FIGURE_SETTINGS)} of its {len(engine.SETTINGS)} softness" in title
    assert f"from {start:g} s" in title
    assert images.drawn_before(fig, start, ("MuJoCo",)) == []
    assert "three" not in title
    titles = [ax.get_title(loc="left") for ax in fig.axes]
    assert sum("magnitude of its radial load" in t for t in titles) == 2
    assert "signed" not in " ".join(titles[:2])


def test_a_radial_load_is_the_length_of_its_two_components():
    result = _result(np.linspace(0.0, 0.02, 3))
    rows = next(iter(load_rows(result.op).values()))
    forces = result.runs["default"].forces
    assert np.allclose(load_of(forces, rows), np.linalg.norm(forces @ rows.T, axis=1))
    band = engine._band(result.op, rows, np.array([1]))
    assert 0.0 <= band[0, 0] <= band[0, 1]


def test_drake_is_drawn_beside_mujoco_in_a_style_of_its_own(tmp_path, drawn):
    """With Drake's runs (forces built by hand), its first step is drawn beside MuJoCo's
    settings, counted in the title, and the figure keeps the rules of print."""
    result = _result(np.linspace(0.0, 0.2, 21))
    rng = np.random.default_rng(1)
    for s in engine.DRAKE_SETTINGS:
        result.runs[s.label] = SimpleNamespace(softness=s, forces=100.0 * rng.standard_normal(
            (len(result.op.t), len(result.op.names))))
    engine.draw(result, tmp_path / "engine")
    fig, = drawn
    assert images.print_problems(fig) == []
    assert f"Drake: 1 of its {len(engine.DRAKE_SETTINGS)} steps" in fig.get_suptitle()
    styles = {line.get_label(): (line.get_linestyle(), line.get_marker())
              for line in fig.axes[0].lines if not line.get_label().startswith("_")}
    drake = styles.pop(engine.DRAKE_SETTINGS[0].label)
    assert drake not in styles.values()
