"""The report of ``cardan life``: :func:`~cardan_forces.experiments.life_study.study`'s
answer written into ``--out`` (:func:`write_outputs`): ``life.csv`` (every ``P`` over
time, by bin, the reason beside an empty cell, :func:`write_csv`), ``life.md`` (the
tables of loads and lives, the sentences on each selection, the lives without a value,
the minimum and light loads, the open set's release, :func:`markdown`) and the figure
``life.<format>`` (each bearing's life interval with each selection's mark, a page per
:data:`ROWS_PER_PAGE` bearings, :func:`figures`).

It reads the answer only (and the study's names of its selections and its
minimum-load rule), computing no load or life, so that the files' words and drawing
change apart from the study, and the study runs without them.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

from cardan_forces.experiments import files, images
from cardan_forces.experiments.environment import number_text
from cardan_forces.experiments.life_runs import ENGINE, PENALTY
from cardan_forces.experiments.life_study import MINIMUM_LOAD, SELECTIONS

MARKS = dict(zip((*SELECTIONS, PENALTY, ENGINE), "os^Dv<>"))
"""Each selection's marker on the figure."""


EMPTY = {
    "rigid": "not solved at this instant",
    "simulated": "left out at this instant (life.md's line of the selection says why)",
    "set": "not solved at this instant (an LP of the set's interval)",
    "open": "open: the set has no finite greatest P at this instant",
}
"""Why a cell of ``life.csv`` is empty, by the series' kind."""

LIGHT_LOAD = 0.05
"""``P / C`` at or below which a bearing's load is light (the bearing makers' classes,
e.g. SKF's: light ``P <= 0.05 C``, normal up to ``0.1 C``, heavy above)."""


def write_csv(answer: dict, path: Path) -> None:
    """Long format: one row per bin of the duty cycle (``window`` without one), instant,
    bearing and series (each selection's ``P``, the set's least and greatest); an empty
    cell where undefined, with why in ``note`` (:data:`EMPTY`).
    """
    with files.replacing(path, newline="") as f:
        w = csv.writer(f)
        w.writerow(["bin", "t_s", "bearing", "series", "P_N", "note"])
        for label, times, entries in _histories(answer):
            for bearing, entry in entries:
                series = {name: sel["P_N"] for name, sel in entry["selections"].items()}
                series.update(set_min=entry["interval"]["P_min_N"],
                              set_max=entry["interval"]["P_max_N"])
                for name, values in series.items():
                    for t, p in zip(times, values):
                        w.writerow([label, f"{t:.6g}", bearing, name,
                                    number_text(p, ".9g", ""), _empty_note(name, p)])


def _histories(answer: dict) -> list[tuple]:
    """``(bin, instants, [(bearing, its entry there)])`` of each load history rated:
    the window's, or each bin's of a duty cycle.
    """
    if answer["duty_cycle"] is None:
        return [("window", answer["t_s"], [(e["bearing"], e) for e in answer["bearings"]])]
    return [(k + 1, b["t_s"], [(e["bearing"], e["bins"][k]) for e in answer["bearings"]])
            for k, b in enumerate(answer["duty_cycle"]["bins"])]


def _empty_note(series: str, p: float) -> str:
    """``life.csv``'s note: why ``p`` of ``series`` is no number, empty where it is one."""
    if math.isfinite(p):
        return ""
    if math.isinf(p):
        return EMPTY["open"]
    kind = ("set" if series.startswith("set_") else
            "simulated" if series in (PENALTY, ENGINE) else "rigid")
    return EMPTY[kind]


def _life_text(value: float) -> str:
    if math.isinf(value):
        return "unloaded"
    return number_text(value, ".4g", "-")


def life_unit(answer: dict) -> tuple[str, str]:
    """The key and the unit lives are shown in: hours over a duty cycle, else millions
    of revolutions (a window gives no hours).
    """
    return ("h", "h") if answer["duty_cycle"] else ("Mrev", "million revolutions")


def _cell(life_entry: dict, key: str) -> str:
    """A selection's life ``key`` in life.md's tables, marked where it lies outside the
    set's interval.
    """
    outside = " (outside the set)" if life_entry["in_set"]["inside"] is False else ""
    return _life_text(life_entry[key]) + outside


def markdown(answer: dict) -> str:
    """``life.md``: what the lives are rated over (a duty cycle's bins, or the window);
    per bearing the loads' ranges, ``C``, ``C_u``, the speeds and ``kappa``; ``L10`` of
    each selection and of the set, and over a duty cycle ``L_nm`` with ``a_ISO`` per
    bin; what each selection is and whether its life lies in the set's interval, why a
    life has no finite value, the minimum-load warnings and the light-load sentence,
    what the interval's ends are, what was not run, and the release where the set is
    open.
    """
    lines = [f"# Bearing life (ISO 281) of scene {answer['scene']}", "",
             *_basis_lines(answer), "", *_load_table(answer), "", *_life_table(answer, "L10")]
    if answer["duty_cycle"]:
        lines += ["", *_life_table(answer, "L_nm")]
    lines += _selection_lines(answer) + _reason_lines(answer) + _minimum_lines(answer)
    lines += _split_lines(answer) + _load_lines(answer)
    lines += ["", f"Radial directions: {answer['directions']} (greatest radial load within "
              f"{100 * answer['direction_error']:.2f} % above the true one)."]
    if answer["unrated"]:
        lines.append(f"- no catalogue data (no life): {', '.join(answer['unrated'])}")
    if answer["open"]:
        release = answer["release"]
        labels = f" ({', '.join(release['labels'])})" if release["labels"] else ""
        lines += ["", f"**{answer['open_reason']}.** The release that bounds it: "
                  f"{release['words']}{labels}."]
    return "\n".join(lines) + "\n"


def _basis_lines(answer: dict) -> list[str]:
    """What the lives are rated over: the duty cycle's bins (a table) or the window."""
    spectrum = answer["duty_cycle"]
    if not spectrum:
        return [f"{answer['instants']} instants over the scene's window; `L10` in million "
                "revolutions of each bearing's shaft; the set's worst and best over every "
                f"rigid solution. {answer['hours_reason'][:1].upper()}"
                f"{answer['hours_reason'][1:]}."]
    return [f"Duty cycle ({spectrum['source']}): {len(spectrum['bins'])} bins, each the "
            "steady state of the quasi-static line at its torque and speed, rated at "
            f"{spectrum['instants_per_bin']} instants over one input revolution; the bins' "
            "lives combined by Palmgren-Miner over their shares of the revolutions; hours "
            f"at the mean speed, {spectrum['mean_speed_rpm']:.4g} r/min at the input; "
            f"`L_nm = a1 a_ISO L10` (ISO 281:2007) for {spectrum['reliability_percent']:g} "
            f"% reliability (a1 = {spectrum['a1']:.3g}), `a_ISO` per bin.", "",
            "| bin | input torque [N m] | input speed [r/min] | share of time | share of "
            "revolutions |", "|---" * 5 + "|",
            *(f"| {k + 1} | {b['torque_N_m']:.4g} | {b['speed_rpm']:.4g} | {b['share']:.4g} "
              f"| {b['revolution_share']:.3g} |" for k, b in enumerate(spectrum["bins"]))]


def _load_table(answer: dict) -> list[str]:
    """Per bearing: type, ``C``, ``C_u``, the radial and axial loads' ranges over the
    set and every selection, and over a duty cycle its speed and ``kappa`` per bin.
    """
    spectrum = bool(answer["duty_cycle"])
    extra = " speed by bin [r/min] | kappa by bin |" if spectrum else ""
    lines = ["| bearing | type | C [N] | C_u [N] | Fr [N] | abs(Fa) [N] |" + extra,
             "|---" * (8 if spectrum else 6) + "|"]
    for e in answer["bearings"]:
        fr, fa = (" to ".join("open" if math.isinf(v) else number_text(v, ".4g")
                              for v in e["load_range"][k]) for k in ("Fr_N", "Fa_N"))
        row = (f"| {e['bearing']} | {e['rating']['type']} | {e['rating']['C_N']:.6g} | "
               f"{number_text(e['rating']['C_u_N'], '.6g')} | {fr} | {fa} |")
        if spectrum:
            row += (f" {_by_bin(e['speed_rpm'], '.4g')} (mean {e['mean_speed_rpm']:.4g}) "
                    f"| {_by_bin(e['kappa'])} |")
        lines.append(row)
    return lines


def _by_bin(values, spec: str = ".3g") -> str:
    """Values by bin, comma-separated (``-`` where one has no value)."""
    return ", ".join(number_text(v, spec) for v in values)


def _life_table(answer: dict, life_name: str) -> list[str]:
    """``L10`` or ``L_nm`` (``life_name``) of each selection and of the set's ends, per
    bearing, in :func:`life_unit`'s unit; ``L_nm`` with ``a_ISO`` by bin.
    """
    names, (unit, _) = list(answer["selections"]), life_unit(answer)
    key = f"{life_name}_{unit}"
    lines = ["| bearing | " + " | ".join(f"{n} {life_name} [{unit}]" for n in names) +
             f" | set worst {life_name} [{unit}] | set best {life_name} [{unit}] |" +
             (" set's ends |" if life_name == "L10" else ""),
             "|---" * (len(names) + (4 if life_name == "L10" else 3)) + "|"]
    for e in answer["bearings"]:
        cells = [_cell(e["selections"][n], key) + _a_iso(e["selections"][n], life_name)
                 for n in names]
        worst, best = e["interval"][key]
        lines.append(f"| {e['bearing']} | " + " | ".join(cells) +
                     f" | {'0 (open)' if e['interval']['open'] else _life_text(worst)} | "
                     f"{_life_text(best)} |" +
                     (f" {e['interval']['ends']} |" if life_name == "L10" else ""))
    return lines


def _a_iso(life_entry: dict, life_name: str) -> str:
    """``a_ISO`` by bin after an ``L_nm`` cell (nothing after an ``L10`` one)."""
    return f" (a_ISO {_by_bin(life_entry['a_ISO'])})" if life_name == "L_nm" else ""


def _selection_lines(answer: dict) -> list[str]:
    """What each selection is and at which bearings its life lies in the set's interval
    (its ``Pm`` between the set's over the same instants, to the answer's tolerance);
    then why each selection not run was not.
    """
    lines = ["", "Each selection, and whether its life lies within the set's interval (its "
             "Pm between the set's least and greatest over the same instants, to "
             f"{answer['in_set_tol']:g} of the bearing's greatest load):"]
    for name, sel in answer["selections"].items():
        about = f"{sel['about']}; " if "about" in sel else ""
        checks = {e["bearing"]: e["selections"][name]["in_set"] for e in answer["bearings"]}
        check = f" {_in_set_words(checks)}." if checks else ""
        lines.append(f"- {name}: {about}{sel['model']}.{check}")
    return lines + [f"- {name}: {why}" for name, why in answer["not_run"].items()]


def _in_set_words(checks: dict) -> str:
    """Where a selection's life lies in the set's interval, where outside (by how much)
    and where it was not compared, in words.
    """
    inside = [b for b, c in checks.items() if c["inside"]]
    parts = [f"outside at {b} (Pm {100 * abs(c['Pm_beyond']):.3g} % "
             f"{'below the least' if c['Pm_beyond'] < 0 else 'above the greatest'})"
             for b, c in checks.items() if c["inside"] is False]
    parts += [f"at {b} {c['why']}" for b, c in checks.items() if c["inside"] is None]
    if len(inside) == len(checks):
        return "Inside at every bearing"
    if inside:
        parts.append(f"inside at {', '.join(inside)}")
    text = "; ".join(parts)
    return text[:1].upper() + text[1:]


def _reason_lines(answer: dict) -> list[str]:
    """Why each life without a finite value has none (an open worst case is said below
    the table with the release that bounds it).
    """
    lines = []
    for e in answer["bearings"]:
        found = [(n, s["reason"]) for n, s in e["selections"].items() if s["reason"]]
        worst, best = e["interval"]["reason"]
        found += [("set worst", worst)] if worst and not e["interval"]["open"] else []
        found += [("set best", best)] if best else []
        lines += [f"- {e['bearing']}, {name}: {why}." for name, why in found]
    if answer["duty_cycle"]:
        lines += _modified_lines(answer["bearings"])
    return ["", "Lives without a finite value:", *lines] if lines else []


def _modified_lines(entries: list[dict]) -> list[str]:
    """Why modified lives have no finite value: each reason once, after the bearings
    that give it.
    """
    found: dict[str, list[str]] = {}
    for e in entries:
        for why in _modified_reasons(e):
            found.setdefault(why, []).append(e["bearing"])
    return [f"- {', '.join(names)}, L_nm: {why}." for why, names in found.items()]


def _modified_reasons(entry: dict) -> list[str]:
    """A bearing's distinct reasons why a modified life has no finite value (the same
    for every selection where its rating lacks ISO 281:2007's inputs).
    """
    found = [s["modified_reason"] for s in entry["selections"].values()]
    found += entry["interval"]["modified_reason"]
    return list(dict.fromkeys(why for why in found if why))


def _minimum_lines(answer: dict) -> list[str]:
    """A warning per bearing whose least ``P`` of any selection is below the requisite
    minimum load (:data:`MINIMUM_LOAD`), naming the bins where it is.
    """
    lines = []
    for e in answer["bearings"]:
        check = e["minimum_load"]
        if not check["below"]:
            continue
        where = f" in bin(s) {', '.join(map(str, check['bins']))}" if "bins" in check else ""
        family = "roller" if check["rule_P_over_C"] == MINIMUM_LOAD["roller"] else "ball"
        lines.append(f"- **{e['bearing']}**{where}: its least P is "
                     f"{100 * check['least_P_over_C']:.2g} % of C, below the requisite "
                     f"minimum load of {100 * check['rule_P_over_C']:g} % of C for {family} "
                     "bearings.")
    if not lines:
        return []
    return ["", "Minimum load not met (SKF, Rolling bearings, PUB BU/P1 17000, 2018, "
            "\"Requisite minimum load\": \"minimum loads of 0,01 C should be imposed on "
            "ball bearings and 0,02 C on roller bearings\"; below it skidding and smearing, "
            "not fatigue, may end a bearing's life, so its ISO 281 life is no guide):",
            *lines]


def _split_lines(answer: dict) -> list[str]:
    """Per bearing that carries axial load beyond ``e`` in some selection: at how many
    instants ``P = X Fr + Y |Fa|`` in each, and the factors where the scene gives them.
    """
    lines = []
    for e in answer["bearings"]:
        counts = {n: s["axial_instants"] for n, s in e["selections"].items()}
        if not any(counts.values()):
            continue
        factors = e["rating"]["X_Y_e"]
        given = ("X, Y, e from ISO 281's tables" if isinstance(factors, str) else
                 "X {:g}, Y {:g}, e {:g} as the scene gives them".format(*factors))
        lines.append(f"- {e['bearing']}: P = X Fr + Y |Fa| (|Fa| > e Fr) at "
                     + ", ".join(f"{k} ({n})" for n, k in counts.items())
                     + f" of {answer['instants']} instants; {given}.")
    return [""] + lines if lines else []


def _load_lines(answer: dict) -> list[str]:
    """The greatest ``P`` of any selection against its bearing's ``C``, and for the
    bearings whose greatest ``P`` is at most :data:`LIGHT_LOAD` of ``C`` (every one, or
    those named), that their lives are long because their loads are light.
    """
    ratios = {e["bearing"]: e["peak_P_over_C"] for e in answer["bearings"]
              if math.isfinite(e["peak_P_over_C"])}
    if not ratios:
        return []
    top = max(ratios, key=ratios.get)
    line = (f"Loads against the ratings: the greatest P of any selection is "
            f"{100 * ratios[top]:.2g} % of C ({top}).")
    light = [name for name, ratio in ratios.items() if ratio <= LIGHT_LOAD]
    if len(light) == len(ratios):
        line += (f" Every bearing is lightly loaded (P <= {LIGHT_LOAD:g} C): ISO 281's "
                 "L10 = (C/P)^p makes these lives long because the scene's loads are "
                 "light, not because of the bearings.")
    elif light:
        line += (f" Lightly loaded (P <= {LIGHT_LOAD:g} C): {', '.join(light)}; ISO 281's "
                 "L10 = (C/P)^p makes their lives long because their loads are light, "
                 "not because of the bearings.")
    return ["", line]


ROW_IN = 0.6
"""The height of one bearing's row on the figure (inches): its bar and each
selection's mark at a height of its own."""

FRAME_IN = 1.25
"""The figure's height besides its rows and its legend (inches): the titles above the
panel and the x axis below it."""

LEGEND_LINE_IN = 0.14
"""The height of one line of the legend beside the panel (inches)."""

MARK_STEP = 0.19
"""How far apart (a row's height is 1) the selections' marks of one row are drawn: at
one life they all show, each at its own height."""

BAR, CAP, OPEN_END = "0.72", "0.3", "0.3"
"""The colours of a rigid set's bar, of its finite ends' caps, and of the arrow of an
open end."""

SET_BAR_LABEL = "rigid set: worst to best\n(a cap at a finite end)"
OPEN_WORST_LABEL = "open: no finite worst case\n(the arrow: L10 down to 0)"
UNLOADED_BEST_LABEL = "unloaded at best: no finite\nbest case (the arrow: L10\nunbounded)"
"""Legend labels of the rigid set's bar and of its open ends (wrapped to the legend's
width)."""


ROWS_PER_PAGE = int((images.PAGE_IN[1] - FRAME_IN) / ROW_IN)
"""How many bearings' rows one page of the figure holds (:data:`images.PAGE_IN`)."""


def _arrow(pointing: str):
    """A marker whose tip is the point it marks, pointing ``left`` or ``right``: drawn at
    the axis' edge, the arrow of an end that runs on beyond the axis (no cap).
    """
    from matplotlib.path import Path as Shape

    sign = 1.0 if pointing == "left" else -1.0
    return Shape([(0.0, 0.0), (sign * 1.6, 1.0), (sign * 1.6, -1.0), (0.0, 0.0)],
                 [Shape.MOVETO, Shape.LINETO, Shape.LINETO, Shape.CLOSEPOLY])


def _legend_in(answer: dict) -> float:
    """The height of the legend beside the panel at most (inches): each selection, the
    set's bar and its two open ends.
    """
    lines = len(answer["selections"]) + sum(
        label.count("\n") + 1 for label in (SET_BAR_LABEL, OPEN_WORST_LABEL,
                                            UNLOADED_BEST_LABEL))
    return lines * LEGEND_LINE_IN + 0.4


def figures(answer: dict) -> list:
    """The figure's pages (:data:`ROWS_PER_PAGE` bearings each, one x range on all):
    each bearing's ``L10`` interval over the rigid set (in :func:`life_unit`'s unit:
    hours over a duty cycle, else millions of revolutions) as a bar with a cap at each
    finite end, an open end as an arrow on the axis' edge pointing to the open side,
    and each selection's ``L10`` as a mark, each selection at a height of its own in
    the row so that marks at one life all show. Make them in :func:`images.styled`.
    """
    entries = answer["bearings"]
    pages = [entries[k:k + ROWS_PER_PAGE]
             for k in range(0, len(entries), ROWS_PER_PAGE)] or [[]]
    key = f"L10_{life_unit(answer)[0]}"
    values = [v for e in entries for v in (*e["interval"][key],
              *(s[key] for s in e["selections"].values())) if 0 < v < math.inf]
    room = 100.0 if any(e["interval"]["open"] for e in entries) else 1.0  # for the arrow
    span = (10.0 ** math.floor(math.log10(min(values, default=1.0) / room)),  # decades
            10.0 ** (math.floor(math.log10(max(values, default=1.0))) + 1))
    return [_page(answer, rows, span, k, len(pages)) for k, rows in enumerate(pages)]


def figure(answer: dict):
    """The figure of one page (a scene whose bearings fit one; :func:`figures`)."""
    return figures(answer)[0]


def _page(answer: dict, entries: list, span: tuple, page: int, pages: int):
    """One page of :func:`figures`: ``entries``' rows over the x range ``span``."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import LogLocator, NullFormatter

    names = list(answer["selections"])
    unit, words = life_unit(answer)
    key = f"L10_{unit}"
    rows = max(len(entries), 1)
    height = max(FRAME_IN + ROW_IN * rows, _legend_in(answer))
    fig, ax = plt.subplots(figsize=(images.PAGE_IN[0], height))
    left, right = span
    for k, e in enumerate(entries):
        _bar(ax, k, e["interval"], key, left, right)
        for c, name in enumerate(names):
            value = e["selections"][name][key]
            if 0 < value < math.inf:
                ax.plot([value], [k + MARK_STEP * (c - (len(names) - 1) / 2)],
                        MARKS.get(name, "x"), color=f"C{c}", ms=4.5, mfc="none", mew=1.0,
                        zorder=3, label=name)
    ax.set_xscale("log")
    ax.set_xlim(left, right)
    ax.xaxis.set_major_locator(LogLocator(numticks=12))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_yticks(range(len(entries)), [e["bearing"] for e in entries])
    ax.tick_params(axis="y", length=0)
    reach = max(0.5, MARK_STEP * (len(names) - 1) / 2 + 0.18)  # the outer marks inside
    ax.set_ylim(rows - 1 + reach, -reach)  # the first bearing on top
    ax.grid(True, axis="x", which="major")
    ax.set_xlabel(f"basic rating life L10 [{words}]")
    ax.set_ylabel("rated bearing [shaft.bearing]")
    ax.set_title(images.typeset("L10 over the rigid set (bar) and of each selection "
                                "(marks, one height each)"), loc="left")
    of = f" ({page + 1} of {pages})" if pages > 1 else ""
    fig.suptitle(images.typeset(f"{answer['scene']}: ISO 281 bearing life{of}"))
    if entries:
        handles = _handles(ax)
        fig.legend(handles.values(), handles.keys(), loc="upper right",
                   bbox_to_anchor=(1.0, 1 - FRAME_IN / 2 / height), labelspacing=0.7)
    else:
        ax.set_axis_off()  # no rows, no lives: the page says so and draws no axes
        ax.set_title("", loc="left")
        ax.text(0.5, 0.5, "no bearing of the scene has catalogue data", ha="center",
                transform=ax.transAxes)
    fig.canvas.draw()
    beside = (fig.legends[0].get_window_extent().width / fig.dpi + 0.05
              if fig.legends else 0.0)
    above = fig._suptitle.get_window_extent().height / fig.dpi
    fig.tight_layout(rect=(0, 0, 1 - beside / images.PAGE_IN[0], 1 - above / height),
                     pad=0.3)
    return fig


def _bar(ax, k: int, interval: dict, key: str, left: float, right: float) -> None:
    """Row ``k``'s ``interval`` over the rigid set (its lives ``key``): a bar from the
    worst life to the best,
    a cap at each finite end (one cap where the interval is a point), an arrow on the
    axis' edge where an end is open (no finite worst case: to the left; unloaded at
    best: to the right). Nothing where an end was not solved.
    """
    worst, best = interval[key]
    if math.isnan(worst) or math.isnan(best):
        return
    open_low = interval["open"] or not worst > 0
    open_high = math.isinf(best)
    lo, hi = left if open_low else worst, right if open_high else max(best, worst)
    caps = [i for i, is_open in ((0, open_low), (1, open_high)) if not is_open]
    ax.plot([lo, hi], [k, k], color=BAR, lw=6, solid_capstyle="butt", zorder=1,
            marker="|", ms=11, mew=1.2, mec=CAP, markevery=caps, label=SET_BAR_LABEL)
    for is_open, x, side, label in ((open_low, left, "left", OPEN_WORST_LABEL),
                                    (open_high, right, "right", UNLOADED_BEST_LABEL)):
        if is_open:
            ax.plot([x], [k], ls="none", marker=_arrow(side), ms=15, color=OPEN_END,
                    zorder=2, clip_on=False, label=label)


def _handles(ax) -> dict:
    """One legend handle per label of ``ax``: the selections in their marks' order in a
    row (top to bottom), then the set's bar and its open ends.
    """
    handles = {}
    for line in ax.lines:
        handles.setdefault(line.get_label(), line)
    ends = (SET_BAR_LABEL, OPEN_WORST_LABEL, UNLOADED_BEST_LABEL)
    return {**{k: v for k, v in handles.items() if k not in ends},
            **{k: handles[k] for k in ends if k in handles}}


def write_outputs(answer: dict, out: Path, formats=("png",)) -> list[Path]:
    """``life.csv``, ``life.md`` and the figure (``life.<format>``; a page each where
    its rows take more than one, :func:`images.save_pages`) into ``out``; their paths.
    """
    return images.write_study(out, "life", lambda path: write_csv(answer, path),
                              markdown(answer), lambda: figures(answer), formats)
