"""``cardan secondary``'s figure read back from what it drew: the handbook's values as
markers over the package's curves, the scene and torque in the title, loads that
coincide drawn once and named together, the print rules; and every number drawn is in
``secondary.csv``, the handbook's with their source named as in the legend."""

from __future__ import annotations

import csv

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from cardan_forces.experiments import images, secondary  # noqa: E402


@pytest.fixture(scope="module")
def drawn(tmp_path_factory):
    """``cardan secondary paper-slip --torque 250``: the loads by case, the figure (kept,
    not written) and the rows of ``secondary.csv``."""
    out = tmp_path_factory.mktemp("secondary")
    kept = []
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(secondary, "save",
                      lambda fig, stem, formats=("png",): kept.append(fig) or [])
        results = secondary.revolutions("paper-slip", 250.0, out)
    with open(out / "secondary.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    fig, = kept
    yield results, fig, rows
    plt.close(fig)


def test_the_handbook_values_sit_on_the_package_curves(drawn):
    results, fig, _ = drawn
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
        drawn_names = [n for label in curves for n in label.split(" = ")]
        assert sorted(drawn_names) == sorted(loads)  # every load drawn, once


def _table(rows, source: str) -> dict:
    """{(case, load): {angle deg: N}} of the rows of ``source``."""
    table = {}
    for r in rows:
        if r["source"] == source and r["force_N"]:
            table.setdefault((r["case"], r["bearing_load"]), {})[float(r["angle_deg"])] = \
                float(r["force_N"])
    return table


def _in(table: dict, key, x: float, y: float) -> bool:
    """Whether ``table`` holds (``x``, ``y``) for ``key``, to the CSV's 9 digits."""
    value = table.get(key, {}).get(round(float(x), 6))
    return value is not None and np.isclose(value, y, rtol=1e-8, atol=1e-9)


def test_every_number_drawn_is_in_the_csv(drawn):
    """Each handbook marker (its load in the marker's gid) is a row of the handbook's
    source, named as the legend names it; each point of each curve a row of the
    package's, for every load the curve stands for; and the CSV holds nothing else."""
    results, fig, rows = drawn
    assert tuple(rows[0]) == secondary.CSV_COLUMNS
    assert {r["source"] for r in rows} == {secondary.PACKAGE_SOURCE, secondary.HANDBOOK_LABEL}
    legend = {t.get_text() for ax in fig.axes if ax.get_legend()
              for t in ax.get_legend().get_texts()}
    assert secondary.HANDBOOK_LABEL in legend
    handbook = _table(rows, secondary.HANDBOOK_LABEL)
    package = _table(rows, secondary.PACKAGE_SOURCE)
    marked = 0
    for ax, case in zip(fig.axes, results):
        for line in ax.get_lines():
            points = list(zip(line.get_xdata(), line.get_ydata()))
            if line.get_marker() == "o":
                marked += 1
                missing = [p for p in points if not _in(handbook, (case, line.get_gid()), *p)]
                assert not missing, f"{case} {line.get_gid()}: markers not in the CSV {missing}"
            else:
                for name in line.get_label().split(" = "):
                    missing = [p for p in points if np.isfinite(p[1])
                               and not _in(package, (case, name), *p)]
                    assert not missing, f"{case} {name}: curve points not in the CSV"
    assert marked == 2 * len(results)
    assert sum(len(v) for v in handbook.values()) == 2 * marked  # at 0 and 90 deg, no more
