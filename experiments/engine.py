"""``cardan engine SCENE``: what the physics engines say about the drive line's loads,
set against the rigid analysis. ``--engine mujoco`` (the default), ``drake`` or ``all``:
MuJoCo (:mod:`cardan_forces.driveline.engine_mujoco`) and Drake
(:mod:`cardan_forces.driveline.engine_drake`) build the same line from the element
kinds and simulate it forward.

At sampled instants, for the engine's forces ``x_e`` under each setting:

- the residual of the package's equilibrium, ``||A x_e - b|| / ||b||``;
- the determinate components: ``|x_e - x|`` against the rigid value (a point);
- every indeterminate component inside or outside its rigid interval
  (:func:`~cardan_forces.experiments.study.intervals`), within a tolerance of
  1e-6 of the largest load plus the equilibrium residual's size;
- the formulation whose forces lie closest, ``||x_e - x_f|| / ||x_f||``;
- the member of the rigid set the engine's regularisation selects, predicted without
  simulating (:mod:`~cardan_forces.experiments.engine_member`), and its distance
  ``||x_p - x_e|| / ||x_e||`` from the simulated forces;
- the spread of each component over the softness settings: the determinate ones stay
  put (to the softness error), the indeterminate ones move with settings that have
  nothing to do with the machine.

The softness settings (:data:`SETTINGS`) vary MuJoCo's ``solref`` time constant over
0.0005-0.008 s, its damping ratio 0.3-1, ``solimp``'s impedance (0.9, 0.95) to (0.99, 0.999)
and width 1 mm to 1 um, all bearings alike; the relative softness of the input
and output shafts' bearings (one shaft's time constant 4 times the other's); and the
integration step (MuJoCo's coarsest, half the time constant, against 1/8). Drake's
settings (:data:`DRAKE_SETTINGS`) are its discrete step, the only parameter that
softens its ball constraints (SAP fixes their near-rigid threshold). Instants
within the engine's settling (the first 10 time constants of the softest constraint:
the line starts unloaded and sags into its constraints) are left out of the
statistics and said to be. An engine that is not installed, or cannot express the
scene, is left out with one line saying why (an explicit ``--engine`` of it is refused).
"""

from __future__ import annotations

import csv
import json
import textwrap
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from cardan_forces.driveline import engine_drake, engine_mujoco
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import reduced_inertia, simulate
from cardan_forces.driveline.engine_drake import Stepping
from cardan_forces.driveline.engine_mujoco import EngineRun, EngineUnsupported, Governor, Softness
from cardan_forces.driveline.equilibrium import Operator, build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.driveline.scene import IN_MOTION
from cardan_forces.experiments import engine_member, files
from cardan_forces.experiments.engine_loads import ENGINES, engine_of, load_of, load_rows
from cardan_forces.experiments.environment import number_text
from cardan_forces.experiments.images import (
    COINCIDE,
    MIN_TEXT_PT,
    PAGE_IN,
    bound_note,
    chars_across,
    coincide_note,
    coinciding,
    draw_set,
    format_list,
    legend_below,
    limits,
    on_bound,
    save,
    styled,
)
from cardan_forces.experiments.study import intervals as rigid_intervals
from cardan_forces.experiments.study import value_ranges
from cardan_forces.formulations import FALLBACK, FORMULATIONS
from cardan_forces.formulations.convex import NotApplicable
from cardan_forces.solvers import SolverNotFound, UnsupportedProblem, solve

SETTINGS = (
    Softness(label="default"),
    Softness(timeconst_s=0.0005, label="timeconst 0.0005 s"),
    Softness(timeconst_s=0.008, label="timeconst 0.008 s"),
    Softness(dampratio=0.3, label="dampratio 0.3"),
    Softness(dmin=0.99, dmax=0.999, label="solimp 0.99/0.999"),
    Softness(width_m=1e-6, label="solimp width 1 um"),
    Softness(scaled=(("output", 4.0),), label="output bearings 4x softer"),
    Softness(scaled=(("input", 4.0),), label="input bearings 4x softer"),
    Softness(steps_per_timeconst=2, label="step timeconst/2"),
)
"""The softness settings compared (module doc); the first is the reference. A
``scaled`` shaft the scene lacks leaves that setting uniform."""

FIGURE_SETTINGS = ("default", "output bearings 4x softer", "input bearings 4x softer")
"""MuJoCo's settings drawn over time (Drake's first setting is drawn beside them)."""

DRAKE_SETTINGS = (
    Stepping(2.5e-4, "Drake, step 0.25 ms"),
    Stepping(1.25e-4, "Drake, step 0.125 ms"),
    Stepping(5e-4, "Drake, step 0.5 ms"),
)
"""Drake's settings compared (module doc): its discrete step; the first is its reference.
A step that does not divide the scene's is left out."""

PREDICTION_RTOL = 1e-2
"""The prediction is said to match a simulation within this share of the force norm."""


INSIDE_RTOL = 1e-6


@dataclass(frozen=True)
class InstantComparison:
    """One setting at one instant (module doc). ``outside``: indeterminate components
    outside their interval; ``closest``: (formulation, relative distance);
    ``predicted_error``: ``||x_p - x_e|| / ||x_e||`` (nan where not predicted).
    """

    setting: str
    t: float
    residual: float
    determinate_error_N: float
    outside: tuple[str, ...]
    closest: tuple[str, float]
    predicted_error: float = float("nan")


@dataclass(frozen=True)
class EngineStudy:
    """The runs, the operator they were read on, and the comparisons; ``predicted``:
    per run, the predicted member at each sampled instant; ``compliances``: per run and
    sampled instant, the bearing compliances the prediction used (relative);
    ``skipped``: per engine left out, why.
    """

    op: Operator
    runs: dict[str, EngineRun]
    sampled: np.ndarray
    settled: np.ndarray
    intervals: dict[int, np.ndarray]
    determinate: np.ndarray
    rigid: dict[int, np.ndarray]
    comparisons: tuple[InstantComparison, ...]
    formulations: dict[int, dict[str, np.ndarray]]
    predicted: dict[str, dict[int, np.ndarray]] = field(default_factory=dict)
    compliances: dict[str, dict[int, dict[str, float]]] = field(default_factory=dict)
    skipped: dict[str, str] = field(default_factory=dict)


def _formulation_forces(op, i: int) -> dict[str, np.ndarray]:
    """Each convex formulation's forces at instant ``i`` (those some backend solves: its
    default backends, then the fallback; one that does not take the scene's problem,
    e.g. a QP solver given a friction cone, is passed over for the next). The paper's
    NLS and the LCP are left out: the first lands wherever its root finder does, the
    second is ``positive``'s answer again.
    """
    out = {}
    for name, formulation in FORMULATIONS.items():
        if not formulation.exportable:
            continue
        for backend in (*formulation.backends, FALLBACK):
            try:
                record = solve(formulation(op, i), backend)
            except (SolverNotFound, NotApplicable, UnsupportedProblem):
                continue
            if record.solved:
                out[name] = np.asarray(record.x[:len(op.names)], float)
                break
    return out


def _ends(found: dict) -> tuple[float, float]:
    """An interval's ``min``, ``max`` as numbers, +-inf where a side is not bounded."""
    return (-np.inf if found["min"] is None else found["min"],
            np.inf if found["max"] is None else found["max"])


def _intervals(op, i: int) -> np.ndarray:
    """(n, 2): each component's rigid interval at instant ``i``, +-inf where unbounded."""
    return np.array([_ends(found) for found in rigid_intervals(op, i).values()])


def settle_s(runs: dict[str, EngineRun]) -> float:
    """The engine's settling (s from the start): 10 time constants of the softest
    constraint of any run (the line starts unloaded and sags into its constraints).
    """
    return 10 * max(r.softness.timeconst_s * max([1.0] + [f for _, f in r.softness.scaled])
                    for r in runs.values())


def compliances(op, run: EngineRun, sampled: np.ndarray) -> dict[int, dict[str, float]]:
    """The bearing compliances (relative) the run's engine and setting give at each
    ``sampled`` instant (:mod:`~cardan_forces.experiments.engine_member`, eqs. 2 and 3):
    MuJoCo's stay as the line turns, Drake's are taken with the line posed at the rigid
    motion's angle of the instant.
    """
    if isinstance(run.softness, Stepping):
        angles = simulate(op.scene, op.t[sampled]).q
        return dict(zip(sampled.tolist(), engine_member.compliances_drake(op, angles)))
    found = engine_member.compliances_mujoco(op, run.softness)
    return {i: found for i in sampled.tolist()}


def compare(op, runs: dict[str, EngineRun], sampled: np.ndarray,
            skipped: dict[str, str] | None = None) -> EngineStudy:
    """Set every run against the rigid analysis and against its predicted member at the
    ``sampled`` instants; ``skipped``: the engines left out and why.
    """
    settled = op.t[sampled] - op.t[0] >= settle_s(runs)
    det0 = determinacy(op, int(sampled[0]))
    weights, drake = {}, None
    for label, r in runs.items():
        if engine_of(r) == ENGINES["drake"]:  # its step does not move them: taken once
            drake = drake or compliances(op, r, sampled)
            weights[label] = drake
        else:
            weights[label] = compliances(op, r, sampled)
    intervals, rigid, forms, comparisons = {}, {}, {}, []
    predicted: dict[str, dict[int, np.ndarray]] = {label: {} for label in runs}
    for i in sampled:
        det = determinacy(op, int(i))
        intervals[i], rigid[i] = _intervals(op, int(i)), det.min_norm
        forms[i] = _formulation_forces(op, int(i))
        for label, r in runs.items():
            predicted[label][i] = engine_member.predicted(op, int(i), weights[label][int(i)])
            comparisons.append(compare_instant(op, int(i), label, r.forces[i], det,
                                               intervals[i], forms[i], predicted[label][i]))
    return EngineStudy(op, runs, sampled, settled, intervals, det0.determinate, rigid,
                       tuple(comparisons), forms, predicted, weights, dict(skipped or {}))


def compare_instant(op, i, label, x, det, interval, forms,
                    predicted: np.ndarray | None = None) -> InstantComparison:
    """The engine's forces ``x`` at instant ``i`` against the rigid model (module doc):
    ``det`` its determinacy there, ``interval`` (n, 2) each component's rigid interval
    (+-inf where unbounded), ``forms`` formulation forces by name (may be empty),
    ``predicted`` the engine's predicted member (None: not predicted).
    """
    b = op.b[i]
    residual = float(np.linalg.norm(op.A[i] @ x - b) / np.linalg.norm(b))
    d = det.determinate
    error = float(np.max(np.abs(x[d] - det.min_norm[d]), initial=0.0))
    slack = INSIDE_RTOL * max(np.abs(b).max(), np.abs(x).max()) + residual * np.linalg.norm(b)
    out = [n for n, v, (lo, hi), fixed in zip(op.names, x, interval, d)
           if not fixed and not lo - slack <= v <= hi + slack]
    distances = {f: float(np.linalg.norm(x - xf) / np.linalg.norm(xf)) for f, xf in forms.items()}
    closest = min(distances.items(), key=lambda kv: kv[1]) if distances else ("-", np.nan)
    off = (np.nan if predicted is None
           else float(np.linalg.norm(predicted - x) / np.linalg.norm(x)))
    return InstantComparison(label, float(op.t[i]), residual, error, tuple(out), closest, off)


def _unusable(name: str, scene, op=None) -> str:
    """Why engine ``name`` cannot run ``scene`` (its operator ``op`` where built), in
    one line; empty where it can.
    """
    try:
        if name == "drake":
            engine_drake.drake_version()
            if op is not None:
                engine_drake.check_expressible(op)
                return ""
        else:
            engine_mujoco.mujoco_version()
        engine_mujoco.check_expressible(scene)
    except EngineUnsupported as err:
        return str(err).replace("MuJoCo cannot", f"{ENGINES[name]} cannot")
    return ""


def usable(engines, scene, op=None) -> tuple[tuple[str, ...], dict[str, str]]:
    """The ``engines`` that run ``scene`` and, for each other, why not (one line each);
    :class:`NotApplicable` where none can (every reason in its message).
    """
    why = {name: _unusable(name, scene, op) for name in engines}
    ok = tuple(name for name in engines if not why[name])
    if not ok:
        raise NotApplicable("; ".join(why.values()))
    return ok, {ENGINES[name]: text for name, text in why.items() if text}


def study(spec: str, stop_s: float | None = None, instants: int = 6,
          settings=SETTINGS, engines=("mujoco",), drake_settings=DRAKE_SETTINGS) -> EngineStudy:
    """Run the ``engines`` on scene ``spec`` up to ``stop_s`` (default its stop) under
    each of their settings and compare at ``instants`` evenly spaced instants; an
    engine that cannot run the scene is left out (:func:`usable`). A quasi-static scene
    is taken in motion (:meth:`~cardan_forces.driveline.scene.Scene.in_motion`: its
    inertia added, for the engines and the rigid set alike, its description saying so).
    """
    given = load_scene(spec)
    scene = given.in_motion()
    usable(engines, scene)
    t = scene.time.instants()
    if stop_s is not None:
        t = t[t <= stop_s + 1e-12]
        if len(t) < 2:
            raise NotApplicable(f"--stop {stop_s}: the scene's grid starts at "
                                f"{scene.time.start_s} s with step {scene.time.step_s} s; "
                                "give at least two of its instants")
    motion = simulate(scene, t)
    governor = None if given is scene or len(t) < 2 else Governor(
        motion.t, motion.q, motion.qd, float(reduced_inertia(scene, motion.kin)[0][0]))
    return study_operator(build_operator(motion), instants, settings, engines,
                          drake_settings, governor)


def study_operator(op, instants: int = 6, settings=SETTINGS, engines=("mujoco",),
                   drake_settings=DRAKE_SETTINGS, governor=None) -> EngineStudy:
    """:func:`study` on an operator already built: :func:`engine_runs`, compared at
    ``instants`` evenly spaced instants.
    """
    ok, skipped = usable(engines, op.scene, op)
    sampled = np.unique(np.linspace(0, len(op.t) - 1, instants).round().astype(int))
    return compare(op, engine_runs(op, settings, ok, drake_settings, governor), sampled,
                   skipped)


def engine_runs(op, settings=SETTINGS, engines=("mujoco",),
                drake_settings=DRAKE_SETTINGS, governor=None) -> dict[str, EngineRun]:
    """The ``engines`` on the operator's scene by setting label: MuJoCo under every
    setting whose ``scaled`` shafts the scene has, Drake under every step that divides
    the scene's (:class:`NotApplicable` where one cannot run); their input speed held
    by ``governor`` (:class:`~cardan_forces.driveline.engine_mujoco.Governor`) where
    one is given.
    """
    shafts = {s.name for s in op.scene.shafts}
    step = op.scene.time.step_s
    runs = {}
    try:
        if "mujoco" in engines:
            runs.update({s.label: engine_mujoco.run(op, s, governor) for s in settings
                         if all(name in shafts for name, _ in s.scaled)})
        if "drake" in engines:
            runs.update({s.label: engine_drake.run(op, s, governor) for s in drake_settings
                         if abs(step / s.time_step_s - round(step / s.time_step_s)) < 1e-6})
    except EngineUnsupported as err:
        raise NotApplicable(str(err)) from None
    return runs


def _band(op, rows: np.ndarray, sampled: np.ndarray) -> np.ndarray:
    """(k, 2): the rigid interval of the load ``rows`` (:func:`_load`) at the sampled
    instants (+-inf: unbounded): of one row exact; of a length, the range its two
    components' intervals allow (their box hull: it contains the exact range).
    """
    out = []
    for i in sampled:
        ends = [_ends(found) for found in value_ranges(op, int(i), rows)]
        if len(ends) == 1:
            out.append(ends[0])
            continue
        closest = [0.0 if lo <= 0.0 <= hi else min(abs(lo), abs(hi)) for lo, hi in ends]
        out.append((np.hypot(*closest), np.hypot(*(max(abs(lo), abs(hi)) for lo, hi in ends))))
    return np.array(out, float).reshape(-1, 2)


def draw(result: EngineStudy, stem: Path, formats=("png",)) -> list[Path]:
    """The engine's first-shaft bearing loads over time for :data:`FIGURE_SETTINGS`
    from the end of its settling on (:func:`settle_s`, the instants its statistics
    use), over the rigid set, drawn as ``cardan repro``'s figures draw it
    (:func:`~cardan_forces.experiments.images.draw_set`: a band where both ends are
    finite, the finite end with the open side marked, one far below the loads marked
    on the panel's edge), one legend below the panels, on one page in the print style
    (:mod:`~cardan_forces.experiments.images`); saved as ``stem`` in each of ``formats``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    op, rows = result.op, load_rows(result.op)
    drake = [n for n, r in result.runs.items() if engine_of(r) == ENGINES["drake"]]
    names = [n for n in FIGURE_SETTINGS if n in result.runs] + drake[:1]
    start = float(op.t[0]) + settle_s(result.runs)
    counts = [f"MuJoCo: {len(names) - len(drake[:1])} of its "
              f"{len(result.runs) - len(drake)} softness settings"] if len(drake) < len(
        result.runs) else []
    counts += [f"Drake: {len(drake[:1])} of its {len(drake)} steps"] if drake else []
    with styled():
        fig, axes = plt.subplots(len(rows), 1, figsize=(PAGE_IN[0], 2.3 * len(rows) + 1.3),
                                 squeeze=False)
        handles = {}
        for ax, (label, c) in zip(axes[:, 0], rows.items()):
            handles.update(_draw_load(ax, result, label, c, names, start))
        fig.suptitle(f"The engines' first-shaft bearing loads over the rigid set "
                     f"({op.scene.name})\n{'; '.join(counts)}; from {start:g} s")
        legend_below(fig, handles)
        paths = save(fig, stem, formats)
    plt.close(fig)
    return paths


def _draw_load(ax, result: EngineStudy, label: str, rows: np.ndarray, names: list[str],
               start: float) -> dict:
    """One panel: the load of each setting in ``names`` from ``start`` (s) on (markers
    at staggered instants; those on one another or on a bound of the set named above
    the panel, with how close) over its rigid set at the sampled instants; its legend
    handles.
    """
    op, handles = result.op, {}
    shown = op.t >= start - 1e-12
    sampled = result.sampled[shown[result.sampled]]
    band = _band(op, rows, sampled)
    curves = {(n if engine_of(result.runs[n]) == ENGINES["drake"] else f"MuJoCo, {n}"):
              np.where(shown, load_of(result.runs[n].forces, rows), np.nan) for n in names}
    low, high = limits(list(curves.values()), [band[:, 0], band[:, 1]])
    step, first = max(1, int(shown.sum()) // 8), int(np.argmax(shown))
    for k, (name, values) in enumerate(curves.items()):
        handles[name], = ax.plot(op.t, values, ("-", "--", "-.", ":")[k % 4], color=f"C{k}",
                                 marker="osD^"[k % 4], markevery=(first + k * step // len(curves),
                                                                  step), zorder=3, label=name)
    drawn, note = draw_set(ax, op.t[sampled], band[:, 0], band[:, 1], "N", view=(low, high))
    handles.update(drawn)
    ax.set_ylim(low, high)
    tol = COINCIDE * (high - low)
    ends = np.full((len(op.t), 2), np.nan)
    ends[sampled] = np.where(np.isfinite(band), band, np.nan)
    above = "; ".join(n for n in (
        coincide_note(curves, coinciding(curves, tol), "N"),
        *(bound_note(on_bound(curves, ends[:, k], tol), word, "N")
          for k, word in enumerate(("lower", "upper"))), note) if n)
    above = textwrap.fill(above, chars_across(PAGE_IN[0] - 0.8))
    if above:
        ax.annotate(above, xy=(0, 1),
                    xycoords="axes fraction",
                    xytext=(0, 3), textcoords="offset points", va="bottom",
                    fontsize=MIN_TEXT_PT, color="0.25")
    ax.set_title(label, loc="left", pad=5 + 1.3 * MIN_TEXT_PT * (above.count("\n") + 1
                                                                 if above else 0))
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("force [N]")
    ax.grid(True)
    return handles


def _g(value: float) -> str:
    return number_text(value, ".3g")


def _end(value: float) -> str:
    """An interval's end, ``unbounded`` where the LP is."""
    return number_text(value, ".2f", "unbounded")


def spread(result: EngineStudy) -> np.ndarray:
    """Per component, the largest spread (max - min) over the settings at a settled
    sampled instant (N, N m); ``nan`` where no sampled instant is settled.
    """
    settled = result.sampled[result.settled]
    if not len(settled):
        return np.full(len(result.op.names), np.nan)
    stack = np.stack([r.forces[settled] for r in result.runs.values()])
    return np.max(np.ptp(stack, axis=0), axis=0)


def report_lines(result: EngineStudy, versions: str) -> list[str]:
    """``engine.md``: cost, agreement per setting, the predicted members and the
    sensitivity table; ``versions``: the engines' names and versions.
    """
    op, settled = result.op, set(result.sampled[result.settled].tolist())
    lines = [f"# {versions} beside the rigid analysis: {op.scene.name}", "",
             "Forward simulation from the scene's start (module doc of "
             "`driveline/engine_mujoco.py`: inverse dynamics on the package's exact "
             "motion gives no constraint force in a soft-constraint engine); every bearing "
             "a constraint to the ground (MuJoCo's `connect`, Drake's ball constraint to a "
             "seat welded to the ground), the joints in the engine's kinematic tree; forces "
             f"read at the scene's instants. Compared at {len(result.sampled)} instants, "
             f"{len(settled)} of them after the engines' settling (10 time constants), which "
             "the statistics use."]
    if op.scene.description.endswith(IN_MOTION):
        held = max(run.governed_N_m for run in result.runs.values())
        lines += ["", "The scene is quasi-static: it is taken in motion, its inertia added "
                  "for the engines and the rigid set alike (the engines integrate dynamics), "
                  "and the engines' input shaft held on the rigid set's motion by a "
                  "governor on the "
                  f"input torque (`Governor`): at most {_g(held)} N m at the instants "
                  "read."]
    lines += [f"Not run: {name}: {why}" for name, why in result.skipped.items()]
    lines += ["", *cost_lines(result), "", *agreement_lines(result), "",
              *prediction_lines(result), "", *_sensitivity_lines(result)]
    return lines


def cost_lines(result: EngineStudy) -> list[str]:
    """Each run's cost: step, steps, wall time and wall time per simulated second."""
    lines = ["## Cost (one run)", "",
             "| engine | setting | step (s) | steps | wall (s) | s per simulated s |",
             "|---|---|---|---|---|---|"]
    span = result.op.t[-1] - result.op.t[0]
    for label, r in result.runs.items():
        lines.append(f"| {engine_of(r)} | {label} | {r.timestep_s:.3g} | {r.steps} | "
                     f"{r.wall_s:.2f} | {_g(r.wall_s / span if span > 0 else np.nan)} |")
    return lines


BEYOND = ("Beyond its residual: a discrete engine's forces carry, besides their residual "
          "of A x = b, a self-stress from its time step that A x = b does not see; it grows "
          "with the line's speed and shrinks with the step (docs: Physics engines and the "
          "member they pick).")
"""What the report says where a prediction misses beyond the engine's own residual."""


def verdict(rows: list[InstantComparison]) -> str:
    """Whether the predicted member matches a run at its settled instants ``rows``:
    ``yes`` within :data:`PREDICTION_RTOL` at each; otherwise whether every miss lies
    within the engine's own residual of ``A x = b`` at its instant, or beyond it.
    """
    missed = [c for c in rows if c.predicted_error > PREDICTION_RTOL]
    if not missed:
        return "yes"
    if all(c.predicted_error <= c.residual for c in missed):
        return "no, within its residual"
    return "no, beyond its residual"


def prediction_lines(result: EngineStudy) -> list[str]:
    """Per run, over the settled instants: the bearing compliances its engine's
    regularisation gives (relative to the smallest), the largest distance of the
    predicted member from the simulated forces, the engine's own largest residual, and
    the :func:`verdict`; :data:`BEYOND` where a run misses beyond its residual.
    """
    op, settled = result.op, set(result.sampled[result.settled].tolist())
    names = [link.name for link in op.bearings()]
    lines = ["## The member each engine picks, predicted without simulating", "",
             "Predicted: the least complementary energy of the bearings as springs of the "
             "compliances the engine's regularisation gives (MuJoCo: `R / k` from `solref`, "
             "`solimp` and `body_invweight0`; Drake: SAP's near-rigid `R`, proportional to "
             "its Delassus estimate), over the rigid set (`experiments/engine_member.py`). "
             f"Distance: ||x_predicted - x_engine|| / ||x_engine||; matches: within "
             f"{PREDICTION_RTOL:g} of the force norm at every settled instant, or where "
             "not, whether within the engine's own residual at the instant.", "",
             "| engine | setting | compliances at the last instant (" + ", ".join(names) + ") | "
             "distance from the simulation | engine's residual of A x = b | matches |",
             "|---|---|---|---|---|---|"]
    for label, r in result.runs.items():
        rows = [c for c in result.comparisons if c.setting == label
                and np.argmin(np.abs(op.t - c.t)) in settled]
        if not rows:
            continue
        c = result.compliances[label][max(i for i in result.sampled.tolist() if i in settled)]
        least = min(c.values())
        far = max(x.predicted_error for x in rows)
        lines.append(f"| {engine_of(r)} | {label} | "
                     + ", ".join(_g(c[n] / least) for n in names)
                     + f" | {_g(far)} | {_g(max(x.residual for x in rows))} | "
                     f"{verdict(rows)} |")
    if any(line.endswith("| no, beyond its residual |") for line in lines):
        lines += ["", BEYOND]
    return lines


def agreement_lines(result: EngineStudy) -> list[str]:
    """Per setting, over the settled instants: residual, determinate error, components
    outside their interval, the closest formulation (at its farthest instant).
    """
    op, settled = result.op, set(result.sampled[result.settled].tolist())
    lines = ["## Agreement with the rigid model (settled instants)", "",
              "| engine | setting | max residual of A x = b | max determinate error (N) | "
              "outside their interval | closest formulation (rel. distance) |",
              "|---|---|---|---|---|---|"]
    for label in result.runs:
        rows = [c for c in result.comparisons if c.setting == label
                and np.argmin(np.abs(op.t - c.t)) in settled]
        if not rows:
            continue
        outside = sorted({n for c in rows for n in c.outside})
        worst = max(rows, key=lambda c: c.closest[1])
        lines.append(f"| {engine_of(result.runs[label])} | {label} | "
                     f"{_g(max(c.residual for c in rows))} | "
                     f"{_g(max(c.determinate_error_N for c in rows))} | "
                     f"{', '.join(outside) or 'none'} | {worst.closest[0]} "
                     f"({_g(worst.closest[1])}) |")
    return lines


def _sensitivity_lines(result: EngineStudy) -> list[str]:
    op, spreads = result.op, spread(result)
    i = int(result.sampled[-1])
    lines = ["## Sensitivity to the softness (spread over the settings)", "",
             f"Interval and values at t = {op.t[i]:.3f} s; spread: the largest over "
             "settled instants.", "",
             "| component | determinate | rigid interval | "
             + " | ".join(result.runs) + " | spread |",
             "|---|---|---|" + "---|" * len(result.runs) + "---|"]
    for j, name in enumerate(op.names):
        lo, hi = result.intervals[i][j]
        values = " | ".join(f"{r.forces[i, j]:.2f}" for r in result.runs.values())
        lines.append(f"| {name} | {'yes' if result.determinate[j] else 'no'} | "
                     f"[{_end(lo)}, {_end(hi)}] | {values} | {_g(spreads[j])} |")
    det = result.determinate
    lines += ["", f"Largest spread: determinate components "
              f"{_g(np.nanmax(spreads[det], initial=0.0))}, indeterminate "
              f"{_g(np.nanmax(spreads[~det], initial=0.0))} (N, N m)."]
    return lines


def checks(result: EngineStudy) -> dict:
    """``engine.json``: per run its engine, setting and cost, and per sampled instant
    the checks (module doc) and the predicted member; the engines left out and why.
    """
    op = result.op
    settled = set(result.sampled[result.settled].tolist())

    def number(value: float):
        return None if not np.isfinite(value) else float(value)

    runs = []
    for label, r in result.runs.items():
        instants = []
        for c in (c for c in result.comparisons if c.setting == label):
            i = int(np.argmin(np.abs(op.t - c.t)))
            instants.append({
                "t": c.t, "settled": i in settled, "residual": number(c.residual),
                "determinate_error_N": number(c.determinate_error_N),
                "outside": list(c.outside), "closest": c.closest[0],
                "closest_distance": number(c.closest[1]),
                "predicted_distance": number(c.predicted_error),
                "predicted": [float(v) for v in result.predicted[label][i]],
                "compliances": result.compliances[label][i],
                "forces": [float(v) for v in r.forces[i]]})
        counted = [c for c in result.comparisons if c.setting == label
                   and int(np.argmin(np.abs(op.t - c.t))) in settled]
        runs.append({"engine": engine_of(r), "setting": label, "step_s": r.timestep_s,
                     "steps": r.steps, "wall_s": r.wall_s,
                     "prediction": verdict(counted) if counted else None,
                     "instants": instants})
    return {"scene": op.scene.name, "names": list(op.names), "runs": runs,
            "skipped": result.skipped}


def write(result: EngineStudy, out: Path, versions: str,
          formats=("png",)) -> list[Path]:
    """``engine.csv`` (every instant: each run's forces), ``engine.json``
    (:func:`checks`), ``engine.md``, the figure ``engine.<format>`` for each of
    ``formats`` and the softening study's CSV and figure
    (:mod:`~cardan_forces.experiments.engine_softening`, imported here as it reads this
    module's loads); ``versions`` as :func:`report_lines` takes them.
    """
    from cardan_forces.experiments import engine_softening

    out.mkdir(parents=True, exist_ok=True)
    with files.replacing(out / "engine.csv", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["engine", "setting", "t", *result.op.names])
        for label, r in result.runs.items():
            for t, x in zip(r.t, r.forces):
                writer.writerow([engine_of(r), label, f"{t:.6g}",
                                 *(number_text(v, ".9g", "") for v in x)])
    files.write_text(out / "engine.json", json.dumps(checks(result), indent=1) + "\n")
    files.write_text(out / "engine.md", "\n".join(report_lines(result, versions)) + "\n")
    return [out / "engine.csv", out / "engine.json", out / "engine.md",
            *draw(result, out / "engine", formats),
            *engine_softening.write(result, out, formats)]


def add_parser(subparsers) -> None:
    """Register ``cardan engine``."""
    p = subparsers.add_parser("engine", help="MuJoCo's constraint forces for the same line, "
                              "against the rigid solution set (CSV, PNG, Markdown)")
    p.add_argument("scene", nargs="?", default="paper", help="built-in name or TOML path")
    p.add_argument("--out", type=files.folder, default="results/engine",
                   help="output folder (default %(default)s)")
    p.add_argument("--stop", type=_stop, default=None,
                   help="simulate up to this time (s; default the scene's stop)")
    p.add_argument("--instants", type=_instants, default=6,
                   help="instants compared with the rigid set (default 6)")
    p.add_argument("--format", type=format_list, default=("png",), metavar="FORMATS",
                   help="figure formats, comma-separated: png, svg, pdf (default png)")
    p.add_argument("--engine", choices=(*ENGINES, "all"), default="mujoco",
                   help="the physics engine: mujoco (default), drake (the drake extra) "
                   "or all (every installed engine that can express the scene)")
    p.set_defaults(func=run)


def _number(text: str, kind=float):
    """``text`` as a ``kind`` (an argparse type error in one line otherwise)."""
    import argparse

    try:
        return kind(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None


def _stop(text: str) -> float:
    import argparse

    value = _number(text)
    if not 0.0 < value <= 1e6:
        raise argparse.ArgumentTypeError(f"a time in (0, 1e6] s, got {text}")
    return value


def _instants(text: str) -> int:
    import argparse

    value = _number(text, int)
    if not 2 <= value <= 1001:
        raise argparse.ArgumentTypeError(f"2 ... 1001, got {text}")
    return value


def engine_versions(engines) -> str:
    """``MuJoCo 3.x and Drake 1.y``: the installed ``engines``' names and versions."""
    found = {"mujoco": engine_mujoco.mujoco_version, "drake": engine_drake.drake_version}
    return " and ".join(f"{ENGINES[name]} {found[name]()}" for name in engines)


def run(args) -> int:
    """``cardan engine``: the study, its files, and per setting a line of agreement and
    one of the predicted member; an engine of ``--engine all`` that cannot run the
    scene said in one line on stderr.
    """
    import sys

    engines = tuple(ENGINES) if args.engine == "all" else (args.engine,)
    start = time.perf_counter()
    result = study(args.scene, args.stop, args.instants, engines=engines)
    ran = tuple(name for name in engines if ENGINES[name] not in result.skipped)
    for name, why in result.skipped.items():
        print(f"cardan engine: {name} left out: {why}", file=sys.stderr)
    paths = write(result, Path(args.out), engine_versions(ran), args.format)
    print("\n".join(agreement_lines(result) + [""] + prediction_lines(result)))
    files.say_written("engine", paths, note=f"{time.perf_counter() - start:.1f} s")
    return 0

