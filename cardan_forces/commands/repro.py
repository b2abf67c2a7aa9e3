"""``cardan repro``: the paper's Figs. 11-15 as CSV + PNG and ``report.md``."""

from __future__ import annotations

from cardan_forces.driveline.loading import load_scene

from . import UsageError, progress

FIGURES = (11, 12, 13, 14, 15)


def add_parser(subparsers) -> None:
    """Register ``cardan repro``."""
    rp = subparsers.add_parser("repro", help="reproduce the paper's figures (CSV + PNG)")
    rp.add_argument("scene", nargs="?", default="paper", help="built-in name or TOML path")
    rp.add_argument("--fig", type=int, action="append", choices=FIGURES,
                    help="one figure (repeatable); default all")
    rp.add_argument("--out", default="results", help="output folder (default results/)")
    rp.add_argument("--quick", action="store_true", help="first 0.15 s only (tests, CI)")
    rp.add_argument("--no-penalty", dest="penalty", action="store_false",
                    help="leave out the penalty-contact simulation (the slow part)")
    rp.add_argument("--fig15-scene", default="paper-fig15",
                    help="scene of Fig. 15 (default paper-fig15: gravity +y; "
                         "paper-fig15-axial: gravity +x)")
    rp.set_defaults(func=run)


def run(args) -> int:
    from cardan_forces.paper_repro.repro import run_repro

    figures = sorted(set(args.fig or FIGURES))
    check_paper_layout(args.scene)
    if 15 in figures:
        check_paper_layout(args.fig15_scene)
    run_repro(args.scene, figures, args.out, args.quick, args.fig15_scene,
              progress=progress, penalty=args.penalty)
    return 0


def check_paper_layout(spec: str) -> None:
    """``cardan repro`` draws the paper's quantities by name: refuse a scene without the
    paper's layout (three shafts, the first ``input`` with bearings ``far`` and ``near``,
    the first joint ``uj1``) before any work.
    """
    scene = load_scene(spec)
    missing = []
    if len(scene.shafts) != 3:
        missing.append(f"three shafts (it has {len(scene.shafts)})")
    first = scene.shafts[0]
    if first.name != "input":
        missing.append(f"a first shaft named 'input' (it is {first.name!r})")
    absent = sorted({"far", "near"} - {b.name for b in first.bearings})
    if absent:
        missing.append(f"bearings {' and '.join(map(repr, absent))} on the first shaft")
    if scene.joints[0].name != "uj1":
        missing.append(f"a first joint named 'uj1' (it is {scene.joints[0].name!r})")
    if missing:
        raise UsageError(f"scene {scene.source}: cardan repro needs the paper's layout; "
                         f"missing: {'; '.join(missing)}")
