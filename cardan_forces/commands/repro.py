"""``cardan repro``: the paper's Figs. 11-15 as CSV + images and ``report.md``."""

from __future__ import annotations

from cardan_forces.experiments import files
from cardan_forces.experiments.images import format_list
from cardan_forces.util.names import did_you_mean

from . import UsageError, progress

FIGURES = (11, 12, 13, 14, 15)


def add_parser(subparsers) -> None:
    """Register ``cardan repro``."""
    rp = subparsers.add_parser("repro", help="reproduce the paper's figures (CSV + images)")
    rp.add_argument("scene", nargs="?", default="paper", help="built-in name or TOML path")
    rp.add_argument("--fig", type=int, action="append", choices=FIGURES,
                    help="one figure (repeatable); default all")
    rp.add_argument("--out", type=files.folder, default="results/repro",
                    help="output folder (default %(default)s)")
    rp.add_argument("--quick", action="store_true", help="first 0.15 s only (tests, CI)")
    rp.add_argument("--methods", type=_words,
                    help="comma-separated methods to draw (default all: paper,positive,"
                         "min_max,compliance,penalty, and engine where MuJoCo is "
                         "installed); leave out one that does not apply to the scene, "
                         "e.g. the paper's method on a slip joint")
    rp.add_argument("--no-penalty", dest="penalty", action="store_false",
                    help="leave out the penalty-contact simulation (the slow part)")
    rp.add_argument("--format", type=format_list, default=("png",),
                    help="comma-separated image formats (default png; any of png,svg,pdf)")
    rp.add_argument("--fig15-scene", action="append",
                    help="scene of Fig. 15 (repeatable; default both paper-fig15, gravity "
                         "+y, and paper-fig15-axial, gravity +x)")
    rp.set_defaults(func=run)


def _words(text: str) -> tuple[str, ...]:
    """A comma-separated list, order kept, repeats dropped."""
    return tuple(dict.fromkeys(w.strip() for w in text.split(",") if w.strip()))


def _check(words: tuple[str, ...], allowed: tuple[str, ...], flag: str) -> tuple[str, ...]:
    """``words``, each among ``allowed``; else a :class:`UsageError` naming the first
    unknown one's nearest names (:func:`~cardan_forces.util.names.did_you_mean`).
    """
    bad = [w for w in words if w not in allowed]
    if bad or not words:
        near = did_you_mean(bad[0], allowed) if bad else ""
        raise UsageError(f"{flag}: {'unknown ' + ', '.join(bad) if bad else 'empty'}"
                         f"{near or '; choose among ' + ','.join(allowed)}")
    return words


def run(args) -> int:
    from cardan_forces.paper_repro.repro import (
        ALL_METHODS,
        FIG15_SCENES,
        default_methods,
        run_repro,
    )

    figures = sorted(set(args.fig or FIGURES))
    methods = _check(args.methods or default_methods(), ALL_METHODS, "--methods")
    methods = tuple(m for m in methods if args.penalty or m != "penalty")
    if not methods:
        raise UsageError("--methods penalty with --no-penalty: nothing left to draw")
    run_repro(args.scene, figures, args.out, args.quick,
              tuple(args.fig15_scene or FIG15_SCENES), progress=progress, methods=methods,
              formats=args.format)
    return 0
