"""Run both physics engines on every built-in scene they express and store the run.

    python docs/engine_members.py           # every scene, its whole time grid
    python docs/engine_members.py --page    # only rewrite the page's tables

Runs ``cardan engine``'s study (:func:`cardan_forces.experiments.engine.study_operator`)
with MuJoCo (its default softness and one shaft's bearings four times softer, either
way) and Drake (SAP at its reference step; on ``paper`` at every step of
:data:`~cardan_forces.experiments.engine.DRAKE_SETTINGS` and at :data:`FINEST`) on every
built-in scene both engines express, over the scene's whole time grid, compared at :data:`INSTANTS`
evenly spaced instants. Per run and instant it stores the engine's residual of
``A x = b``, the components outside their rigid interval and the distance of the
predicted member (:mod:`cardan_forces.experiments.engine_member`) from the simulated
forces, with the rigid motion's speed; per run the wall time per simulated second.

Writes ``docs/data/engine_members.json`` (with the command, the UTC date, the machine
and the versions) and rewrites the generated part of ``docs/explanation/engines.md``
(between its ``engine-members`` markers) from it. ``tests/test_engines_page.py`` holds
the page to the stored data.
"""

from __future__ import annotations

import argparse
import datetime
import json
import sys
from importlib import metadata
from pathlib import Path

import numpy as np

DOCS = Path(__file__).resolve().parent
DATA = DOCS / "data" / "engine_members.json"
PAGE = DOCS / "explanation" / "engines.md"
BEGIN = "<!-- engine-members: generated from docs/data/engine_members.json -->"
END = "<!-- engine-members: end -->"

INSTANTS = 6
"""Evenly spaced instants of each scene's grid at which the engines are compared."""
MUJOCO = ("default", "output bearings 4x softer", "input bearings 4x softer")
"""MuJoCo's settings run (labels of :data:`~cardan_forces.experiments.engine.SETTINGS`)."""
EVERY_STEP = "paper"
"""The scene on which Drake runs at every step of its settings and at :data:`FINEST`
(elsewhere at its first)."""
FINEST = 6.25e-5
"""A step (s) finer than the study's, on :data:`EVERY_STEP`: where Drake's distance from
its predicted member goes as the step shrinks."""


def expressed() -> dict[str, str]:
    """Every built-in scene: ``""`` where both engines run it, else why not."""
    from cardan_forces.driveline.dynamics import simulate
    from cardan_forces.driveline.equilibrium import build_operator
    from cardan_forces.driveline.loading import builtin_names, load_scene
    from cardan_forces.experiments import engine
    from cardan_forces.formulations.convex import NotApplicable

    out = {}
    for name in builtin_names():
        scene = load_scene(name)
        try:
            ok, why = engine.usable(("mujoco", "drake"), scene)
            if len(ok) == 2:
                op = build_operator(simulate(scene, scene.time.instants()[:2]))
                ok, why = engine.usable(("mujoco", "drake"), scene, op)
            out[name] = "" if len(ok) == 2 else "; ".join(why.values())
        except NotApplicable as err:
            out[name] = str(err)
    return out


def measure_scene(name: str) -> dict:
    """One scene's runs and checks (module doc)."""
    from cardan_forces.driveline.dynamics import simulate
    from cardan_forces.driveline.engine_drake import Stepping
    from cardan_forces.driveline.equilibrium import build_operator
    from cardan_forces.driveline.loading import load_scene
    from cardan_forces.experiments import engine

    scene = load_scene(name)
    op = build_operator(simulate(scene, scene.time.instants()))
    finest = Stepping(FINEST, f"Drake, step {FINEST:g} s")
    drake = (*engine.DRAKE_SETTINGS, finest) if name == EVERY_STEP else engine.DRAKE_SETTINGS[:1]
    settings = [s for s in engine.SETTINGS if s.label in MUJOCO]
    result = engine.study_operator(op, INSTANTS, settings, ("mujoco", "drake"), drake)
    sampled = result.sampled
    speeds = simulate(scene, op.t[sampled]).qd
    span = float(op.t[-1] - op.t[0])
    runs = []
    for label, r in result.runs.items():
        rows = [c for c in result.comparisons if c.setting == label]
        runs.append({
            "engine": engine.engine_of(r), "setting": label, "step_s": r.timestep_s,
            "wall_s_per_simulated_s": r.wall_s / span,
            "instants": [{"t": c.t, "settled": bool(s), "residual": c.residual,
                          "predicted_distance": c.predicted_error, "outside": len(c.outside)}
                         for c, s in zip(rows, result.settled)]})
    return {"scene": name, "simulated_s": span, "t": op.t[sampled].tolist(),
            "speed_rad_s": np.asarray(speeds, float).tolist(), "runs": runs}


def run() -> dict:
    """Every scene both engines express measured, with where and when."""
    from cardan_forces.experiments.engine import engine_versions
    from cardan_forces.experiments.environment import json_safe, machine, versions

    found = expressed()
    return json_safe({
        "command": "python docs/engine_members.py",
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "machine": machine(),
        "versions": f"{versions()}, {engine_versions(('mujoco', 'drake'))}",
        "cardan_forces": metadata.version("cardan-forces"),
        "refused": {n: why for n, why in found.items() if why},
        "scenes": [measure_scene(n) for n, why in found.items() if not why],
    })


# ------------------------------------------------------------------------- the page


def worst(run: dict, key: str) -> float:
    """The largest ``key`` over a run's settled instants."""
    return max(i[key] for i in run["instants"] if i["settled"])


def _g(value: float) -> str:
    return f"{value:.2g}"


def matches(run: dict) -> bool:
    return verdict(run) == "yes"


def verdict(run: dict) -> str:
    """``cardan engine``'s verdict (:func:`cardan_forces.experiments.engine.verdict`) on
    a stored run's settled instants.
    """
    from cardan_forces.experiments.engine import InstantComparison
    from cardan_forces.experiments.engine import verdict as judged

    return judged([InstantComparison(run["setting"], i["t"], i["residual"], 0.0, (),
                                     ("-", 0.0), i["predicted_distance"])
                   for i in run["instants"] if i["settled"]])


def _setting(run: dict) -> str:
    """A run's setting as the page writes it (a Drake step in seconds)."""
    return f"step {run['step_s']:.3g} s" if run["engine"] == "Drake" else run["setting"]


def note(scene: dict) -> list[str]:
    """Per run that misses the rule: up to which instant it holds, and how the distance
    and the residual at the last instant go with Drake's step (generated words).
    """
    from cardan_forces.experiments.engine import PREDICTION_RTOL

    lines = []
    missed = [r for r in scene["runs"] if not matches(r)]
    for r in missed:
        held = [(t, v) for t, v, i in zip(scene["t"], scene["speed_rad_s"], r["instants"])
                if i["settled"] and i["predicted_distance"] <= PREDICTION_RTOL]
        upto = (f"within {PREDICTION_RTOL:.0%} up to t = {held[-1][0]:g} s "
                f"({held[-1][1]:.3g} rad/s)" if held else f"beyond {PREDICTION_RTOL:.0%} at "
                "every settled instant")
        lines.append(f"- {scene['scene']}, {r['engine']} at {_setting(r)}: {upto}; at "
                     f"t = {scene['t'][-1]:g} s ({scene['speed_rad_s'][-1]:.3g} rad/s) the "
                     f"distance is {_g(r['instants'][-1]['predicted_distance'])}, its "
                     f"residual of A x = b {_g(r['instants'][-1]['residual'])}.")
    drake = sorted((r for r in scene["runs"] if r["engine"] == "Drake"),
                   key=lambda r: r["step_s"])
    if missed and len(drake) > 1:
        last = [r["instants"][-1] for r in drake]
        shrink = all(a["predicted_distance"] < b["predicted_distance"] and
                     a["residual"] < b["residual"] for a, b in zip(last, last[1:]))
        steps = ", ".join(f"{r['step_s']:.3g} s" for r in drake)
        lines.append(f"- At the last instant, over Drake's steps {steps}: distance "
                     + ", ".join(_g(i["predicted_distance"]) for i in last) + "; residual "
                     + ", ".join(_g(i["residual"]) for i in last) + ". "
                     + ("Both shrink with the step." if shrink
                        else "They do not both shrink with the step."))
    return lines


def markdown(data: dict) -> str:
    """The generated part of the page: where and when, the table, the notes."""
    from cardan_forces.experiments.engine import PREDICTION_RTOL

    lines = [BEGIN, "",
             f"Measured by `{data['command']}` on {data['date']}: {data['machine']}; "
             f"cardan-forces {data['cardan_forces']}, {data['versions']}. Each scene's "
             f"whole time grid simulated from its start, compared at {INSTANTS} evenly "
             "spaced instants, those after the engines' settling counted. Residual: "
             "`||A x - b|| / ||b||` of the engine's forces; distance: "
             "`||x_predicted - x_engine|| / ||x_engine||`; matches: distance within "
             f"{PREDICTION_RTOL:.0%} at every counted instant, or where not, whether within "
             "the engine's residual at the instant; wall time per simulated second of one "
             "run.", "",
             "| scene | engine | setting | largest residual | largest distance | matches "
             "| outside the rigid set | wall s per simulated s |",
             "|---|---|---|---:|---:|---|---:|---:|"]
    for scene in data["scenes"]:
        for r in scene["runs"]:
            outside = sum(i["outside"] for i in r["instants"] if i["settled"])
            lines.append(f"| {scene['scene']} | {r['engine']} | {_setting(r)} | "
                         f"{_g(worst(r, 'residual'))} | {_g(worst(r, 'predicted_distance'))} "
                         f"| {verdict(r)} | {outside} | "
                         f"{r['wall_s_per_simulated_s']:.3g} |")
    notes = [line for scene in data["scenes"] for line in note(scene)]
    if notes:
        lines += ["", "Where a prediction misses:", "", *notes]
    return "\n".join(lines + ["", END])


def generated_part(page: str) -> str:
    """The page's text from :data:`BEGIN` to :data:`END`, both included."""
    begin, end = page.index(BEGIN), page.index(END)
    return page[begin:end + len(END)]


def write_page(data: dict, page: Path = PAGE) -> None:
    text = page.read_text()
    page.write_text(text.replace(generated_part(text), markdown(data)))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--page", action="store_true",
                        help="only rewrite the page from the stored data")
    args = parser.parse_args(argv)
    if not args.page:
        DATA.write_text(json.dumps(run(), indent=1) + "\n")
        print(f"wrote {DATA}")
    write_page(json.loads(DATA.read_text()))
    print(f"wrote {PAGE}")


if __name__ == "__main__":
    sys.exit(main())
