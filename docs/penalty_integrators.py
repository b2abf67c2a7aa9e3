"""Measure the penalty simulation's integrators against each other and store the run.

    python docs/penalty_integrators.py              # 1 s of every scene, 2 runs each
    python docs/penalty_integrators.py --stop 0.2 --repeats 3
    python docs/penalty_integrators.py --scipy-on all   # SciPy on every scene: long
    python docs/penalty_integrators.py --page       # only rewrite the page's table

Runs :func:`~cardan_forces.driveline.penalty.simulate_penalty` on every built-in scene
(:func:`~cardan_forces.driveline.loading.builtin_names`), each as its released line
(:func:`penalty.released`): a quasi-static scene through its dynamic counterpart,
:meth:`Scene.in_motion` (the scene with the ``inertia`` effect added), so that every
built-in scene is run; two scenes with the same released line once, a line whose kinds
the penalty simulation refuses not at all (stored as refused).

On every scene the compiled BDF (``BDF-numba``) runs, and again at a tenfold tighter
tolerance. SciPy's LSODA, BDF and Radau, on the same compiled right-hand side and
Jacobian (``kernel="numba"``), run where ``--scipy-on`` says: by default ``dynamic``,
the built-in scenes that are dynamic as defined (not a quasi-static scene's
counterpart). The counterparts cost the compiled BDF many times paper-penalty's CPU per
simulated second (the table's column), and SciPy's BDF and Radau many times the
compiled BDF, so on the counterparts they would dominate the run (the decision says by
how much at the measured ratios). The rule goes by kind, not cost, so the run's length
is known before it starts. ``all`` runs them everywhere, ``none`` nowhere.

Each run is repeated and its smallest CPU time kept: the CPU time of this process over
the integration (``PenaltyResult.cpu_s``, ``time.process_time``; loading the compiled
code is before it and not counted), so other jobs on the machine slow the wall clock,
not the measure. The forces of each SciPy integrator are compared with the compiled BDF's at
the sampled instants (largest difference over the largest force) and as averages over
the window's second half.

Writes ``docs/data/penalty_integrators.json`` (the measurements with the command, the UTC
date, the machine and the versions) and rewrites the generated part of
``docs/explanation/physical.md`` (between its ``penalty-integrators`` markers) from it:
the table and the decision (:func:`decision`), which weighs SciPy's integrators on the
scenes they ran on. The scenes refused are stored, not shown.
``tests/test_penalty_integrators_page.py`` holds the page to the stored data.
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
ALWAYS = (COMPILED, TIGHTER)
"""The rows run on every scene; SciPy's (:data:`SCIPY`) where affordable."""
SCIPY_ON = {"dynamic": "the dynamic built-in scenes", "all": "every scene", "none": "no scene"}
"""The choices of ``--scipy-on`` (the first the default): where SciPy's integrators run."""
KEEP_WITHIN = 1.5
"""A simpler integrator is kept where its CPU per simulated second is within this factor
of the compiled BDF's on every scene, with no more failures."""


def released_line(name: str):
    """Built-in scene ``name``'s released line: a quasi-static scene's through its
    dynamic counterpart (:meth:`Scene.in_motion`, inertia added).
    """
    from cardan_forces.driveline.loading import load_scene
    from cardan_forces.driveline.penalty import released

    return released(load_scene(name).in_motion())


def quasi_static(name: str) -> bool:
    """Whether built-in scene ``name`` is quasi-static (runs as its dynamic counterpart)."""
    from cardan_forces.driveline.loading import load_scene

    return not load_scene(name).has("inertia")


def _released_line(name: str) -> str | None:
    """The name of built-in scene ``name``'s released line (:func:`released_line`), None
    where the penalty simulation refuses it (a kind it has no model for).
    """
    from cardan_forces.driveline.elements.base import PENALTY_SIMULATION
    from cardan_forces.driveline.elements.registry import refusals
    from cardan_forces.driveline.scene import SceneError

    try:
        line = released_line(name)
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


def scipy_runs_on(name: str, scipy_on: str) -> bool:
    """Whether SciPy's integrators run on built-in scene ``name`` (:data:`SCIPY_ON`)."""
    if scipy_on not in SCIPY_ON:
        raise ValueError(f"scipy_on {scipy_on!r}; one of {', '.join(SCIPY_ON)}")
    return scipy_on == "all" or (scipy_on == "dynamic" and not quasi_static(name))


def measure_scene(name: str, stop_s: float, repeats: int, scipy: bool = True,
                  progress=print) -> dict:
    """One scene's runs: per integrator the smallest CPU time of ``repeats`` runs of
    ``stop_s`` simulated seconds, the counts, every run's status, and the forces'
    agreement with the compiled BDF. The compiled BDF's rows (:data:`ALWAYS`), and
    SciPy's (:data:`SCIPY`) where ``scipy``.
    """
    from cardan_forces.driveline.penalty import simulate_penalty

    scene = released_line(name)
    start = scene.time.start_s
    t = np.arange(start, start + stop_s + 1e-9, scene.time.step_s)
    span = float(t[-1] - t[0])
    rows, forces = {}, {}
    for row in RUNS:
        if row not in ALWAYS and not scipy:
            continue
        method, atol_m = RUNS[row]
        runs = []
        for _ in range(repeats):
            result = simulate_penalty(scene, t, method=method, kernel="numba", atol_m=atol_m)
            runs.append(result)
            progress(f"{scene.name:28s} {row:22s} cpu {result.cpu_s:8.2f} s  "
                     f"wall {result.wall_s:8.2f} s  {result.message}")
        best = min(runs, key=lambda r: r.cpu_s)
        rows[row] = {
            "method": method, "atol_m": atol_m,
            "cpu_s": [r.cpu_s for r in runs],
            "wall_s": [r.wall_s for r in runs],
            "cpu_per_simulated_s": best.cpu_s / span,
            "failures": sum(not r.success for r in runs),
            "runs": len(runs),
            "messages": sorted({r.message for r in runs}),
            "statuses": sorted({int(r.status) for r in runs}),
            "steps": best.nsteps, "rhs": best.nfev, "jacobians": best.njev, "lu": best.nlu,
        }
        forces[row] = _force_matrix(best)
    for row in rows:
        if row != COMPILED:
            rows[row]["ratio"] = (rows[row]["cpu_per_simulated_s"]
                                  / rows[COMPILED]["cpu_per_simulated_s"])
            rows[row]["agreement"] = agreement(forces[row], forces[COMPILED], t)
    return {"scene": scene.name, "from": name, "quasi_static": quasi_static(name),
            "simulated_s": span, "sample_s": scene.time.step_s,
            "scipy": scipy, "integrators": rows}


def run(stop_s: float, repeats: int, scipy_on: str = next(iter(SCIPY_ON))) -> dict:
    """Every penalty scene measured (:func:`measure_scene`), SciPy's integrators where
    ``scipy_on`` says (:data:`SCIPY_ON`), with where and when.
    """
    from cardan_forces.experiments.environment import json_safe, machine, versions

    scenes = [measure_scene(source, stop_s, repeats, scipy_runs_on(source, scipy_on))
              for source in penalty_scenes().values()]
    return json_safe({
        "command": f"python docs/penalty_integrators.py --stop {stop_s:g} --repeats {repeats}"
                   f" --scipy-on {scipy_on}",
        "scipy_on": scipy_on,
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


def _worst(values) -> float | None:
    """The largest of ``values`` that are stored (None: no instant compared)."""
    return max((v for v in values if v is not None), default=None)


def compared(data: dict) -> list[dict]:
    """The scenes SciPy's integrators ran on."""
    return [s for s in data["scenes"] if s["scipy"]]


def summary(data: dict) -> dict:
    """Per SciPy integrator, over the scenes it ran on (:func:`compared`): the smallest
    and largest ratio of its CPU per simulated second to the compiled BDF's, its
    failures and the compiled BDF's on the same scenes, the worst force agreements.
    The tighter compiled BDF's worst agreements over every scene; the compiled BDF's
    failures and runs over every scene.
    """
    out = {}
    scenes = compared(data)
    compiled_failures = sum(s["integrators"][COMPILED]["failures"] for s in scenes)
    for method in SCIPY:
        rows = [s["integrators"][method] for s in scenes]
        out[method] = {
            "low": min(r["ratio"] for r in rows), "high": max(r["ratio"] for r in rows),
            "failures": sum(r["failures"] for r in rows),
            "runs": sum(r["runs"] for r in rows),
            "compiled_failures": compiled_failures,
            "sampled": _worst(r["agreement"]["sampled"] for r in rows),
            "averaged": _worst(r["agreement"]["averaged"] for r in rows),
        }
    tighter = [s["integrators"][TIGHTER]["agreement"] for s in data["scenes"]]
    out[TIGHTER] = {"sampled": _worst(a["sampled"] for a in tighter),
                    "averaged": _worst(a["averaged"] for a in tighter)}
    compiled = [s["integrators"][COMPILED] for s in data["scenes"]]
    out[COMPILED] = {"failures": sum(r["failures"] for r in compiled),
                     "runs": sum(r["runs"] for r in compiled),
                     "failed": [s["scene"] for s in data["scenes"]
                                if s["integrators"][COMPILED]["failures"]],
                     "scenes": len(compiled), "compared": len(scenes)}
    return out


def _coverage(data: dict, table: dict) -> str:
    """Where the compiled BDF ran and finished, and where SciPy's integrators ran."""
    c = table[COMPILED]
    finished = (f"The compiled BDF finished all {c['runs']} runs on all {c['scenes']} "
                "scenes" if not c["failures"] else
                f"The compiled BDF failed {c['failures']} of {c['runs']} runs over the "
                f"{c['scenes']} scenes (on {', '.join(c['failed'])})")
    skipped = [s for s in data["scenes"] if not s["scipy"]]
    if not skipped:
        return f"{finished}. SciPy's integrators ran on all {c['compared']} scenes."
    where = (f"SciPy's integrators ran on {SCIPY_ON[data['scipy_on']]} "
             f"({c['compared']} scenes), not on the other {len(skipped)}")
    if data["scipy_on"] == "dynamic":
        where += ", the quasi-static scenes' dynamic counterparts"
    if c["compared"]:
        low, high = (sum(table[m][end] for m in SCIPY) for end in ("low", "high"))
        hours = sum(s["integrators"][COMPILED]["cpu_per_simulated_s"] * s["simulated_s"]
                    * s["integrators"][COMPILED]["runs"] for s in skipped) / 3600
        where += (f": at the ratios measured where they ran, their runs there would have "
                  f"cost {low * hours:.1f} to {high * hours:.1f} CPU hours more")
    return f"{finished}. {where}."


def decision(data: dict) -> str:
    """The rule applied to the stored run: keep the simplest SciPy integrator (in the
    order LSODA, BDF, Radau: cheapest first) whose CPU per simulated second is within
    :data:`KEEP_WITHIN` of the compiled BDF's on every scene it ran on with no more
    failures; otherwise keep the compiled BDF, saying by how much it wins over the best
    of them. Says first where the compiled BDF finished and where SciPy's ran.
    """
    table = summary(data)
    coverage = _coverage(data, table)
    for method in SCIPY:
        s = table[method]
        if s["high"] <= KEEP_WITHIN and s["failures"] <= s["compiled_failures"]:
            return (f"{coverage} **Decision: SciPy's {method} on the compiled right-hand "
                    f"side and Jacobian is enough.** On those scenes it takes "
                    f"{s['low']:.2f} to {s['high']:.2f} "
                    f"times the compiled BDF's CPU per simulated second, within "
                    f"{KEEP_WITHIN:g}, with {s['failures']} failures in {s['runs']} runs "
                    f"(the compiled BDF {s['compiled_failures']}); its forces' averages over "
                    f"the window's second half differ from the compiled BDF's by up to "
                    f"{percent(s['averaged'])} of the largest force.")
    best = min(SCIPY, key=lambda m: table[m]["high"])
    s, tighter = table[best], table[TIGHTER]
    others = ", ".join(f"{m} {table[m]['low']:.1f} to {table[m]['high']:.1f}"
                       for m in SCIPY if m != best)
    return (f"{coverage} **Decision: keep the compiled BDF.** The cheapest SciPy integrator "
            f"on the same compiled right-hand side and Jacobian, {best}, takes "
            f"{s['low']:.1f} to {s['high']:.1f} times its CPU per simulated second over the "
            f"scenes it ran on, beyond "
            f"the {KEEP_WITHIN:g} allowed ({others}); failures: {s['failures']} in "
            f"{s['runs']} runs of {best}, {s['compiled_failures']} in as many of the compiled "
            f"BDF. The averages of {best}'s forces over the window's second half differ from "
            f"the compiled BDF's by up to {percent(s['averaged'])} of the largest force, "
            f"those of the compiled BDF at a tenfold tighter tolerance by up to "
            f"{percent(tighter['averaged'])} (over every scene); at single instants by up to "
            f"{percent(s['sampled'])} and {percent(tighter['sampled'])}.")


def percent(fraction: float | None) -> str:
    """``fraction`` as a percentage: two significant digits below 10 %, whole above;
    ``-`` where there is none (stored as null: no instant to compare).
    """
    if fraction is None:
        return "-"
    value = 100 * fraction
    return f"{value:.0f} %" if value >= 10 else f"{value:.2g} %"


def _source(scene: dict) -> str:
    """The table's built-in scene cell: a quasi-static scene's row says it is its
    dynamic counterpart.
    """
    if scene["quasi_static"]:
        return f"{scene['from']} (quasi-static; run in motion, inertia added)"
    return scene["from"]


def _compared_from(scene: dict, paper: dict | None) -> str:
    """The compiled BDF's CPU per simulated s over paper-penalty's, as a cell."""
    if paper is None:
        return "-"
    cpu = scene["integrators"][COMPILED]["cpu_per_simulated_s"]
    return f"{cpu / paper['integrators'][COMPILED]['cpu_per_simulated_s']:.1f}"


REFERENCE = "paper-penalty"
"""The scene the compiled BDF's cost on every other scene is given relative to."""


def markdown(data: dict) -> str:
    """The generated part of the page: where and when, the table, the decision."""
    window = data["scenes"][0]["simulated_s"]
    samples = sorted({s["sample_s"] for s in data["scenes"]})
    paper = next((s for s in data["scenes"] if s["scene"] == REFERENCE), None)
    counterparts = [s["from"] for s in data["scenes"] if s["quasi_static"]]
    lines = [BEGIN, "",
             f"Measured by `{data['command']}` on {data['date']}: {data['machine']}; "
             f"cardan-forces {data['cardan_forces']}, {data['versions']}. "
             f"{window:g} s simulated from the scene's start per scene, forces sampled every "
             f"{', '.join(f'{x:.3g}' for x in samples)} s (the scene's own step); "
             f"CPU s per simulated s is the "
             f"{data['measure']}. Ratio: that CPU over the compiled BDF's on the same "
             f"scene; x {REFERENCE}: the compiled BDF's CPU over its CPU on {REFERENCE}. "
             "Forces: the largest difference from the compiled BDF's over the "
             "largest force, at the sampled instants and of the averages over the "
             "window's second half. Failed: failed runs of all runs.", ""]
    if counterparts:
        lines += [f"The rows of {', '.join(counterparts)} are not those scenes as "
                  "defined: each is quasi-static (no dynamics of its own), so it runs as "
                  "its dynamic counterpart, the same scene with the inertia of its shafts "
                  "added (`Scene.in_motion`), then released.", ""]
    lines += ["| scene | built-in scene | integrator | CPU s per simulated s | ratio "
              f"| x {REFERENCE} | steps | failed | forces, sampled | forces, averaged |",
              "|---|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for scene in data["scenes"]:
        for method, r in scene["integrators"].items():
            ratio = "1" if method == COMPILED else f"{r['ratio']:.2f}"
            against = _compared_from(scene, paper) if method == COMPILED else "-"
            agree = r.get("agreement") or {}
            sampled, averaged = percent(agree.get("sampled")), percent(agree.get("averaged"))
            failed = f"{r['failures']}/{r['runs']}"
            if r["failures"]:
                failed += f" ({'; '.join(r['messages'])})"
            lines.append(f"| {scene['scene']} | {_source(scene)} | {method} "
                         f"| {r['cpu_per_simulated_s']:.3g} "
                         f"| {ratio} | {against} | {r['steps']} | {failed} "
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
    parser.add_argument("--scipy-on", choices=list(SCIPY_ON), default=next(iter(SCIPY_ON)),
                        help="where SciPy's integrators run: dynamic (default) the "
                             "dynamic built-in scenes, not the quasi-static scenes' "
                             "counterparts; all every scene; none no scene")
    parser.add_argument("--page", action="store_true",
                        help="only rewrite the page from the stored data")
    args = parser.parse_args(argv)
    if not args.page:
        if args.repeats < 2:
            parser.error("--repeats: at least 2 (the smaller CPU time is kept)")
        DATA.write_text(json.dumps(run(args.stop, args.repeats, args.scipy_on),
                                   indent=1) + "\n")
        print(f"wrote {DATA}")
    write_page(json.loads(DATA.read_text()))
    print(f"wrote {PAGE}")


if __name__ == "__main__":
    sys.exit(main())
