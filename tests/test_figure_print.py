"""Every figure the figure commands draw, read back at its printed size against the rules
of print (:mod:`cardan_forces.experiments.images`): a page at most (7 x 9.5 in), no text
under 7 pt, every legend entry with an artist that shows (not covered by others), and no
data drawn inside a start-up interval the figure declares (the penalty simulation's
before :data:`~cardan_forces.paper_repro.verdicts.SETTLED_S`, the engine's before its
settling). On quick runs of a few instants; then the checks themselves, each on a
figure that breaks its rule.
"""

from __future__ import annotations

import re
from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from cardan_forces.driveline.dynamics import simulate  # noqa: E402
from cardan_forces.driveline.equilibrium import build_operator  # noqa: E402
from cardan_forces.driveline.loading import load_scene  # noqa: E402
from cardan_forces.experiments import (  # noqa: E402
    engine,
    images,
    life_report,
    life_study,
    regularization,
    report,
    secondary,
    tolerances,
)
from cardan_forces.paper_repro import repro, verdicts  # noqa: E402
from matplotlib.text import Text  # noqa: E402

PAGE = (7.0, 9.5)
"""The largest figure a page holds (inches)."""
SMALLEST_PT = 7.0


def _kept(monkeypatch_context, *modules) -> list:
    """Figures passed to ``save`` (in :mod:`images` and ``modules``) kept, not written."""
    kept = []

    def keep(fig, stem, formats=("png",)):
        kept.append((stem.name, fig))
        return []

    for module in (images, *modules):
        monkeypatch_context.setattr(module, "save", keep)
    return kept


def _kept_pages(monkeypatch_context) -> list:
    """:func:`_kept` for figures saved by :func:`images.save_pages`: each page kept, not
    written, with the path it would have."""
    kept = []

    def keep(fig, stem, formats=("png",)):
        kept.append((stem.name, fig))
        return [stem.with_suffix(f".{fmt}") for fmt in formats]

    monkeypatch_context.setattr(images, "save", keep)
    return kept


def _check(fig, start_s: float | None = None, labels=()) -> None:
    """The rules of print on ``fig``: each said with the figure's title."""
    name = fig.get_suptitle()
    width, height = fig.get_size_inches()
    assert width <= PAGE[0] and height <= PAGE[1], name
    small = [t.get_text() for t in fig.findobj(Text)
             if t.get_visible() and t.get_text().strip() and t.get_fontsize() < SMALLEST_PT]
    assert small == [], name
    assert images.print_problems(fig) == [], name
    if start_s is not None:
        assert images.drawn_before(fig, start_s, labels) == [], name


@pytest.fixture(scope="module")
def repro_figures(tmp_path_factory):
    """``cardan repro --quick``'s figures (Figs. 11-15 and MuJoCo's where installed),
    with the penalty simulation, by file stem."""
    with pytest.MonkeyPatch.context() as patch:
        kept = _kept(patch)
        repro.run_repro(out=tmp_path_factory.mktemp("repro"), quick=True, workers=0,
                        progress=lambda _: None)
    yield dict(kept)
    for _, fig in kept:
        plt.close(fig)


@pytest.mark.slow
def test_repro_s_figures_fit_a_page_and_keep_the_rules_of_print(repro_figures):
    assert {"fig11", "fig12", "fig13", "fig14"} <= set(repro_figures)
    assert any(stem.startswith("fig15_") for stem in repro_figures)
    start = verdicts.SETTLED_S  # the quick run starts at t = 0
    for stem, fig in repro_figures.items():
        if stem == "engine":
            continue
        _check(fig, start, ("penalty",))
        assert any(line.get_label().startswith("penalty") for ax in fig.axes
                   for line in ax.lines), f"{stem}: the penalty is drawn after its start-up"


def test_repro_s_mujoco_figure_is_drawn_after_the_engine_s_settling(repro_figures):
    pytest.importorskip("mujoco")
    fig = repro_figures["engine"]
    start = engine.settle_s({s.label: SimpleNamespace(softness=s)
                             for s in engine.SETTINGS if s.label in engine.FIGURE_SETTINGS})
    _check(fig, start, ("MuJoCo",))


def test_titles_write_powers_of_units_as_superscripts(repro_figures):
    titles = [fig.get_suptitle() for stem, fig in repro_figures.items()
              if stem.startswith("fig15_")]
    assert titles and all("m/s\u00b2" in t and "^2" not in t for t in titles)


@pytest.fixture(scope="module")
def paper_report():
    """``cardan report paper`` over its first 0.1 s at three instants: the operator and
    the histories."""
    op = build_operator(simulate(load_scene("paper"), np.linspace(0.0, 0.1, 3)))
    return op, report.histories(op)


@pytest.mark.slow  # every page; the default run holds the first page to the rules of print
# (test_report_pages_with_the_engine_draw_nothing_in_its_settling)
def test_report_pages_keep_the_rules_of_print(paper_report):
    op, h = paper_report
    with images.styled():
        figs = report.pages(op, h)
    assert len(figs) > 1  # paginated, not one canvas
    for fig in figs:
        _check(fig)
        plt.close(fig)


@pytest.mark.slow
def test_report_pages_with_the_engine_draw_nothing_in_its_settling(paper_report):
    """MuJoCo's open circles on every panel, none within the engine's settling; the
    rules of print on the first page (the overlay is alike on every page)."""
    pytest.importorskip("mujoco")
    op, h = paper_report
    overlay = report.engine_overlay(op, h, "test")
    with images.styled():
        figs = report.pages(op, h, overlay)
    _check(figs[0])
    settling = op.t < op.t[0] + overlay.settle_s
    assert settling.any()
    for fig in figs:
        circles = [line for ax in fig.axes for line in ax.lines if line.get_marker() == "o"]
        assert circles and not any(np.isfinite(np.asarray(line.get_ydata(), float)[
            settling]).any() for line in circles)
        plt.close(fig)


@pytest.mark.slow
def test_cardan_engine_s_figure_keeps_the_rules_of_print(tmp_path):
    pytest.importorskip("mujoco")
    result = engine.study("paper", stop_s=0.15, instants=3)
    with pytest.MonkeyPatch.context() as patch:
        kept = _kept(patch, engine)
        engine.draw(result, tmp_path / "engine")
    (_, fig), = kept
    _check(fig, engine.settle_s(result.runs), ("MuJoCo",))
    plt.close(fig)


def test_cardan_secondary_s_figure_keeps_the_rules_of_print(tmp_path):
    with pytest.MonkeyPatch.context() as patch:
        kept = _kept(patch, secondary)
        secondary.revolutions("paper-slip", 100.0, tmp_path)
    (_, fig), = kept
    _check(fig)
    plt.close(fig)


@pytest.fixture(scope="module")
def life_answers():
    """``cardan life``'s answers at five instants: paper and axle-pinion (open worst
    cases, the selections' lives alike on paper), propshaft (every interval a point)."""
    return {name: life_study.study(name, 5) for name in ("paper", "propshaft", "axle-pinion")}


def _open_arrows(fig, label: str, side: str) -> list:
    """The lines labelled ``label`` drawn as an arrow on the panel's ``side`` edge
    (``left``, ``right``, ``bottom``) pointing out of the panel: a marker whose tip is
    its point and whose body lies inside."""
    found = []
    for ax in fig.axes:
        edge = {"left": ax.get_xlim()[0], "right": ax.get_xlim()[1],
                "bottom": ax.get_ylim()[0]}[side]
        for line in ax.lines:
            if line.get_label() != label:
                continue
            marker = line.get_marker()
            assert hasattr(marker, "vertices"), f"{label!r} is not drawn as an arrow"
            body = np.asarray(marker.vertices, float)[1:]  # the tip first, at (0, 0)
            axis, sign = {"left": (0, 1), "right": (0, -1), "bottom": (1, 1)}[side]
            assert np.allclose(marker.vertices[0], 0) and np.all(sign * body[:, axis] >= 0)
            at = line.get_xdata() if axis == 0 else line.get_ydata()
            assert np.allclose(np.asarray(at, float), edge), f"{label!r} off the {side} edge"
            found.append(line)
    return found


@pytest.mark.slow
def test_cardan_life_s_figures_keep_the_rules_of_print(life_answers, tmp_path):
    """Every selection's mark shows (on paper they lie at one life), at a height of
    its own in the bearing's row; the y axis names the bearings, not a unit."""
    for name, answer in life_answers.items():
        with pytest.MonkeyPatch.context() as patch:
            kept = _kept_pages(patch)
            life_report.write_outputs(answer, tmp_path / name)
        (stem, fig), = kept
        assert stem == "life"
        _check(fig)
        legend = {t.get_text() for lg in fig.legends for t in lg.get_texts()}
        assert set(answer["selections"]) <= legend, name
        ax = fig.axes[0]
        assert ax.get_ylabel() != "bearing [-]"
        heights = {line.get_label(): float(line.get_ydata()[0]) % 1 for line in ax.lines
                   if line.get_label() in answer["selections"]}
        assert len(set(np.round(list(heights.values()), 6))) == len(heights), name
        plt.close(fig)


def test_cardan_life_draws_an_open_worst_case_as_an_arrow(life_answers):
    """paper's worst cases are open: each row's bar runs to the axis' left edge and
    ends there in an arrow pointing left, without a cap; its best end has one."""
    answer = life_answers["paper"]
    assert all(e["interval"]["open"] for e in answer["bearings"])
    with images.styled():
        fig = life_report.figure(answer)
    arrows = _open_arrows(fig, life_report.OPEN_WORST_LABEL, "left")
    assert len(arrows) == len(answer["bearings"])
    left = fig.axes[0].get_xlim()[0]
    bars = [line for line in fig.axes[0].lines if line.get_label() == life_report.SET_BAR_LABEL]
    assert len(bars) == len(answer["bearings"])
    for bar in bars:
        x = np.asarray(bar.get_xdata(), float)
        assert x[0] == left and list(bar.get_markevery()) == [1]  # a cap at the best only
    assert images.print_problems(fig) == []
    plt.close(fig)
    closed = life_answers["propshaft"]
    with images.styled():
        fig = life_report.figure(closed)
    assert _open_arrows(fig, life_report.OPEN_WORST_LABEL, "left") == []
    plt.close(fig)


@pytest.mark.slow
def test_cardan_life_s_figure_of_many_bearings_takes_pages(life_answers, tmp_path):
    answer = dict(life_answers["paper"])
    answer["bearings"] = [dict(e, bearing=f"{e['bearing']}{k}")
                          for k in range(8) for e in answer["bearings"]]
    with images.styled():
        figs = life_report.figures(answer)
    assert len(figs) == -(-len(answer["bearings"]) // life_report.ROWS_PER_PAGE) > 1
    for fig in figs:
        _check(fig)
    paths = images.save_pages(figs, tmp_path / "life", ("png",))
    assert [p.name for p in paths] == [f"life-{k}.png" for k in range(1, len(figs) + 1)]
    for fig in figs:
        plt.close(fig)


@pytest.fixture(scope="module")
def tolerance_answer(tmp_path_factory):
    """``cardan tolerances propshaft``'s answer over three samples at three instants."""
    answer, lost = tolerances.run_study("propshaft", 3, 0, 3,
                                        tmp_path_factory.mktemp("tolerances"))
    assert not lost
    return answer


def test_cardan_tolerances_figure_keeps_the_rules_of_print(tolerance_answer, tmp_path):
    """The compliance median shows where the other lines lie on it (interleaved
    dashes), and the panels say which lie on one another."""
    with pytest.MonkeyPatch.context() as patch:
        kept = _kept_pages(patch)
        tolerances.write_outputs(tolerance_answer, tmp_path)
    (stem, fig), = kept
    assert stem == "tolerances"
    _check(fig)
    assert "compliance: median" in {t.get_text() for lg in fig.legends
                                    for t in lg.get_texts()}
    notes = [t.get_text() for ax in fig.axes for t in ax.texts]
    assert any("on one another: compliance median = " in n for n in notes)
    assert all(ax.get_position().width * fig.get_figwidth() <= images.COLUMN_IN
               for ax in fig.axes if ax.get_visible())
    plt.close(fig)


@pytest.mark.slow
def test_cardan_tolerances_figure_of_many_loads_takes_pages(tolerance_answer):
    answer = {**tolerance_answer, "loads": {
        form: {f"{name}{k}": entry for k in range(3) for name, entry in loads.items()
               if name.startswith("P:")} for form, loads in tolerance_answer["loads"].items()}}
    per_page = tolerances.COLUMNS * tolerances.ROWS_PER_PAGE
    with images.styled():
        figs = tolerances.figures(answer)
    assert len(figs) == -(-len(answer["loads"]["compliance"]) // per_page) > 1
    for fig in figs:
        _check(fig)
        plt.close(fig)


def _softened_rows() -> list[dict]:
    """Rows of the regularization study as :func:`regularization.measure` gives them,
    made up: two scenes and formulations, their distances shrinking with ``R``, one
    rigid answer exactly on the compliance member, and MuJoCo's point."""
    rows = []
    for s, scene in enumerate(("paper", "propshaft")):
        for f, form in enumerate(("positive", "compliance")):
            for k, R in enumerate(regularization.LADDER):
                rows.append({"scene": scene, "formulation": form, "R": R,
                             "time_us": 100.0 * (1 + s) + 10 * f + k,
                             "rigid_median": R if R else 1e-14,
                             "compliance_median": (R if R else 0.0) if form == "compliance"
                             else max(R, 1e-6)})
    rows.append({"scene": "paper", "formulation": "MuJoCo (default softness)",
                 "R": float("nan"), "time_us": 3e4, "rigid_median": 2e-5,
                 "compliance_median": 3e-5})
    return rows


def test_the_regularization_figure_keeps_the_rules_of_print(tmp_path):
    """On a page of two columns; a distance of exactly 0 (the rigid compliance answer
    on the compliance member) is an arrow on the panel's lower edge, not a floor."""
    with pytest.MonkeyPatch.context() as patch:
        kept = _kept(patch, regularization)
        regularization.draw(_softened_rows(), tmp_path / "regularization")
    (_, fig), = kept
    _check(fig)
    arrows = _open_arrows(fig, regularization.ZERO_LABEL, "bottom")
    assert len(arrows) == 1 and arrows[0].axes is fig.axes[1]
    assert len(arrows[0].get_xdata()) == 2  # paper's and propshaft's compliance
    assert not any(np.nanmin(np.asarray(line.get_ydata(), float)) < fig.axes[1].get_ylim()[0]
                   for line in fig.axes[1].lines if line not in arrows)
    plt.close(fig)


def test_the_print_style_is_for_a_page():
    assert images.PAGE_IN[0] <= PAGE[0] and images.PAGE_IN[1] <= PAGE[1]
    assert images.MIN_TEXT_PT >= SMALLEST_PT
    sizes = {k: v for k, v in images.STYLE.items()  # the type sizes
             if k.endswith(("font.size", "titlesize", "labelsize", "fontsize"))}
    assert sizes and min(sizes.values()) >= images.MIN_TEXT_PT


# The checks themselves, each on a figure that breaks its rule.

def _figure(size=(6.0, 4.0)):
    fig, ax = plt.subplots(figsize=size)
    fig.suptitle("a figure")
    ax.set_title("(a) a panel", loc="left")
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("force [N]")
    return fig, ax


def test_a_figure_larger_than_a_page_is_found():
    fig, ax = _figure((8.0, 10.0))
    ax.plot([0, 1], [0, 1])
    assert any("larger than a page" in p for p in images.print_problems(fig))
    plt.close(fig)


def test_text_under_7_pt_is_found():
    fig, ax = _figure()
    ax.plot([0, 1], [0, 1])
    ax.annotate("tiny", (0.5, 0.5), fontsize=6)
    assert any("'tiny' at 6 pt" in p for p in images.print_problems(fig))
    plt.close(fig)


def test_text_running_off_the_figure_is_found():
    fig, ax = _figure()
    ax.plot([0, 1], [0, 1])
    ax.annotate("a note far too long for its panel " * 4, (0, 1), xycoords="axes fraction")
    assert any("runs off the figure" in p for p in images.print_problems(fig))
    plt.close(fig)


def test_a_legend_entry_covered_by_another_line_is_found():
    """Two equal lines of one width and style: the first does not show. Drawn in
    interleaved dashes (:func:`images.interleave`), both show."""
    t = np.linspace(0, 1, 50)
    fig, ax = _figure()
    ax.plot(t, t, color="C0", label="a")
    ax.plot(t, t, color="C1", label="b")
    fig.legend(loc="lower center")
    fig.subplots_adjust(bottom=0.3)
    assert images.covered(fig) == ["a"]
    assert any("'a' is covered" in p for p in images.print_problems(fig))
    plt.close(fig)
    fig, ax = _figure()
    for k, colour in enumerate(("C0", "C1", "C2")):
        ax.plot(t, t, color=colour, ls=images.interleave(k, 3), label="abc"[k])
    fig.legend(loc="lower center", ncol=3)
    fig.subplots_adjust(bottom=0.3)
    assert images.covered(fig) == []
    plt.close(fig)


def test_data_inside_a_start_up_interval_is_found():
    t = np.linspace(0, 1, 11)
    fig, ax = _figure()
    ax.plot(t, t, label="penalty (raw)")
    ax.plot(t, np.where(t >= 0.1, t, np.nan), label="penalty, filtered")
    found = images.drawn_before(fig, 0.1, ("penalty",))
    assert found == ["'penalty (raw)' drawn at x = 0 < 0.1"]
    plt.close(fig)


def test_a_figure_of_several_pages_is_one_pdf_and_a_png_per_page(tmp_path):
    figs = [_figure()[0] for _ in range(3)]
    (tmp_path / "report.png").write_bytes(b"an earlier single page")
    (tmp_path / "report-4.png").write_bytes(b"an earlier fourth page")
    paths = images.save_pages(figs, tmp_path / "report", ("png", "pdf"))
    assert [p.name for p in paths] == ["report-1.png", "report-2.png", "report-3.png",
                                       "report.pdf"]
    assert sorted(p.name for p in tmp_path.glob("report*.png")) == [
        "report-1.png", "report-2.png", "report-3.png"]  # no page of an earlier drawing
    pdf = (tmp_path / "report.pdf").read_bytes()
    assert len(re.findall(rb"/Type /Page\b", pdf)) == 3
    one = images.save_pages(figs[:1], tmp_path / "one", ("png",))
    assert [p.name for p in one] == ["one.png"]
    for fig in figs:
        plt.close(fig)


def test_units_are_typeset():
    assert images.typeset("gravity (0, 9.81, 0) m/s^2") == "gravity (0, 9.81, 0) m/s\u00b2"


def test_a_curve_on_a_bound_of_the_set_is_named():
    """A selection on the set's lower bound hides the bound's line: found where the
    bound is known (NaN elsewhere) and said with how close; a curve that leaves it is
    not."""
    bound = np.array([0.0, np.nan, 0.0, np.nan, 0.0])
    curves = {"positive": np.array([0.001, 5.0, 0.0, 7.0, 0.002]),
              "paper": np.array([0.0, 1.0, 3.0, 1.0, 0.0])}
    found = images.on_bound(curves, bound, tol=0.01)
    assert found == {"positive": 0.002}
    assert images.bound_note(found, "lower", "N") == (
        "positive on the rigid set's lower bound within 0.002 N")


@pytest.mark.slow
def test_cardan_bench_s_figures_keep_the_rules_of_print(tmp_path, capsys):
    """``cardan bench --quick`` on two formulations and four backends: the Pareto and
    the profiles figures, every page in the print style and the rules of print."""
    from cardan_forces.cli import main

    with pytest.MonkeyPatch.context() as patch:
        kept = _kept_pages(patch)
        assert main(["bench", "--quick", "--quiet", "--formulation", "min_norm",
                     "--formulation", "positive", "--solver", "numpy-kkt", "--solver",
                     "qpsolvers-daqp", "--solver", "newton", "--solver", "numpy-batched",
                     "--out", str(tmp_path)]) == 0
    capsys.readouterr()
    assert {stem.split("-")[0] for stem, _ in kept} == {"bench_pareto", "bench_profiles"}
    for _, fig in kept:
        _check(fig)
        assert max(t.get_fontsize() for t in fig.findobj(Text)
                   if t.get_text().strip()) <= images.TITLE_PT  # no type of its own
        plt.close(fig)


@pytest.mark.slow
def test_cardan_bench_s_figures_of_many_panels_take_pages(tmp_path):
    """Nine formulations by two profiles, eighteen panels: two columns on pages of
    :data:`images.PAGE_IN`, each a figure of its own (``bench_profiles-1``, ...) in the
    rules of print, curves at 1 all showing."""
    from cardan_forces.experiments import bench_report
    from cardan_forces.experiments.bench_metrics import TAUS

    solvers = ("clarabel", "moreau", "newton", "numpy-kkt", "qpsolvers-daqp")
    profiles = [{"formulation": f"form-{f}", "profile": level, "clock": "solver",
                 "level": 1e-8, "solver": s,
                 "curve": list(np.where(TAUS >= 1 + k % 3, 1.0, 0.0))}
                for f in range(9) for level in ("default", "high")
                for k, s in enumerate(solvers)]
    with pytest.MonkeyPatch.context() as patch:
        kept = _kept_pages(patch)
        bench_report.plot_profiles(profiles, tmp_path / "bench_profiles.png")
    assert len(kept) > 1
    assert [stem for stem, _ in kept] == [f"bench_profiles-{k}" for k in
                                          range(1, len(kept) + 1)]
    assert sum(ax.get_visible() for _, fig in kept for ax in fig.axes) == 18
    for _, fig in kept:
        assert fig.get_size_inches()[0] == pytest.approx(images.PAGE_IN[0])
        _check(fig)
        plt.close(fig)
