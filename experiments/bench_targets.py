"""The targets a developer's check holds ``cardan bench`` to (``pytest -m targets``),
kept out of what the bench reports (``report.md``, ``--json`` and the Benchmarks page
carry measurements only): the bench's policy, beside the formulations' definitions
(:mod:`cardan_forces.formulations`), which say nothing of it.

:data:`TARGETS` holds what each formulation's runs are wanted to reach, keyed by the
registry's names; the run-wide targets (glue share, checks per instant, wall time) are
constants of their own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from cardan_forces.formulations import BASELINE

from .bench_metrics import best_runs


@dataclass(frozen=True)
class Targets:
    """What the targets want of one formulation's runs in a quick bench.

    ``rate``: instants per second of its best batched run (``None``: no such target);
    ``paper_ratio``: the speed-up over the paper's method of its best run (read for a
    conic formulation); ``newton_share``: the ``newton`` family's best batched rate over
    ``numpy-batched``'s, both solving every instant (``None``: no such target);
    ``success``: ``(level, rate)``, its best backend solves at least ``rate`` of the
    instants at accuracy ``level`` (``None``: no such target).
    """

    rate: float | None = None
    paper_ratio: float = 20.0
    newton_share: float | None = None
    success: tuple[float, float] | None = None


TARGETS: dict[str, Targets] = {
    "min_norm": Targets(rate=1e5),
    "positive": Targets(rate=1e5, newton_share=0.5),
    "min_max": Targets(success=(1e-6, 0.9)),
    "lcp": Targets(rate=1e5),
    "compliance": Targets(rate=1e5, newton_share=0.5),
    "compliance_hertz": Targets(paper_ratio=50.0),
}
"""The formulations' targets by name, in the registry's order (one not named here: the
defaults of :class:`Targets`, no target but the speed-up over the paper's method)."""

GLUE_SHARE = 0.25
"""Largest share of a per-instant conic solve spent outside the solver."""
WALL_S = 180.0
"""Wanted wall time of the full benchmark."""
CHECKS_S = 20e-6
"""Largest time of the checks per instant (residuals, both optimality views and the
record), in every run, per instant or batched."""


def target_levels() -> tuple[float, ...]:
    """The accuracy levels of the success targets: the success table must hold them
    beside the ladder's.
    """
    return tuple(sorted({t.success[0] for t in TARGETS.values() if t.success}))


def targets(summary: list[dict], success_rows: list[dict], conic: set[str],
            wall_s: float | None) -> list[dict]:
    """The targets of a run, a developer's check (``tests/test_bench_targets.py``), not
    a part of what the bench reports: ``{name, value, wanted, met, detail}`` rows.

    The paper's fair baseline is its fastest run (warm-started, analytic Jacobian);
    ``conic`` names the formulations whose problem is conic; a formulation with a
    ``success`` target is judged by its best backend's success at the target's level
    (``success_rows`` must hold :func:`target_levels`).
    """
    best = best_runs(summary)
    paper = max((e for e in summary if e["formulation"] == BASELINE),
                key=lambda e: e["instants_per_s"], default=None)
    out = []
    for name, wanted in TARGETS.items():
        if not wanted.rate:
            continue
        runs = [e for e in summary if e["formulation"] == name and e["mode"] == "batched"]
        run = max(runs, key=lambda e: e["instants_per_s"], default=None)
        out.append(_target(f"{name} batched instants/s", run and run["instants_per_s"],
                           wanted.rate, run and f"{run['solver']}, solved "
                           f"{100 * run['success_rate']:.1f}%"))
    for name in sorted(conic):
        run = best.get(name)
        ratio = run and paper and run["instants_per_s"] / paper["instants_per_s"]
        wanted = TARGETS.get(name, Targets()).paper_ratio
        out.append(_target(f"{name} best run / paper", ratio, wanted,
                           run and f"{run['solver']} {run['mode']}"))
        cold = [e for e in summary if e["formulation"] == name and e["mode"] == "cold"
                and e["solver"] == "clarabel"]
        if cold:
            glue = 1.0 - cold[0]["solver_share"]
            out.append(_target(f"{name} glue share (clarabel per instant)", glue, GLUE_SHARE,
                               "build + conversion + checks + dispatch", below=True))
    out += _success_targets(success_rows) + _newton_targets(summary)
    for mode, label in (("cold", "per-instant"), ("batched", "batched")):
        runs = [e for e in summary if e["mode"] == mode]
        worst = max(runs, key=lambda e: e["split_s"]["checks_s"], default=None)
        out.append(_target(f"checks per instant, {label} runs, worst (us)",
                           worst and 1e6 * worst["split_s"]["checks_s"], 1e6 * CHECKS_S,
                           worst and f"{worst['formulation']} {worst['solver']}"
                           + (_first_pass(runs) if mode == "cold" else ""), below=True))
    out.append(_target("wall time of the run (s)", wall_s, WALL_S, None, below=True))
    return out


def _newton_targets(summary: list[dict]) -> list[dict]:
    """One target per formulation with a ``newton_share``: the ``newton`` family's best
    batched rate over ``numpy-batched``'s (both solving every instant).
    """
    out = []
    for name, wanted in TARGETS.items():
        if wanted.newton_share is None:
            continue
        runs = [e for e in summary if e["formulation"] == name
                and e["mode"] == "batched" and e["success_rate"] == 1.0]
        mine = max((e for e in runs if e["solver"].startswith("newton")),
                   key=lambda e: e["instants_per_s"], default=None)
        theirs = next((e for e in runs if e["solver"] == "numpy-batched"), None)
        share = mine and theirs and mine["instants_per_s"] / theirs["instants_per_s"]
        out.append(_target(f"{name} newton / numpy-batched (batched)", share,
                           wanted.newton_share, mine and mine["solver"]))
    return out


def _success_targets(success_rows: list[dict]) -> list[dict]:
    """One target per formulation with a ``success`` target: its best backend's success
    rate at the target's level.
    """
    out = []
    for name, wanted in TARGETS.items():
        if not wanted.success:
            continue
        level, rate = wanted.success
        mine = [r for r in success_rows if r["formulation"] == name and r["level"] == level]
        top = max(mine, key=lambda r: r["rate"], default=None)
        out.append(_target(f"{name} success at {level:g} (best backend)",
                           None if top is None else top["rate"], rate,
                           None if top is None else f"{top['solver']} at tol {top['tol']}"))
    return out


def _first_pass(runs: list[dict]) -> str:
    """The first check pass of per-instant runs (cold after the solver's run, the one
    their end-to-end time holds; ``checks_s`` is the fastest of
    :data:`~.bench_run.CHECK_PASSES`): its worst and median, in words.
    """
    first = [(1e6 * e["split_s"]["checks_first_s"], e) for e in runs]
    value, top = max(first, key=lambda pair: pair[0])
    return (f"; first pass (cold, in the end-to-end time): worst {value:.1f} us "
            f"({top['formulation']} {top['solver']}), median "
            f"{float(np.median([v for v, _ in first])):.1f} us")


def _target(name, value, wanted, detail, below=False) -> dict:
    met = None if value is None else (value <= wanted if below else value >= wanted)
    return {"name": name, "value": value, "wanted": wanted, "met": met,
            "detail": detail or ""}
