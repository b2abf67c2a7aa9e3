"""``cardan tolerances``: the loads a redundant line's manufacturing tolerances put into
it, as a Monte Carlo over the scene's stated tolerances (:class:`~cardan_forces.
driveline.scene.Tolerances`).

Each sample draws, uniformly within the scene's half-widths, every bearing seat's radial
offset ``delta`` (two components in its shaft's frame ``r1``, ``r2``, m), every joint's
articulation and, where the scene calls for ``clearance``, every bearing's clearance,
then solves :data:`RUN` (``compliance`` and ``compliance_hertz``) at ``--instants``
instants of the scene's window. A seat offset is a misfit: it enters each problem's
complementary energy as the work ``-delta . F`` of the bearing's force ``F`` through the
imposed displacement (Menabrea with prescribed support movements), a signed term beside
the clearance's ``gap ||F||``. The equations ``A x = b`` are unchanged by a misfit, so
it moves only the indeterminate loads; an articulation changes the geometry (the
sample's operator is built again), so it moves the determinate loads too.

Answer: each load's (every contact's force magnitude and every rated bearing's ISO 281
``P``) 5th, 50th and 95th percentiles over the samples at each instant, per formulation;
each rated bearing's ``L10`` distribution (:mod:`cardan_forces.experiments.life_study`); how
many sampled force components fell outside the nominal line's rigid interval (none can
without an articulation tolerance). Samples are seeded one by one
(``default_rng([seed, index])``), so any subset gives the same draws in any order.

Runs in this process with a progress bar, or on a Dask cluster (``--scheduler``, the
sweep's connection and executor, :mod:`.sweep_exec`: a cluster left without workers
ends the run after ``--timeout`` s, keeping the samples stored). Every finished sample
is appended to ``samples.jsonl`` in ``--out`` in one flushed line
(:mod:`.tolerance_store`): a rerun computes only the samples the file lacks, and a
sample in it twice is read once. The store's study holds the SHA-256 of the scene's
content: an edited scene is another study, refused in the same ``--out``.
"""

from __future__ import annotations

import csv
import dataclasses
import functools
import math
import sys
import textwrap
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from cardan_forces.driveline import bearing_life as iso
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import Operator, build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.driveline.scene import MAX_ARTICULATION_DEG, Scene, SceneError
from cardan_forces.experiments import files, images
from cardan_forces.experiments import progress as bars
from cardan_forces.experiments import tolerance_store as store
from cardan_forces.experiments.arguments import UsageError, whole_number
from cardan_forces.experiments.environment import json_text, number_text
from cardan_forces.experiments.images import format_list
from cardan_forces.experiments.life_study import loads as bearing_loads
from cardan_forces.experiments.life_study import rated
from cardan_forces.experiments.study import interval_history, solve_over_time
from cardan_forces.experiments.sweep_exec import NO_WORKERS_S, close, connect, dask
from cardan_forces.experiments.sweep_point import scene_digest
from cardan_forces.formulations import FORMULATIONS, where
from cardan_forces.formulations.convex import contact_laws
from cardan_forces.formulations.problems import QP, Conic
from threadpoolctl import threadpool_limits

RUN = where(compliant=True)
"""The formulations each sample solves: those whose contacts have a stiffness (the
records' ``compliant``), on which a misfit does work."""

INSTANTS = 11
"""Instants per sample by default."""

MAX_SAMPLES = 100_000
"""Most samples a study takes."""

MAX_SOLVES = 500_000
"""Most problems a study solves (samples x instants x formulations), checked before any
work: a study of this size keeps a few cores busy for hours."""

QUANTILES = (5.0, 50.0, 95.0)
"""Percentiles of each load's distribution."""

INSIDE_RTOL = 1e-5
"""A sampled component counts as outside its rigid interval when it passes an end by
more than this times the instant's largest force (the solvers' acceptance is 1e-6)."""


@dataclass(frozen=True)
class Task:
    """One sample of a study: the scene (a built-in name or a path) and the SHA-256 of
    its content (:func:`~.sweep_point.scene_digest`), the study's seed, the sample's
    index and the instants.
    """

    scene: str
    digest: str
    seed: int
    index: int
    instants: int


def scene_bearings(scene: Scene) -> list[str]:
    """Every bearing as ``<shaft>.<bearing>``, in the scene's order (the draws' order)."""
    return [f"{s.name}.{b.name}" for s in scene.shafts for b in s.bearings]


def draws(scene: Scene, seed: int, index: int) -> dict[str, np.ndarray]:
    """Sample ``index``'s deviations: ``seat`` (bearings, 2; m), ``articulation``
    (joints; deg) and ``clearance`` (bearings; m, at least 0), uniform within the
    scene's half-widths (zero without a ``[tolerances]`` table).
    """
    tol = scene.tolerances
    rng = np.random.default_rng([seed, index])
    nb, nj = len(scene_bearings(scene)), len(scene.joints)
    seat = rng.uniform(-1.0, 1.0, (nb, 2)) * (tol.bearing_seat_m if tol else 0.0)
    articulation = rng.uniform(-1.0, 1.0, nj) * (tol.articulation_deg if tol else 0.0)
    spread = rng.uniform(-1.0, 1.0, nb) * (tol.bearing_clearance_m if tol else 0.0)
    clearance = np.maximum(scene.contact.bearing_clearance_m + spread, 0.0)
    return {"seat": seat, "articulation": articulation, "clearance": clearance}


def check_size(scene: Scene, samples: int, instants: int) -> None:
    """A study's size and its tolerances within bounds, before any work (ValueError)."""
    if not 1 <= samples <= MAX_SAMPLES:
        raise ValueError(f"--samples {samples}: must be in [1, {MAX_SAMPLES}]")
    solves = samples * instants * len(RUN)
    if solves > MAX_SOLVES:
        raise ValueError(f"{samples} samples x {instants} instants x {len(RUN)} formulations "
                         f"= {solves} solves; at most {MAX_SOLVES}")
    tol = scene.tolerances
    reach = max((abs(j.articulation_deg) for j in scene.joints), default=0.0) + \
        (tol.articulation_deg if tol else 0.0)
    if reach > MAX_ARTICULATION_DEG:
        raise ValueError(f"scene {scene.name}: a joint's articulation plus its tolerance "
                         f"reaches {reach:g} deg; at most {MAX_ARTICULATION_DEG:g}")


# ---------------------------------------------------------------------------- one sample


@functools.lru_cache(maxsize=4)
def nominal(scene_spec: str, digest: str, instants: int
            ) -> tuple[Scene, Operator, dict, object]:
    """The scene, its operator at ``instants`` instants over its window, each
    formulation's problems and the rigid intervals, once per process and scene content
    (``digest``: a scene file edited since is refused, not read as the study's).
    """
    scene = load_scene(scene_spec)
    if scene_digest(scene) != digest:
        raise ValueError(f"scene {scene_spec}: its content changed since the study "
                         "started; run the study again")
    t = np.linspace(scene.time.start_s, scene.time.stop_s, instants)
    op = build_operator(simulate(scene, t))
    problems = {name: [FORMULATIONS[name](op, i) for i in range(len(t))] for name in RUN}
    return scene, op, problems, interval_history(op)


def sampled_operator(scene: Scene, op: Operator, articulation: np.ndarray) -> Operator:
    """The operator of the line with each joint's articulation moved by ``articulation``
    (deg), on the same instants; ``op`` itself when nothing moves.
    """
    if not np.any(articulation):
        return op
    joints = tuple(dataclasses.replace(j, articulation_deg=j.articulation_deg + float(d))
                   for j, d in zip(scene.joints, articulation))
    return build_operator(simulate(scene.with_changes(joints=joints), op.t))


def misfit_vector(op: Operator, scene: Scene, seat: np.ndarray) -> np.ndarray:
    """``d`` (n) with ``d . x = sum_b delta_b . F_b``: each bearing's seat offset (m, in
    its shaft's ``r1``, ``r2``) against its radial force on the shaft (N).
    """
    index = {name: k for k, name in enumerate(scene_bearings(scene))}
    d = np.zeros(len(op.names))
    for c in op.bearings():
        B = op.bearing_matrix(c)
        d += seat[index[c.element], 0] * B[0] + seat[index[c.element], 1] * B[1]
    return d


def _load_vars(problem: Conic, n: int) -> dict[int, int]:
    """Force column -> the unknown ``r_c >= ||f_c||`` of its contact, read from the
    problem's second-order cones (apex row first).
    """
    out, row = {}, 0
    for kind, size in problem.cones:
        rows = 3 if kind == "pow" else int(size)
        if kind == "soc":
            load = int(np.flatnonzero(problem.A[row, n:])[0]) + n
            for r in range(row + 1, row + rows):
                out.update((int(j), load) for j in np.flatnonzero(problem.A[r, :n]))
        row += rows
    return out


def misfit_problem(problem, op: Operator, d: np.ndarray, gaps: dict[int, float] | None):
    """``problem`` (a compliance QP or conic) with the misfit's work ``-d . x`` (J) in
    its objective and, in the conic form, each bearing column's contact clearance set to
    ``gaps[column]`` (m). The objective's scale is read from a bearing's energy weight
    (``1/(2k)`` of its law's stiffness ``k``, :func:`~cardan_forces.formulations.convex.
    contact_laws`) as the formulation wrote it:
    ``P_jj k / sb`` is the problem's objective per joule of complementary energy, per
    unit of force ``sb``.
    """
    n, column = len(op.names), op.bearings()[0].columns[0]
    k = next(law.stiffness for law in contact_laws(op) if column in law.columns)
    sb = problem.to_forces.scale
    if isinstance(problem, QP):
        weight = problem.P[column, column] * k / sb
        return dataclasses.replace(problem, q=problem.q - weight * d)
    loads = _load_vars(problem, n)
    weight = problem.P[loads[column], loads[column]] * k / sb
    q = problem.q.copy()
    q[:n] -= weight * d
    for j, gap in (gaps or {}).items():  # a pair's held column has no cone: its partner's
        if j in loads:
            q[loads[j]] = weight * gap
    return dataclasses.replace(problem, q=q)


def _gap_columns(op: Operator, scene: Scene, clearance: np.ndarray) -> dict[int, float] | None:
    """Each bearing column's sampled clearance (m), where the scene calls for
    ``clearance`` (else the compliance problems have no gaps: ``None``).
    """
    if not scene.has("clearance"):
        return None
    index = {name: k for k, name in enumerate(scene_bearings(scene))}
    return {j: float(clearance[index[c.element]]) for c in op.bearings() for j in c.columns}


def run_sample(task: Task) -> dict:
    """One sample's loads (JSON-ready): per formulation each load over the instants,
    each rated bearing's ``L10`` (million revolutions), the instants solved and the
    force components outside the nominal rigid interval. One BLAS thread (the problems
    are small; a Dask worker's process is not the command's).
    """
    with threadpool_limits(limits=1):
        scene, op0, problems, sets = nominal(task.scene, task.digest, task.instants)
        drawn = draws(scene, task.seed, task.index)
        op = sampled_operator(scene, op0, drawn["articulation"])
        d = misfit_vector(op, scene, drawn["seat"])
        gaps = _gap_columns(op, scene, drawn["clearance"])
        out = {"index": task.index, "loads": {}, "L10_Mrev": {}, "solved": {}, "outside": {}}
        for name in RUN:
            def make(i, name=name):
                base = problems[name][i] if op is op0 else FORMULATIONS[name](op, i)
                return misfit_problem(base, op, d, gaps)
            history = solve_over_time(op, name, problem=make)
            out["solved"][name] = history.solved
            out["loads"][name] = sample_loads(op, history.forces)
            out["L10_Mrev"][name] = sample_lives(op, history.forces)
            out["outside"][name] = outside(history.forces, sets)
    return out


def sample_loads(op: Operator, forces: np.ndarray) -> dict[str, list[float]]:
    """Every contact's force magnitude (N; N m never: a slip joint's mixed units are
    left out) and every rated bearing's ``P`` (``P:<bearing>``, N), over the instants.
    """
    loads = {name: v.tolist() for name, v in op.contact_magnitudes(forces).items()}
    for contact, rating in rated(op):
        loads[f"P:{contact.element}"] = iso.equivalent_load(
            rating, *bearing_loads(op, contact, forces)).tolist()
    return loads


def sample_lives(op: Operator, forces: np.ndarray) -> dict[str, float]:
    """Each rated bearing's ``L10`` (million revolutions) over the sample's instants."""
    revs = _revolutions(op.scene, tuple(op.t))
    out = {}
    for contact, rating in rated(op):
        p = iso.equivalent_load(rating, *bearing_loads(op, contact, forces))
        out[contact.element] = iso.rating_life(
            rating, iso.mean_load(p, revs[contact.shaft], iso.exponent(rating)))
    return out


@functools.lru_cache(maxsize=8)
def _revolutions(scene: Scene, t: tuple[float, ...]) -> np.ndarray:
    """Each shaft's revolutions over the stretch of each instant ``t`` (the operator
    does not keep its motion: the scene's motion at those instants, once per process).
    """
    motion = simulate(scene, np.array(t))
    return np.array([iso.revolutions(w, motion.t) for w in motion.omega])


def outside(forces: np.ndarray, sets) -> int:
    """How many (instant, component) values of ``forces`` (T, n) lie outside the rigid
    set's interval ``sets`` by more than :data:`INSIDE_RTOL` of the instant's largest
    force (an open end holds everything on its side; unsolved instants are not counted).
    """
    scale = INSIDE_RTOL * np.nanmax(np.abs(forces), axis=1, initial=1.0)[:, None]
    with np.errstate(invalid="ignore"):
        low = np.where(np.isnan(sets.min), -math.inf, sets.min) - scale
        high = np.where(np.isnan(sets.max), math.inf, sets.max) + scale
        bad = (forces < low) | (forces > high)
    return int(bad.sum())


# ---------------------------------------------------------------------------- a study


def study_key(scene: Scene, seed: int, instants: int) -> dict:
    """What names a study in its store: a sample of another key is another study's.
    The scene by its content (SHA-256), not its file: an edit that changes any value is
    another study, the same scene at another path the same.
    """
    tol = dataclasses.asdict(scene.tolerances) if scene.tolerances else None
    return {"scene": scene.name, "scene_sha256": scene_digest(scene), "seed": seed,
            "instants": instants, "formulations": list(RUN), "tolerances": tol,
            "clearance": scene.has("clearance")}


def layout(op: Operator) -> dict[str, list[str]]:
    """The names a sample of ``op``'s line holds (:func:`sample_loads`,
    :func:`sample_lives`): ``loads`` and ``L10_Mrev``.
    """
    bearings = [contact.element for contact, _ in rated(op)]
    return {"loads": [*op.contact_magnitudes(np.zeros(len(op.names))),
                      *(f"P:{b}" for b in bearings)],
            "L10_Mrev": bearings}


def _local(tasks: list[Task]):
    """Each task run in this process, in order, with a progress bar: ``(task, sample)``,
    or ``(task, error)`` for a sample that could not be made (retried by a rerun).
    """
    for task in bars.bar(tasks, "tolerances", unit="sample"):
        try:
            yield task, run_sample(task)
        except (ValueError, ArithmeticError, RuntimeError) as exc:
            yield task, exc


def run_study(spec: str, samples: int, seed: int, instants: int, out: Path,
              client=None, progress=None, no_workers_s: float = NO_WORKERS_S
              ) -> tuple[dict, dict[str, int]]:
    """Run the samples ``out``'s store lacks (locally, or on ``client``'s cluster, given
    up after ``no_workers_s`` s without a worker), append each as it finishes; the
    summary of samples ``0 .. samples - 1`` and the samples lost this run, counted by
    reason.
    """
    scene = load_scene(spec)
    check_size(scene, samples, instants)
    key = study_key(scene, seed, instants)
    path = out / store.NAME
    have = store.read(path, key, layout(nominal(spec, key["scene_sha256"], instants)[1]))
    todo = [Task(spec, key["scene_sha256"], seed, k, instants)
            for k in range(samples) if k not in have]
    if progress:
        progress(f"tolerances: {len(have)} samples stored, {len(todo)} to run "
                 f"{'on ' + str(client.scheduler.address) if client else 'here'}")
    results = dask(client, todo, no_workers_s, run_sample, "sample") if client else \
        _local(todo)
    lost: dict[str, int] = {}
    with store.opened(path, key) as f:
        for task, result in results:
            if isinstance(result, Exception):
                reason = f"{type(result).__name__}: {' '.join(str(result).split())}"
                if progress and reason not in lost:
                    progress(f"tolerances: sample {task.index} lost: {reason}")
                lost[reason] = lost.get(reason, 0) + 1
                continue
            store.append(f, result)
            have[task.index] = result
    kept = [have[k] for k in range(samples) if k in have]
    return summarize(spec, key["scene_sha256"], scene, instants, kept, samples), lost


def _stack(samples: list[dict], form: str, part: str, names: list[str]) -> np.ndarray:
    """The samples' ``part`` of ``form`` as floats (samples, names, ...); NaN for null."""
    return np.array([[s[part][form].get(n) for n in names] for s in samples], dtype=float)


def _quantiles(values: np.ndarray) -> dict[str, np.ndarray]:
    """:data:`QUANTILES` over axis 0 (NaN where no sample has a value)."""
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN column is NaN
        found = np.nanpercentile(values, QUANTILES, axis=0) if len(values) else \
            np.full((len(QUANTILES), *values.shape[1:]), np.nan)
    return {f"P{q:g}": v for q, v in zip(QUANTILES, found)}


def summarize(spec: str, digest: str, scene: Scene, instants: int, samples: list[dict],
              asked: int) -> dict:
    """The study's answer (JSON-ready): per formulation each load's percentiles over
    the samples at each instant beside the nominal line's value (no deviation), each
    rated bearing's ``L10`` distribution, the instants solved and the components outside
    the nominal rigid set.
    """
    _, op, _, _ = nominal(spec, digest, instants)
    out = {"scene": scene.name, "samples": asked, "stored": len(samples),
           "t_s": op.t, "instants": instants, "quantiles": list(QUANTILES),
           "tolerances": dataclasses.asdict(scene.tolerances) if scene.tolerances else None,
           "notes": notes(scene), "loads": {}, "L10_Mrev": {}, "solved": {}, "outside": {}}
    for form in RUN:
        base = solve_over_time(op, form).forces
        loads, lives = sample_loads(op, base), sample_lives(op, base)
        names = list(loads)
        bands = _quantiles(_stack(samples, form, "loads", names))
        out["loads"][form] = {n: {**{k: v[j] for k, v in bands.items()}, "nominal": loads[n]}
                              for j, n in enumerate(names)}
        spread = _stack(samples, form, "L10_Mrev", list(lives))
        out["L10_Mrev"][form] = {
            b: {**{k: v[j] for k, v in _quantiles(spread).items()},
                "min": float(np.nanmin(spread[:, j], initial=np.inf)),
                "max": float(np.nanmax(spread[:, j], initial=-np.inf)), "nominal": lives[b]}
            for j, b in enumerate(lives)}
        out["solved"][form] = int(sum(s["solved"][form] for s in samples))
        out["outside"][form] = int(sum(s["outside"][form] for s in samples))
    return out


def notes(scene: Scene) -> list[str]:
    """What the reader must know of this scene's study, one sentence each."""
    found = []
    if scene.tolerances is None:
        found.append("the scene states no tolerances: every sample is the nominal line")
    elif scene.tolerances.bearing_clearance_m and not scene.has("clearance"):
        found.append("the clearance tolerance is not used: the scene does not call for "
                     "'clearance', so its compliance problems have no gaps")
    if scene.tolerances and scene.tolerances.articulation_deg:
        found.append("articulations vary: each sample's geometry, hence its rigid set, "
                     "differs from the nominal line's; 'outside' counts components "
                     "outside the nominal set")
    return found


# ---------------------------------------------------------------------------- output


def write_csv(answer: dict, path: Path) -> None:
    """Long format: one row per formulation, load and instant with its percentiles and
    the nominal value (N); an empty cell where undefined.
    """
    keys = [f"P{q:g}" for q in QUANTILES] + ["nominal"]
    with files.replacing(path, newline="") as f:
        w = csv.writer(f)
        w.writerow(["t_s", "formulation", "load", *(f"{k}_N" for k in keys)])
        for form, loads in answer["loads"].items():
            for name, entry in loads.items():
                for i, t in enumerate(answer["t_s"]):
                    w.writerow([f"{t:.6g}", form, name,
                                *(number_text(entry[k][i], ".7g", "") for k in keys)])


def markdown(answer: dict) -> str:
    """``tolerances.md``: the study, its notes and each bearing's ``L10`` distribution."""
    lines = [f"# Tolerance study of scene {answer['scene']}", "",
             f"{answer['stored']} of {answer['samples']} samples, {answer['instants']} "
             f"instants each; tolerances (half-widths of uniform spreads): "
             f"{answer['tolerances']}.", ""]
    lines += [f"- {note}" for note in answer["notes"]]
    for form in RUN:
        lines += ["", f"## {form}", "", f"Instants solved: {answer['solved'][form]}; "
                  f"components outside the nominal rigid set (by more than {INSIDE_RTOL:g} of "
                  f"the instant's largest load): {answer['outside'][form]}.",
                  "", "| bearing | nominal L10 [Mrev] | P5 | P50 | P95 | least | greatest |",
                  "|---|---|---|---|---|---|---|"]
        for bearing, e in answer["L10_Mrev"][form].items():
            cells = [e["nominal"], e["P5"], e["P50"], e["P95"], e["min"], e["max"]]
            lines.append(f"| {bearing} | " +
                         " | ".join(number_text(c, ".4g", "-") for c in cells) + " |")
    return "\n".join(lines) + "\n"


COLUMNS = 2
"""Panels side by side on a page (a column's width each, :data:`images.COLUMN_IN`)."""

ROW_IN = 2.45
"""The height of one row of panels (inches): the panel, its title and note above it
and its x axis below."""

FRAME_IN = 0.85
"""The page's height besides its rows (inches): the figure's title and the legend."""

ROWS_PER_PAGE = int((images.PAGE_IN[1] - FRAME_IN) / ROW_IN)
"""Rows of panels one page holds (:data:`images.PAGE_IN`); more rows take more pages."""


def _curves(answer: dict, name: str) -> dict[str, tuple]:
    """The lines of one load's panel by legend label, each ``(short name, values,
    colour)``: drawn in interleaved dashes (:func:`images.interleave`) in this order, so
    that where they lie on one another each shows in turn.
    """
    lin, hz = answer["loads"][RUN[0]][name], answer["loads"][RUN[1]][name]
    return {f"{RUN[0]}: median": (f"{RUN[0]} median", lin["P50"], "C0"),
            f"{RUN[1]}: median": ("hertz median", hz["P50"], "C1"),
            f"nominal line ({RUN[0]})": ("nominal", lin["nominal"], "k")}


def figures(answer: dict) -> list:
    """The figure's pages (:data:`ROWS_PER_PAGE` rows of :data:`COLUMNS` panels each):
    each rated bearing's ``P`` over time, the compliance samples' 5-95 % band, the
    medians of compliance and compliance_hertz and the nominal line's value, the three
    lines in interleaved dashes and those that lie on one another named above the panel
    with how close. Make them in :func:`images.styled`.
    """
    names = [n for n in answer["loads"][RUN[0]] if n.startswith("P:")] or \
        list(answer["loads"][RUN[0]])[:4]
    per_page = COLUMNS * ROWS_PER_PAGE
    pages = [names[k:k + per_page] for k in range(0, len(names), per_page)] or [[]]
    return [_page(answer, chunk, k, len(pages)) for k, chunk in enumerate(pages)]


def figure(answer: dict):
    """The figure's first page (:func:`figures`)."""
    return figures(answer)[0]


def _page(answer: dict, names: list[str], page: int, pages: int):
    """One page of :func:`figures`: the panels of ``names``, one legend under them."""
    import matplotlib.pyplot as plt

    rows = max(1, math.ceil(len(names) / COLUMNS))
    height = FRAME_IN + ROW_IN * rows
    fig, axes = plt.subplots(rows, COLUMNS, figsize=(images.PAGE_IN[0], height),
                             squeeze=False)
    handles = {}
    for ax, name in zip(axes.ravel(), names):
        handles.update(_panel(ax, answer, name))
    for ax in axes.ravel()[len(names):]:
        ax.set_visible(False)
    of = f" ({page + 1} of {pages})" if pages > 1 else ""
    fig.suptitle(images.typeset(f"{answer['scene']}: equivalent bearing loads over "
                                f"{answer['stored']} tolerance samples{of}"))
    if handles:
        fig.legend(handles.values(), handles.keys(), loc="lower center", ncol=2)
    fig.canvas.draw()
    below = (fig.legends[0].get_window_extent().height / fig.dpi + 0.05
             if fig.legends else 0.0)
    above = fig._suptitle.get_window_extent().height / fig.dpi + 0.1
    fig.tight_layout(rect=(0, below / height, 1, 1 - above / height), pad=0.3, h_pad=0.8,
                     w_pad=3.0)  # the right panels' y labels clear of the left ones
    return fig


def _panel(ax, answer: dict, name: str) -> dict:
    """One load's panel (:func:`figures`); its legend handles by label."""
    t = np.asarray(answer["t_s"])
    lin = answer["loads"][RUN[0]][name]
    curves = _curves(answer, name)
    values = {short: np.asarray(v, float) for short, v, _ in curves.values()}
    low, high = images.limits([lin["P5"], lin["P95"], *values.values()])
    tol = images.COINCIDE * (high - low)
    width = np.nan_to_num(np.asarray(lin["P95"], float) - np.asarray(lin["P5"], float))
    band = f"{RUN[0]}: 5-95 % of samples"
    flat = bool(np.all(width <= tol))  # a band no wider than a line: not shown, said
    handles = {} if flat else {band: ax.fill_between(t, lin["P5"], lin["P95"], color="C0",
                                                     alpha=0.25, lw=0, label=band)}
    for k, (label, (_, v, colour)) in enumerate(curves.items()):
        handles[label], = ax.plot(t, v, color=colour, label=label,
                                  ls=images.interleave(k, len(curves)))
    ax.set_ylim(low, high)
    together = images.coincide_note(values, images.coinciding(values, tol), "N")
    note = "; ".join(n for n in (
        f"no band: {RUN[0]}'s samples within {width.max(initial=0.0):.2g} N" if flat
        else "", f"on one another: {together}" if together else "") if n)
    if note:
        text = textwrap.fill(note,
                             images.chars_across(images.COLUMN_IN - 0.9))
        ax.annotate(text, xy=(0, 1), xycoords="axes fraction", xytext=(0, 3),
                    textcoords="offset points", va="bottom", fontsize=images.MIN_TEXT_PT,
                    color="0.25").set_in_layout(False)  # the title's pad holds it
    lines = text.count("\n") + 1 if note else 0
    ax.set_title(images.typeset(name.removeprefix("P:")), loc="left",
                 pad=3 + (1.25 * images.MIN_TEXT_PT * lines + 2 if lines else 0))
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("equivalent load P [N]" if name.startswith("P:") else "force [N]")
    ax.grid(True)
    return handles


def write_outputs(answer: dict, out: Path, formats=("png",)) -> list[Path]:
    """``tolerances.csv``, ``tolerances.md`` and the figure (``tolerances.<format>``; a
    page each where its panels take more than one, :func:`images.save_pages`); their
    paths.
    """
    return images.write_study(out, "tolerances", lambda path: write_csv(answer, path),
                              markdown(answer), lambda: figures(answer), formats)


def add_parser(subparsers) -> None:
    """Register ``cardan tolerances``."""
    p = subparsers.add_parser("tolerances", help="Monte Carlo of the loads the scene's "
                              "tolerances put into the line (compliance and Hertz solves)")
    p.add_argument("scene", help="built-in name or TOML path")
    p.add_argument("--samples", type=whole_number(1, MAX_SAMPLES), required=True,
                   help=f"samples (at most {MAX_SAMPLES})")
    p.add_argument("--instants", type=whole_number(2, 2001), default=INSTANTS,
                   help=f"instants over the scene's window (default {INSTANTS})")
    p.add_argument("--seed", type=whole_number(0, 2 ** 63 - 1), default=0,
                   help="the study's seed (default 0); sample k draws from (seed, k)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help='run on this Dask scheduler (pip install -e ".[dask]")')
    p.add_argument("--timeout", type=float, default=NO_WORKERS_S,
                   help="seconds to wait for the Dask scheduler, and for a worker when the "
                        "scheduler has none left (then the run ends, keeping its samples; "
                        "default %(default)g)")
    p.add_argument("--out", type=files.folder, default="results/tolerances",
                   help="output folder, and the samples' store (default %(default)s)")
    p.add_argument("--format", type=format_list, default=("png",),
                   help="comma-separated image formats (default png; any of png,svg,pdf)")
    p.add_argument("--json", action="store_true",
                   help="print the summary as strict JSON on stdout (the store is written)")
    p.set_defaults(func=run)


def run(args) -> int:
    """The study: 0 done, 1 when samples were lost (a rerun retries them), 2 bad input."""
    if not (math.isfinite(args.timeout) and 0 < args.timeout <= 3600):
        raise UsageError(f"--timeout {args.timeout}: must be in (0, 3600] s")
    try:
        load = load_scene(args.scene)
        check_size(load, args.samples, args.instants)
    except ValueError as err:
        if isinstance(err, SceneError):
            raise
        raise UsageError(str(err)) from None
    client = connect(args.scheduler, args.timeout) if args.scheduler is not None else None
    try:
        answer, lost = run_study(args.scene, args.samples, args.seed, args.instants,
                                 Path(args.out), client, bars.line, args.timeout)
    finally:
        if client is not None:
            close(client, args.timeout)
    if args.json:
        print(json_text(answer))
    else:
        files.say_written("tolerances", write_outputs(answer, Path(args.out), args.format))
    for reason, count in lost.items():  # said whatever --quiet says: the exit code's why
        print(f"tolerances: lost {count} sample(s): {reason}", file=sys.stderr)
    return 1 if lost else 0
