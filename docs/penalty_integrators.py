"""Measure the penalty simulation's integrators against each other and store the run.

    python docs/penalty_integrators.py              # 1 s of every scene, 2 runs each
    python docs/penalty_integrators.py --stop 0.2 --repeats 3
    python docs/penalty_integrators.py --page       # only rewrite the page's table

Runs :func:`~cardan_forces.driveline.penalty.simulate_penalty` on every built-in scene
the penalty simulation takes (each scene's released line, :func:`penalty.released`; a
scene refused there, or two scenes with the same released line, once) with the compiled
BDF (``BDF-numba``) and with SciPy's LSODA, BDF and Radau on the same compiled
right-hand side and Jacobian (``kernel="numba"``). Each run is repeated and its
smallest CPU time kept: the CPU time of this process over the integration
(``PenaltyResult.cpu_s``, ``time.process_time``; loading the compiled code is before
it and not counted), so other jobs on the machine slow the wall clock, not the
measure. The forces of each SciPy integrator are compared with the compiled BDF's at
the sampled instants (largest difference over the largest force) and as averages over
the window's second half.

Writes ``docs/data/penalty_integrators.json`` (the measurements with the command, the UTC
date, the machine and the versions) and rewrites the generated part of
``docs/explanation/physical.md`` (between its ``penalty-integrators`` markers) from it:
the table and the decision (:func:`decision`). The scenes refused are stored, not shown:
a new quasi-static built-in scene would stale the page. ``tests/test_penalty_integrators_page.py``
holds the page to the stored data.
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
DATA = DOCS / "data" / "penalty_integrators.json"
PAGE = DOCS / "explanation" / "physical.md"
BEGIN = "<!-- penalty-integrators: generated from docs/data/penalty_integrators.json -->"
END = "<!-- penalty-integrators: end -->"

COMPILED = "BDF-numba"
SCIPY = ("LSODA", "BDF", "Radau")
"""SciPy's integrators, each on the compiled right-hand side and Jacobian."""
TIGHTER = f"{COMPILED}, atol 1e-9"
"""The compiled BDF at a tenfold tighter tolerance (``atol_m``, default 1e-8): how far
the forces move with the tolerance alone, the yardstick of the integrators' agreement
(the rattle in the clearances makes single instants sensitive to any change)."""
RUNS = {COMPILED: (COMPILED, 1e-8), **{m: (m, 1e-8) for m in SCIPY}, TIGHTER: (COMPILED, 1e-9)}
"""Each row of the table: integrator and ``atol_m``."""
KEEP_WITHIN = 1.5
"""A simpler integrator is kept where its CPU per simulated second is within this factor
of the compiled BDF's on every scene, with no more failures."""


def _released_line(name: str) -> str | None:
    """The name of built-in scene ``name``'s released line, None where the penalty
    simulation refuses it (a quasi-static scene; a slip joint with friction).
    """
    from cardan_forces.driveline.elements.base import PENALTY_SIMULATION
    from cardan_forces.driveline.elements.registry import refusals
    from cardan_forces.driveline.loading import load_scene
    from cardan_forces.driveline.penalty import released
    from cardan_forces.driveline.scene import SceneError

    try:
        line = released(load_scene(name))
    except SceneError:
        return None
    if refusals(line, PENALTY_SIMULATION):
        return None
    return line.name


def penalty_scenes() -> dict[str, str]:
    """Every built-in scene the penalty simulation takes: released line's name -> the
    first built-in scene (by name) that gives it.
    """
    from cardan_forces.driveline.loading import builtin_names

    found: dict[str, str] = {}
    for name in builtin_names():
        line = _released_line(name)
        if line is not None:
            found.setdefault(line, name)
    return found


def refused_scenes() -> list[str]:
    """The built-in scenes whose released line the penalty simulation refuses."""
    from cardan_forces.driveline.loading import builtin_names

    return [name for name in builtin_names() if _released_line(name) is None]


def _force_matrix(result) -> np.ndarray:
    return np.array([result.forces[n] for n in sorted(result.forces)]).T  # (T, forces)


def agreement(forces: np.ndarray, reference: np.ndarray, t: np.ndarray) -> dict:
    """How far ``forces`` (T, n) are from ``reference``, each relative to the largest
    reference force: the largest difference at any sampled instant, and the largest
    difference of the averages over the window's second half.
    """
    scale = float(np.nanmax(np.abs(reference)))
    late = t >= t[0] + 0.5 * (t[-1] - t[0])
    return {"largest_force_N": scale,
            "sampled": float(np.nanmax(np.abs(forces - reference))) / scale,
            "averaged": float(np.nanmax(np.abs(forces[late].mean(axis=0)
                                               - reference[late].mean(axis=0)))) / scale}


def measure_scene(name: str, stop_s: float, repeats: int, progress=print) -> dict:
    """One scene's runs: per integrator the smallest CPU time of ``repeats`` runs of
    ``stop_s`` simulated seconds, the counts, every run's status, and the forces'
    agreement with the compiled BDF.
    """
    from cardan_forces.driveline.loading import load_scene
    from cardan_forces.driveline.penalty import released, simulate_penalty

    scene = released(load_scene(name))
    start = scene.time.start_s
    t = np.arange(start, start + stop_s + 1e-9, scene.time.step_s)
    rows, forces = {}, {}
    for row, (method, atol_m) in RUNS.items():
        runs = []
        for _ in range(repeats):
            result = simulate_penalty(scene, t, method=method, kernel="numba", atol_m=atol_m)
            runs.append(result)
            progress(f"{scene.name:28s} {row:22s} cpu {result.cpu_s:8.2f} s  "
                     f"wall {result.wall_s:8.2f} s  {result.message}")
        best = min(runs, key=lambda r: r.cpu_s)
        span = float(t[-1] - t[0])
        rows[row] = {
            "method": method, "atol_m": atol_m,
            "cpu_s": [r.cpu_s for r in runs],
            "wall_s": [r.wall_s for r in runs],
            "cpu_per_simulated_s": best.cpu_s / span,
            "failures": sum(not r.success for r in runs),
            "runs": len(runs),
            "messages": sorted({r.message for r in runs}),
            "steps": best.nsteps, "rhs": best.nfev, "jacobians": best.njev, "lu": best.nlu,
        }
        forces[row] = _force_matrix(best)
    for row in RUNS:
        if row != COMPILED:
            rows[row]["ratio"] = (rows[row]["cpu_per_simulated_s"]
                                  / rows[COMPILED]["cpu_per_simulated_s"])
            rows[row]["agreement"] = agreement(forces[row], forces[COMPILED], t)
    return {"scene": scene.name, "from": name, "simulated_s": float(t[-1] - t[0]),
            "sample_s": scene.time.step_s, "integrators": rows}


def run(stop_s: float, repeats: int) -> dict:
    """Every penalty scene measured (:func:`measure_scene`), with where and when."""
    from cardan_forces.experiments.environment import json_safe, machine, versions

    scenes = [measure_scene(source, stop_s, repeats) for source in penalty_scenes().values()]
    return json_safe({
        "command": f"python docs/penalty_integrators.py --stop {stop_s:g} --repeats {repeats}",
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "machine": machine(),
        "versions": versions() + f", numba {metadata.version('numba')}",
        "cardan_forces": metadata.version("cardan-forces"),
        "measure": "CPU time of the integrating process (time.process_time), the smaller "
                   "of the repeated runs; loading the compiled code not counted",
        "refused": refused_scenes(),
        "scenes": scenes,
    })


# ------------------------------------------------------------------------- the page


def summary(data: dict) -> dict:
    """Per SciPy integrator: the smallest and largest ratio of its CPU per simulated second
    to the compiled BDF's over the scenes, its failures and the compiled BDF's, the
    worst force agreements.
    """
    out = {}
    compiled_failures = sum(s["integrators"][COMPILED]["failures"] for s in data["scenes"])
    for method in SCIPY:
        rows = [s["integrators"][method] for s in data["scenes"]]
        out[method] = {
            "low": min(r["ratio"] for r in rows), "high": max(r["ratio"] for r in rows),
            "failures": sum(r["failures"] for r in rows),
            "runs": sum(r["runs"] for r in rows),
            "compiled_failures": compiled_failures,
            "sampled": max(r["agreement"]["sampled"] for r in rows),
            "averaged": max(r["agreement"]["averaged"] for r in rows),
        }
    tighter = [s["integrators"][TIGHTER]["agreement"] for s in data["scenes"]]
    out[TIGHTER] = {"sampled": max(a["sampled"] for a in tighter),
                    "averaged": max(a["averaged"] for a in tighter)}
    return out


def decision(data: dict) -> str:
    """The rule applied to the stored run: keep the simplest SciPy integrator (in the
    order LSODA, BDF, Radau: cheapest first) whose CPU per simulated second is within
    :data:`KEEP_WITHIN` of the compiled BDF's on every scene with no more failures;
    otherwise keep the compiled BDF, saying by how much it wins over the best of them.
    """
    table = summary(data)
    for method in SCIPY:
        s = table[method]
        if s["high"] <= KEEP_WITHIN and s["failures"] <= s["compiled_failures"]:
            return (f"**Decision: SciPy's {method} on the compiled right-hand side and "
                    f"Jacobian is enough.** It takes {s['low']:.2f} to {s['high']:.2f} "
                    f"times the compiled BDF's CPU per simulated second, within "
                    f"{KEEP_WITHIN:g}, with {s['failures']} failures in {s['runs']} runs "
                    f"(the compiled BDF {s['compiled_failures']}); its forces' averages over "
                    f"the window's second half differ from the compiled BDF's by up to "
                    f"{percent(s['averaged'])} of the largest force.")
    best = min(SCIPY, key=lambda m: table[m]["high"])
    s, tighter = table[best], table[TIGHTER]
    others = ", ".join(f"{m} {table[m]['low']:.1f} to {table[m]['high']:.1f}"
                       for m in SCIPY if m != best)
    return (f"**Decision: keep the compiled BDF.** The cheapest SciPy integrator on the same "
            f"compiled right-hand side and Jacobian, {best}, takes {s['low']:.1f} to "
            f"{s['high']:.1f} times its CPU per simulated second over the scenes, beyond "
            f"the {KEEP_WITHIN:g} allowed ({others}); failures: {s['failures']} in "
            f"{s['runs']} runs of {best}, {s['compiled_failures']} in as many of the compiled "
            f"BDF. The averages of {best}'s forces over the window's second half differ from "
            f"the compiled BDF's by up to {percent(s['averaged'])} of the largest force, "
            f"those of the compiled BDF at a tenfold tighter tolerance by up to "
            f"{percent(tighter['averaged'])}; at single instants by up to "
            f"{percent(s['sampled'])} and {percent(tighter['sampled'])}.")


def percent(fraction: float) -> str:
    """``fraction`` as a percentage: two significant digits below 10 %, whole above."""
    value = 100 * fraction
    return f"{value:.0f} %" if value >= 10 else f"{value:.2g} %"


def markdown(data: dict) -> str:
    """The generated part of the page: where and when, the table, the decision."""
    window = data["scenes"][0]["simulated_s"]
    lines = [BEGIN, "",
             f"Measured by `{data['command']}` on {data['date']}: {data['machine']}; "
             f"cardan-forces {data['cardan_forces']}, {data['versions']}. "
             f"{window:g} s simulated from rest per scene, forces sampled every "
             f"{data['scenes'][0]['sample_s']:g} s; CPU s per simulated s is the "
             f"{data['measure']}. Ratio: that CPU over the compiled BDF's on the same "
             "scene. Forces: the largest difference from the compiled BDF's over the "
             "largest force, at the sampled instants and of the averages over the "
             "window's second half. Failed: failed runs of all runs.", "",
             "| scene | integrator | CPU s per simulated s | ratio | steps | failed "
             "| forces, sampled | forces, averaged |",
             "|---|---|---:|---:|---:|---:|---:|---:|"]
    for scene in data["scenes"]:
        for method in RUNS:
            r = scene["integrators"][method]
            ratio = "1" if method == COMPILED else f"{r['ratio']:.2f}"
            agree = r.get("agreement")
            sampled = "-" if agree is None else percent(agree["sampled"])
            averaged = "-" if agree is None else percent(agree["averaged"])
            lines.append(f"| {scene['scene']} | {method} | {r['cpu_per_simulated_s']:.3g} "
                         f"| {ratio} | {r['steps']} | {r['failures']}/{r['runs']} "
                         f"| {sampled} | {averaged} |")
    lines += ["", decision(data), "", END]
    return "\n".join(lines)


def generated_part(page: str) -> str:
    """The page's text from :data:`BEGIN` to :data:`END`, both included."""
    begin, end = page.index(BEGIN), page.index(END)
    return page[begin:end + len(END)]


def write_page(data: dict, page: Path = PAGE) -> None:
    text = page.read_text()
    page.write_text(text.replace(generated_part(text), markdown(data)))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stop", type=float, default=1.0,
                        help="simulated seconds from each scene's start (default 1)")
    parser.add_argument("--repeats", type=int, default=2,
                        help="runs of each integrator, the smallest CPU time kept (>= 2)")
    parser.add_argument("--page", action="store_true",
                        help="only rewrite the page from the stored data")
    args = parser.parse_args(argv)
    if not args.page:
        if args.repeats < 2:
            parser.error("--repeats: at least 2 (the smaller CPU time is kept)")
        DATA.write_text(json.dumps(run(args.stop, args.repeats), indent=1) + "\n")
        print(f"wrote {DATA}")
    write_page(json.loads(DATA.read_text()))
    print(f"wrote {PAGE}")


if __name__ == "__main__":
    sys.exit(main())
