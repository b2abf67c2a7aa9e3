"""``cardan engine``'s figure read back from what it drew: the rigid set behind the
engine's curves (as ``cardan repro`` draws it), the print rules, the legend off the data."""

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


@pytest.fixture
def drawn(monkeypatch):
    kept = []
    monkeypatch.setattr(engine, "save", lambda fig, stem, formats=("png",): kept.append(fig)
                        or [])
    yield kept
    for fig in kept:
        plt.close(fig)


def test_the_engine_figure_draws_the_rigid_set_behind_its_curves(tmp_path, drawn):
    t = np.linspace(0.0, 0.2, 21)
    op = build_operator(simulate(load_scene("paper"), t))
    rng = np.random.default_rng(0)
    runs = {name: SimpleNamespace(forces=100.0 * rng.standard_normal((len(t), len(op.names))))
            for name in engine.FIGURE_SETTINGS}
    result = SimpleNamespace(op=op, runs=runs, sampled=np.array([0, 10, 20]))
    engine.draw(result, tmp_path / "engine")
    fig, = drawn
    assert images.problems(fig) == []
    assert op.scene.name in fig.get_suptitle()
    rows = engine._load_rows(op)
    for ax, c in zip(fig.axes, rows.values()):
        band = engine._band(op, c, result.sampled)
        notes = " ".join(t.get_text() for t in ax.texts)
        assert "rigid set:" in notes  # every panel says what its set is
        low, high = ax.get_ylim()
        finite = band[np.isfinite(band)]
        assert np.all((low <= finite) & (finite <= high))  # every finite end in view
        if np.isinf(band).all():
            assert "open above and below (any value)" in notes
        assert ax.get_xlabel() == "time t [s]" and ax.get_ylabel() == "force [N]"
