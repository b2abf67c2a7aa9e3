"""``cardan hard``: the hard-case stability suite (DESIGN §4).

Every case is a variant of one scene, the built-in ``paper`` by default or any scene
given (:data:`CASES`, one table); a case changes the scene's own shafts and joints
(every joint, every middle shaft), so it applies to any chain. A variant the scene
limits refuse (a heavy line made 1e6 times heavier) does not apply to that scene and
is reported so, with the reason.
For each case x formulation x backend the suite solves a short window of instants
(one :class:`~cardan_forces.experiments.study.History` each) and reports, per backend:
the worst status, the worst residuals over the window, a NaN check, and how
continuous the selected forces are in time: the **max jump** =
``max_i max_j |x_{i+1,j} - x_{i,j}| / max_{i,j} |x_{i,j}|`` over the operator's
contact forces, the largest step between neighbouring instants relative to the
largest force of the window (``inf`` when an instant has no forces).

A case x formulation passes when at every instant some backend's record is solved
with an equilibrium residual at or below :func:`bar` of the tolerance asked for.
Formulations that genuinely cannot handle a case are listed once, with the reason, in
:data:`KNOWN_FAILURES`; their failures are records like any other.
"""

from __future__ import annotations

import csv
import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.elements.registry import JOINT_KINDS
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.driveline.scene import Scene, SceneError, TorqueLaw
from cardan_forces.experiments import files, progress
from cardan_forces.experiments.arguments import formulation_name
from cardan_forces.experiments.environment import json_number, json_text, number_text
from cardan_forces.experiments.study import History, solve_over_time
from cardan_forces.formulations import BASELINE, FORMULATIONS, default_backends
from cardan_forces.formulations.convex import NotApplicable as NotApplicableProblem
from cardan_forces.solvers import ACCEPT, Residuals, backends_for

TOL = 1e-8
"""Tolerance asked of every backend (``--tol``). Tighter asks find out the solvers, not
the cases: at 1e-9 and below Clarabel reports ``AlmostSolved`` on a third of the
``min_max`` instants (package residuals ~1e-12), so those records are ``inaccurate``."""

BAR_FACTOR = 100.0
"""The pass bar is this many times the tolerance asked for. A solver stops on its own
measures (absolute, on its own scaling of the problem); the package measures
``||Ax - b|| / ||b||`` on the forces. The two differ by the problem's scaling and
conditioning, so a bar at the tolerance itself sits at the solver's last digits (a
``compliance`` record at 4e-8 after a 1e-8 ask); two decades above it do not."""


def bar(tol: float | None) -> float:
    """The equilibrium residual a case x formulation must meet at every instant:
    :data:`BAR_FACTOR` x ``tol``, at most the acceptance level of a solved record
    (:data:`~cardan_forces.solvers.record.ACCEPT`, also the bar of a run at the
    solvers' own defaults, ``tol=None``).
    """
    return ACCEPT if tol is None else min(BAR_FACTOR * tol, ACCEPT)

INSTANTS, QUICK_INSTANTS = 11, 6
"""Instants per window; the quick ones are every other full one."""

QUICK_SOLVERS = default_backends()
"""The reduced backend set of ``--quick``: every formulation's default backends."""


Changes = Callable[[Scene], dict]
"""A case's changes of a scene: ``Scene`` field -> new value (for ``Scene.with_changes``)."""


def _joints(**fields) -> Changes:
    """Every joint with ``fields`` changed (a value, or a list: joint ``k`` takes item
    ``min(k, len - 1)``, so ``[10, 40]`` puts the first joint at 10 and the others at 40).
    """
    def build(scene: Scene) -> dict:
        return {"joints": tuple(
            dataclasses.replace(j, **{f: v[min(k, len(v) - 1)] if isinstance(v, list) else v
                                      for f, v in fields.items()})
            for k, j in enumerate(scene.joints))}
    return build


def _mass_ratio(ratio: float) -> Changes:
    """The middle shafts' (all but the first and the last; the intermediate shaft in
    ``paper``) mass and all their principal moments times ``ratio``.
    """
    def build(scene: Scene) -> dict:
        last = len(scene.shafts) - 1
        return {"shafts": tuple(
            s if k in (0, last) else dataclasses.replace(
                s, mass_kg=ratio * s.mass_kg, inertia_kg_m2=tuple(ratio * j for j in
                                                                 s.inertia_kg_m2))
            for k, s in enumerate(scene.shafts))}
    return build


def _stiffness_ratio(ratio: float) -> Changes:
    """Bearing stiffness = ``ratio`` x the joints' linear (secant) Hertz stiffness, the
    one the ``compliance`` formulation uses (K d_max^(n-1)).
    """
    def build(scene: Scene) -> dict:
        stiffness = [k for j in scene.joints
                     if (k := JOINT_KINDS[j.kind].secant_stiffness(j, scene)) is not None]
        if not stiffness:
            raise SceneError(f"scene {scene.name}: its joints have no contact stiffness "
                             "to set the bearings' against")
        return {"contact": dataclasses.replace(scene.contact,
                                               bearing_stiffness_N_m=ratio * float(stiffness[0]))}
    return build


def _clearance(gap_m: float) -> Changes:
    """Radial, axial and bearing clearances all ``gap_m``, the ``clearance`` effect on."""
    def build(scene: Scene) -> dict:
        return {"joints": tuple(JOINT_KINDS[j.kind].with_clearance(j, gap_m)
                                for j in scene.joints),
                "effects": scene.effects | {"clearance"},
                "contact": dataclasses.replace(scene.contact, bearing_clearance_m=gap_m)}
    return build


def _fixed(**changes) -> Changes:
    return lambda scene: changes


def _huge_torque(scene: Scene) -> dict:
    """1e6 N m through the line: the mean of a harmonic input, or a constant one."""
    harmonic = scene.input_torque.amplitude_N_m != 0 or scene.input_torque.frequency_hz != 0
    drive = dataclasses.replace(scene.input_torque, mean_N_m=1e6) if harmonic else \
        TorqueLaw(1e6)
    return {"input_torque": drive, "load_torque": TorqueLaw(1e6)}


NO_TORQUE = TorqueLaw(0.0)


@dataclass(frozen=True)
class Case:
    """A hard case: ``changes(scene)`` gives the fields that replace the base scene's;
    instants are spread over ``[start, start + stop_s]``.
    """

    name: str
    what: str  # ``{joints}`` stands for the base scene's joints in words
    changes: Changes
    stop_s: float = 0.5

    def describe(self, n_joints: int = 2) -> str:
        """What the case does, in words, for a scene of ``n_joints`` joints."""
        joints = {1: "the joint", 2: "both joints"}.get(n_joints, f"all {n_joints} joints")
        return self.what.format(joints=joints)

    def scene(self, base: str = "paper") -> Scene:
        """The variant of scene ``base`` (validated again: SceneError if it is none)."""
        scene = load_scene(base)
        return scene.with_changes(name=f"hard-{self.name}", **self.changes(scene))


CASES = (
    Case("base", "the scene as it is (what the variants are measured against)", _fixed()),
    Case("articulation-0", "{joints} straight (0 deg)",
         _joints(articulation_deg=0.0)),
    Case("articulation-1e-6rad", "{joints} at 1e-6 rad (in degrees)",
         _joints(articulation_deg=math.degrees(1e-6))),
    Case("articulation-89", "{joints} at 89 deg", _joints(articulation_deg=89.0)),
    Case("W", "W arrangement (input and output not parallel)", _fixed(arrangement="W")),
    Case("unequal-10-40", "joint angles 10 and 40 deg (the first 10, the others 40)",
         _joints(articulation_deg=[10.0, 40.0])),
    Case("torque-0", "no input torque: at rest under gravity",
         _fixed(input_torque=NO_TORQUE)),
    Case("torque-1e6", "1e6 N m mean input torque against a 1e6 N m load (transmitted)",
         _huge_torque),
    Case("mass-1e6", "middle shafts' mass and inertia x 1e6", _mass_ratio(1e6)),
    Case("mass-1e-6", "middle shafts' mass and inertia x 1e-6", _mass_ratio(1e-6)),
    Case("stiffness-1e6", "bearing stiffness 1e6 x the joints' (compliance)",
         _stiffness_ratio(1e6)),
    Case("stiffness-1e-6", "bearing stiffness 1e-6 x the joints' (compliance)",
         _stiffness_ratio(1e-6)),
    Case("clearance-1e-7", "all clearances 1e-7 m, clearance effect on", _clearance(1e-7)),
    Case("clearance-2mm", "all clearances 2 mm, clearance effect on", _clearance(2e-3)),
    Case("surface-contact", "quasi-static, gravity only, no torque: theta1 = theta2",
         _fixed(effects=frozenset({"gravity"}), input_torque=NO_TORQUE,
                initial_speed_rad_s=1.0)),
    Case("gravity-horizontal", "gravity +9.8 m/s^2 along +y, normal to the articulation plane",
         _fixed(gravity_m_s2=(0.0, 9.8, 0.0))),
    Case("speed-1000", "initial speed 1000 rad/s (instants over 0.002 s: 0.2 rad apart)",
         _fixed(initial_speed_rad_s=1000.0), stop_s=0.002),
)

_RANK = "its 34x34 Jacobian is singular everywhere (rank 33 of 34, the closed loop)"

KNOWN_FAILURES: dict[tuple[str, str], str] = {
    ("base", BASELINE): "the paper's 34 equations are singular where a trunnion pair "
        "carries no radial load (gravity along the input shaft at rest, in "
        "paper-fig15-axial): eq. 33 is 0/0 there, fsolve and root(lm) stall",
    ("torque-0", BASELINE): "with no torque the driving trunnions of uj1 carry no radial "
        "load, so their contact angles, and with them the rim points of eqs. 33-36, are "
        "0/0; fsolve reports 'converged' far from equilibrium and root(lm) stalls; " + _RANK,
    ("surface-contact", BASELINE): "theta1 = theta2 makes eq. 33 divide by zero; fsolve "
        "makes no progress and root(lm) stalls",
    ("articulation-89", BASELINE): "at 89 deg the Jacobian's condition reaches 1e18-1e19; "
        "fsolve makes no progress at the first instants and root(lm) stalls; " + _RANK,
    ("mass-1e6", BASELINE): "with the intermediate shaft 1e6 times heavier the Jacobian "
        "loses rank (27-29 of 34) and the residual stalls above the bar",
}
"""``(case, formulation) -> reason`` where no backend gives a solved record at every
instant; each was checked against the reduced (``--quick``) backend set. The residuals
a run reached are quoted from its own table, next to the reason.
"""


@dataclass(frozen=True)
class Run:
    """One case x formulation x backend: its history over the case's window."""

    case: str
    history: History

    @property
    def formulation(self) -> str:
        return self.history.formulation

    @property
    def solver(self) -> str:
        return self.history.solver

    @property
    def t(self) -> tuple[float, ...]:
        return tuple(float(t) for t in self.history.t)

    @property
    def records(self):
        return self.history.records

    @property
    def status(self) -> str:
        """The worst status over the window."""
        return self.history.status

    @property
    def n_solved(self) -> int:
        return self.history.solved

    @property
    def nan_free(self) -> bool:
        """Whether every record that claims forces has finite ones."""
        return bool(np.all(np.isfinite(self.history.answers())
                           | ~self._answered()[:, None]))

    def _answered(self) -> np.ndarray:
        return np.array([r.status.has_answer for r in self.records], bool)

    def worst(self) -> dict[str, float]:
        """The largest of each residual over the window (``inf`` if an instant failed)."""
        return self.history.worst(Residuals.KEYS)

    def jumps(self) -> np.ndarray:
        """Per instant step from the previous one, relative (see the module's max jump)."""
        return self.history.jumps()

    @property
    def max_jump(self) -> float:
        return float(self.jumps().max(initial=0.0))

    def to_json(self) -> dict:
        """The JSON entry of ``--json``: ``forces`` at the window's middle instant."""
        middle = len(self.records) // 2
        return {
            "case": self.case, "formulation": self.formulation, "solver": self.solver,
            "status": str(self.status), "solved": f"{self.n_solved}/{len(self.records)}",
            "residuals": {k: json_number(v) for k, v in self.worst().items()},
            "t_forces": self.t[middle],
            "forces": {k: json_number(v) for k, v in self.records[middle].forces().items()},
            "max_jump": json_number(self.max_jump), "nan_free": self.nan_free,
        }


@dataclass(frozen=True)
class NotApplicable:
    """A case the base scene's limits refuse: its variant is no valid scene."""

    case: str
    reason: str


def run_case(case: Case, formulations=None, solvers=None, instants: int = INSTANTS,
             tol: float | None = TOL, base: str = "paper", scene: Scene | None = None
             ) -> list[Run]:
    """Solve ``case`` (a variant of scene ``base``) at ``instants`` instants over its
    window with every requested formulation and backend (``None``: all), one history
    per formulation x backend (``scene``: the variant, when made already). Raises
    :class:`SceneError` when the variant is no valid scene (see :func:`applies`).
    """
    scene = scene or case.scene(base)
    t = scene.time.start_s + np.linspace(0.0, case.stop_s, instants)
    op = build_operator(simulate(scene, t))
    runs = []
    for formulation in formulations or FORMULATIONS:
        try:  # built once, shared by the backends
            problems = [FORMULATIONS[formulation](op, i) for i in range(len(t))]
        except NotApplicableProblem:
            if formulations:
                raise
            continue  # not called for by this scene (e.g. friction without friction)
        usable = backends_for(problems[0])
        for solver in usable if solvers is None else [s for s in solvers if s in usable]:
            runs.append(Run(case.name, solve_over_time(op, formulation, solver, tol=tol,
                                                       problem=problems.__getitem__)))
    return runs


def applies(case: Case, base: str) -> Scene | NotApplicable:
    """The variant ``case`` makes of scene ``base``, or why it does not apply."""
    try:
        return case.scene(base)
    except SceneError as err:
        return NotApplicable(case.name, " ".join(str(err).split()))


def covered(runs: list[Run], tol: float | None = TOL) -> bool:
    """Whether at every instant some backend's record is solved with an equilibrium
    residual at or below :func:`bar` of ``tol`` (``runs``: one case x formulation).
    """
    return not uncovered(runs, tol)


def uncovered(runs: list[Run], tol: float | None = TOL) -> list[str]:
    """Why each instant no backend covers fails, in words: its time and the closest
    record (backend, status, equilibrium residual against the bar).
    """
    return [why for _, why in _misses(runs, tol)]


def _misses(runs: list[Run], tol: float | None) -> list[tuple[float, str]]:
    limit, out = bar(tol), []

    def equilibrium(r) -> float:
        return r.residuals.get("equilibrium", math.inf)

    for t, records in zip(runs[0].t, zip(*(run.records for run in runs))):
        if any(r.solved and equilibrium(r) <= limit for r in records):
            continue
        best = min(records, key=lambda r: (not r.solved, equilibrium(r)))
        out.append((t, f"t={t:.4g} s: best {best.solver} {best.status}, equilibrium "
                       f"{number_text(equilibrium(best), '.1e')} > {limit:.0e}"))
    return out


def summarize(runs: list[Run], tol: float | None = TOL) -> list[dict]:
    """One row per case x formulation: the best backend (most instants solved, then
    the smallest worst residual), its worst residual and max jump, the NaN check over
    all backends, the backends that failed somewhere, why instants are not covered,
    and the verdict.
    """
    groups: dict[tuple[str, str], list[Run]] = {}
    for run in runs:
        groups.setdefault((run.case, run.formulation), []).append(run)
    misses = {key: _misses(group, tol) for key, group in groups.items()}
    times = {key: {round(t, 12) for t, _ in found} for key, found in misses.items()}
    base = {f: found for (c, f), found in times.items() if c == "base"}
    rows = []
    for (case, formulation), group in groups.items():
        best = min(group, key=lambda r: (-r.n_solved, max(r.worst().values())))
        why, missed = [w for _, w in misses[case, formulation]], times[case, formulation]
        rows.append({
            "case": case, "formulation": formulation, "best": best.solver,
            "solved": f"{best.n_solved}/{len(best.records)}",
            "worst_residual": max(best.worst().values()), "max_jump": best.max_jump,
            "nan_free": all(r.nan_free for r in group),
            "failing": [f"{r.solver} ({r.status})" for r in group if r.status != "solved"],
            "covered": not why, "why": why, "known": KNOWN_FAILURES.get((case, formulation)),
            "inherited": case != "base" and bool(missed) and missed <= base.get(formulation, set()),
        })
    return rows


def _verdict(row: dict) -> str:
    if row["covered"]:
        return "ok" if row["known"] is None else "ok (known failure passed)"
    if row["known"]:
        return "known failure"
    return "fails as the scene does" if row["inherited"] else "FAIL"


def _known_note(row: dict) -> str:
    """A known failure's reason with the residuals of this run's table."""
    return (f"{row['known']}; this run: best {row['best']} solved {row['solved']}, worst "
            f"residual {number_text(row['worst_residual'], '.1e')}")


# ---------------------------------------------------------------------------- output


def _table(rows: list[dict]) -> list[str]:
    lines = [f"{'case':22s} {'formulation':16s} {'best backend':22s} {'solved':>6s} "
             f"{'worst res':>9s} {'max jump':>9s} {'NaN-free':>8s}  verdict"]
    for row in rows:
        lines.append(f"{row['case']:22s} {row['formulation']:16s} {row['best']:22s} "
                     f"{row['solved']:>6s} {number_text(row['worst_residual'], '9.1e')} "
                     f"{number_text(row['max_jump'], '9.2e')} "
                     f"{'yes' if row['nan_free'] else 'NO':>8s}  {_verdict(row)}")
    return lines


def write_csv(runs: list[Run], path: Path) -> None:
    """Long format: one row per case x formulation x backend x instant; a failed
    solve is a row with empty residual cells (undefined); ``jump`` is the step from the
    previous instant, empty next to an instant without forces.
    """
    with files.replacing(path, newline="") as f:
        w = csv.writer(f)
        w.writerow(["case", "formulation", "solver", "t_s", "status", *Residuals.KEYS, "jump",
                    "time_s", "message"])
        for run in runs:
            for ti, r, jump in zip(run.t, run.records, run.jumps()):
                w.writerow([run.case, run.formulation, run.solver, f"{ti:.6g}", r.status,
                            *(number_text(r.residuals[k], ".3e", "") for k in Residuals.KEYS),
                            number_text(jump, ".3e", ""),
                            f"{r.setup_s + r.solve_s:.3e}", r.message])


def write_md(rows: list[dict], path: Path, settings: str, cases: list[Case],
             skipped: list[NotApplicable], n_joints: int) -> None:
    """The Markdown report: cases, the summary table, known and unexpected failures,
    cases that do not apply to the scene.
    """
    lines = ["# Hard cases", "", settings, "",
             "## Cases (variants of the base scene)", "", "| case | what | window (s) |",
             "|---|---|---|"]
    lines += [f"| {c.name} | {c.describe(n_joints)} | 0 .. {c.stop_s:g} |" for c in cases]
    lines += ["", "## Case x formulation: the best backend", "",
              "| case | formulation | best backend | solved | worst residual | max jump | "
              "NaN-free | verdict | backends failing somewhere |", "|---" * 9 + "|"]
    lines += [f"| {r['case']} | {r['formulation']} | {r['best']} | {r['solved']} | "
              f"{number_text(r['worst_residual'], '.1e')} | "
              f"{number_text(r['max_jump'], '.2e')} | "
              f"{'yes' if r['nan_free'] else 'NO'} | {_verdict(r)} | "
              f"{', '.join(r['failing']) or '-'} |" for r in rows]
    lines += ["", "## Known failures", ""]
    lines += [f"- **{r['case']} / {r['formulation']}**: {_known_note(r)}" for r in rows
              if r["known"]] or ["none in this run"]
    lines += ["", "## Failures the base scene has too", ""]
    lines += [f"- **{r['case']} / {r['formulation']}**: {'; '.join(r['why'])}" for r in rows
              if _verdict(r) == "fails as the scene does"] or ["none"]
    lines += ["", "## Unexpected failures", ""]
    lines += [f"- **{r['case']} / {r['formulation']}**: {'; '.join(r['why'])}" for r in rows
              if _verdict(r) == "FAIL"] or ["none"]
    lines += ["", "## Cases that do not apply to this scene", ""]
    lines += [f"- **{c.case}**: {c.reason}" for c in skipped] or ["none"]
    files.write_text(path, "\n".join([*lines, ""]))


# ---------------------------------------------------------------------------- CLI


def add_parser(subparsers) -> None:
    """Register ``cardan hard``."""
    p = subparsers.add_parser("hard", help="hard-case stability suite (every formulation x "
                              "backend on extreme variants of a scene, paper by default)")
    p.add_argument("scene", nargs="?", default="paper", help="built-in name or TOML path")
    p.add_argument("--case", action="append", choices=[c.name for c in CASES],
                   help="one case (repeatable); default all")
    p.add_argument("--formulation", action="append", type=formulation_name,
                   choices=list(FORMULATIONS),
                   help="one formulation (repeatable); default all")
    p.add_argument("--solver", action="append",
                   help="one backend (repeatable); default all (--quick: a reduced set)")
    p.add_argument("--tol", type=float, default=TOL,
                   help=f"tolerance for every backend (default {TOL:g})")
    p.add_argument("--quick", action="store_true",
                   help=f"{QUICK_INSTANTS} instants, backends {', '.join(QUICK_SOLVERS)}")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.add_argument("--out", type=files.folder, help="folder for hard.csv and hard.md "
                                 "(default: none, the table on stdout only)")
    p.set_defaults(func=run)


def run(args) -> int:
    """Run the suite; text summary (or JSON) on stdout, progress on stderr; 1 when a
    case x formulation fails that is no known failure (stdout says which and why).
    """
    scene = load_scene(args.scene)  # a bad scene: one message before any work
    cases = [c for c in CASES if not args.case or c.name in args.case]
    solvers = args.solver or (list(QUICK_SOLVERS) if args.quick else None)
    instants = QUICK_INSTANTS if args.quick else INSTANTS
    runs, skipped = [], []
    for k, case in enumerate(progress.bar(cases, "hard", unit="case"), 1):
        progress.line(f"hard: case {k}/{len(cases)} {case.name}")
        variant = applies(case, args.scene)
        if isinstance(variant, NotApplicable):
            skipped.append(variant)
            continue
        runs += run_case(case, args.formulation, solvers, instants, args.tol, args.scene,
                         variant)
    rows = summarize(runs, args.tol)
    settings = (f"{instants} instants per window, tolerance {args.tol:g}, backends: "
                f"{', '.join(solvers) if solvers else 'all available'}; forces judged by the "
                f"package; pass = every instant solved with equilibrium <= {bar(args.tol):.0e} "
                f"({BAR_FACTOR:g} x the tolerance); max jump = largest change of a force "
                "between neighbouring instants / largest force of the window")
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        write_csv(runs, out / "hard.csv")
        write_md(rows, out / "hard.md", settings, cases, skipped, len(scene.joints))
        files.say_written("hard", [out / "hard.csv", out / "hard.md"])
    failed = 1 if any(_verdict(r) == "FAIL" for r in rows) else 0  # unexpected failures
    if args.json:
        print(json_text({"cases": [r.to_json() for r in runs],
                         "not_applicable": [dataclasses.asdict(c) for c in skipped],
                         "failed": [{"case": r["case"], "formulation": r["formulation"],
                                     "why": r["why"]} for r in rows
                                    if _verdict(r) == "FAIL"]}))
        return failed
    print(settings)
    print("\n".join(_table(rows)))
    for r in rows:  # the known failures of the rows this run made, not of every scene
        if r["known"]:
            print(f"known failure {r['case']} / {r['formulation']}: {_known_note(r)}")
    for r in rows:
        if _verdict(r) == "fails as the scene does":
            print(f"fails as the scene does {r['case']} / {r['formulation']}: "
                  f"{'; '.join(r['why'])} (the base case fails at these instants too)")
    for c in skipped:
        print(f"does not apply {c.case}: {c.reason}")
    for r in rows:
        if _verdict(r) == "FAIL":
            print(f"FAIL {r['case']} / {r['formulation']}: {'; '.join(r['why'])}")
    return failed
