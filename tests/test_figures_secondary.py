"""``cardan secondary``'s figure read back from what it drew: the handbook's values as
markers over the package's curves, the scene and torque in the title, loads that
coincide drawn once and named together, the print rules."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from cardan_forces.experiments import images, secondary  # noqa: E402


def test_the_handbook_values_sit_on_the_package_curves(tmp_path, monkeypatch):
    kept = []
    monkeypatch.setattr(secondary, "save", lambda fig, stem, formats=("png",): kept.append(fig)
                        or [])
    results = secondary.revolutions("paper-slip", 250.0, tmp_path)
    fig, = kept
    assert images.print_problems(fig) == []
    assert "paper-slip" in fig.get_suptitle() and "250 N m" in fig.get_suptitle()
    for ax, loads in zip(fig.axes, results.values()):
        curves = {line.get_label(): line for line in ax.get_lines()
                  if line.get_linestyle() != "None"}
        marks = [line for line in ax.get_lines() if line.get_marker() == "o"]
        assert len(marks) == 2  # the two bearings of the first shaft
        for line in marks:
            for x, y in zip(line.get_xdata(), line.get_ydata()):
                near = [n for n, v in loads.items() if np.isclose(v[int(x) // 5], y, atol=1e-6)
                        and n.endswith(".normal") and n.startswith("input.")]
                assert near, f"a handbook value {y:.3f} N at {x} deg lies on a curve"
        for label, line in curves.items():  # one line per group of equal loads
            names = label.split(" = ")
            for name in names:
                assert np.allclose(loads[name], line.get_ydata(), atol=1e-6)
        drawn = [n for label in curves for n in label.split(" = ")]
        assert sorted(drawn) == sorted(loads)  # every load drawn, once
    plt.close(fig)
