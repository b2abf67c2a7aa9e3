"""``cardan export``: the package's problems as files any solver or benchmark can read.

Chosen scenes x formulations x instants are written into one folder:

- the QPs (``positive``, ``compliance``, and least norms such as ``min_norm`` as the QP
  ``min 1/2 x'Wx s.t. Ax = b``) as a **qpbenchmark test set**: ``<name>.py``, a
  module with one ``TestSet`` class that ``qpbenchmark <name>.py run`` loads, and
  ``<name>.npz``, its data (per problem ``<problem>/P``, ``q``, ``A``, ``b``, ``G``,
  ``h``, ``lb``, ``ub``, absent parts left out; ``names`` lists the problems). The
  module needs only numpy and qpbenchmark.
- the conic problems (``socp_face``, ``min_max``, ``friction``, ``compliance_hertz``) in
  one standard form, ``<name>_conic.npz``: ``min 1/2 z'Pz + q'z s.t. A z + s = b, s in
  K`` with, per problem, ``<problem>/P`` (n, n; zeros for a linear objective), ``q``
  (n,), ``A`` (m, n), ``b`` (m,), ``cone_kinds`` (k,) strings and ``cone_sizes`` (k,):
  the blocks of ``K`` in row order, ``zero`` (size rows, ``s = 0``), ``nonneg`` (``s >=
  0``), ``soc`` (``s_0 >= ||s_1:||``, size rows, apex first) and ``pow`` (3 rows, the
  size is ``alpha``: ``s_0^alpha s_1^(1-alpha) >= |s_2|``) — Clarabel's, SCS's and
  moreau's convention. ``names`` lists the problems.

By default only the QPs are written (no conic file); ``--formulation min_max`` (etc.)
adds the conic file. A formulation that is neither (``paper``, a nonlinear system;
``lcp``, a complementarity problem) is refused before any work, as is a number of
instants above the scene's time grid. Every file is written whole or not at all
(:mod:`.files`); a conic file an earlier export of the same name left is removed when
this export has no conic problem, so the folder holds one export.

Problems are named ``<scene>_<formulation>_<instant:04d>`` (the instant's index on the
scene's time grid); forces in N, moments in N·m, the unknowns in the order of the
formulation's named forces.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.driveline.scene import MAX_INSTANTS
from cardan_forces.experiments.arguments import UsageError, formulation_name, whole_number
from cardan_forces.formulations import FORMULATIONS, where
from cardan_forces.formulations import batch as fbatch
from cardan_forces.formulations.convex import NotApplicable
from cardan_forces.formulations.problems import LS, QP, Conic
from cardan_forces.solvers.conversions import convert

from . import files

QP_FORMULATIONS = ("min_norm", "positive", "compliance")
"""Formulations exported by default: QPs that qpbenchmark takes, the least norm and the
physical selections (export's choice; each is :attr:`~cardan_forces.formulations.
Formulation.exportable`)."""
EXPORTABLE = where(exportable=True)
"""Formulations whose problems export writes (the record's
:attr:`~cardan_forces.formulations.Formulation.exportable`): the ``--help`` lists them,
and the others are refused before any work."""
INSTANTS = 50
"""Evenly spaced instants per scene by default."""
QP_KEYS = ("P", "q", "A", "b", "G", "h", "lb", "ub")

QPBENCHMARK_RUN = 'qpbenchmark --results-path {module}.csv {module}.py run --author "Your Name"'
"""qpbenchmark's command that runs an exported test set in its folder, without a question
(qpbenchmark 2.7 stops without a results path and asks for the report's author)."""

TEST_SET_MODULE = '''"""cardan-forces problems as a qpbenchmark test set (``cardan export``).

Run it in this folder with

    {run}

The problems are in ``{module}.npz`` beside this file (per problem ``<name>/P``, ``q``,
``A``, ``b``, ``G``, ``h``, ``lb``, ``ub``).
"""

from pathlib import Path

import numpy as np
from qpbenchmark import Problem, TestSet

DATA = Path(__file__).with_suffix(".npz")
KEYS = ("P", "q", "G", "h", "A", "b", "lb", "ub")


class {cls}(TestSet):
    """{title}."""

    @property
    def description(self) -> str:
        return "{description}"

    @property
    def title(self) -> str:
        return "{title}"

    @property
    def sparse_only(self) -> bool:
        return False

    def __iter__(self):
        with np.load(DATA) as data:
            for name in data["names"]:
                parts = {{k: data[f"{{name}}/{{k}}"].copy() if f"{{name}}/{{k}}" in data
                         else None for k in KEYS}}
                yield Problem(**parts, name=str(name))
'''


def class_name(module: str) -> str:
    """The class name qpbenchmark looks for in module ``module`` (its ``load_test_set``
    rule: title case, underscores removed).
    """
    return module.title().replace("_", "")


def collect(scenes, formulations, instants: int) -> dict[str, object]:
    """``{name: problem}`` of every scene x formulation at ``instants`` evenly spaced
    instants of the scene's time grid (a formulation a scene does not call for is left
    out for that scene). :class:`UsageError` for more instants than a scene's grid has
    (every scene checked before any is simulated) and for a formulation not in
    :data:`EXPORTABLE`, both before any work.
    """
    refused = [name for name in formulations if name not in EXPORTABLE]
    if refused:
        raise UsageError(
            f"--formulation {refused[0]}: its problems "
            f"({', '.join(cls.__name__ for cls in FORMULATIONS[refused[0]].problem)}) are "
            "neither a QP nor a conic problem, which are the forms export writes; "
            f"exportable: {', '.join(EXPORTABLE)}")
    loaded = [load_scene(name) for name in scenes]
    for scene in loaded:
        available = len(scene.time.instants())
        if instants > available:
            raise UsageError(f"--instants {instants}: scene {scene.name} has {available} "
                             "instants on its time grid; ask for at most as many")
    out = {}
    for scene in loaded:
        times = scene.time.instants()
        chosen = np.unique(np.linspace(0, len(times) - 1, instants).round().astype(int))
        op = build_operator(simulate(scene, times[:chosen[-1] + 1]))
        for formulation in formulations:
            try:
                problems = fbatch.build_problems(op, formulation, chosen)
            except NotApplicable:
                continue
            out |= {f"{scene.name}_{formulation}_{i:04d}": p for i, p in zip(chosen, problems)}
    return out


def as_qp(problem) -> QP | None:
    """The problem as a package ``QP`` (a least norm through ``LS.as_qp``), else ``None``."""
    if isinstance(problem, LS):
        return problem.as_qp()
    return problem if isinstance(problem, QP) else None


def write_qpbenchmark(folder: Path, module: str, qps: dict[str, QP], title: str) -> Path:
    """Write ``<module>.py`` and ``<module>.npz`` (a qpbenchmark test set); the module's path."""
    data = {"names": np.array(list(qps))}
    for name, qp in qps.items():
        for key in QP_KEYS:
            value = getattr(qp, key)
            if value is not None:
                data[f"{name}/{key}"] = np.asarray(value, float)
    files.savez(folder / f"{module}.npz", **data)
    path = folder / f"{module}.py"
    files.write_text(path, TEST_SET_MODULE.format(
        module=module, cls=class_name(module), title=title,
        run=QPBENCHMARK_RUN.format(module=module),
        description=f"{len(qps)} QPs of drive-shaft reaction forces (cardan-forces)"))
    return path


def write_conic(path: Path, conics: dict[str, Conic]) -> None:
    """Write the conic problems in the standard form of the module docstring."""
    data = {"names": np.array(list(conics))}
    for name, c in conics.items():
        data |= {f"{name}/P": np.zeros((c.n, c.n)) if c.P is None else np.asarray(c.P, float),
                 f"{name}/q": np.asarray(c.q, float), f"{name}/A": np.asarray(c.A, float),
                 f"{name}/b": np.asarray(c.b, float),
                 f"{name}/cone_kinds": np.array([k for k, _ in c.cones]),
                 f"{name}/cone_sizes": np.array([float(s) for _, s in c.cones])}
    files.savez(path, **data)


def export(folder: Path, problems: dict[str, object], module: str) -> dict[str, Path]:
    """Split ``problems`` into QPs and conic problems and write both; the paths written.
    The files of the same ``module`` an earlier export left and this one does not
    write (its test set, its conic file) are removed: the folder holds this export.
    """
    folder.mkdir(parents=True, exist_ok=True)
    qps = {name: qp for name, p in problems.items() if (qp := as_qp(p)) is not None}
    conics = {name: convert(p, (Conic,)) for name, p in problems.items() if name not in qps}
    conics = {name: c for name, c in conics.items() if c is not None}
    written = {}
    if qps:
        written["qpbenchmark"] = write_qpbenchmark(folder, module, qps,
                                                   "cardan-forces drive-shaft QPs")
    if conics:
        written["conic"] = folder / f"{module}_conic.npz"
        write_conic(written["conic"], conics)
    for path in files.stale(folder, [*written.values(), folder / f"{module}.npz"],
                            [f"{module}.py", f"{module}.npz", f"{module}_conic.npz"]):
        path.unlink()
    return written


def run(args) -> int:
    """``cardan export``: write the chosen problems into ``args.out`` (named on stderr)."""
    problems = collect(args.scene or ["paper"], args.formulation or QP_FORMULATIONS,
                       args.instants)
    if not problems:
        raise NotApplicable("none of the chosen formulations applies to the chosen scenes")
    folder = Path(args.out)
    written = export(folder, problems, args.module)
    paths = [*written.values()]
    if "qpbenchmark" in written:
        paths.insert(1, folder / f"{args.module}.npz")
    files.say_written(f"export ({len(problems)} problems)", paths)
    return 0


def _module(text: str) -> str:
    """A Python module name (argparse type): qpbenchmark imports the test set by it."""
    if not text.isidentifier():
        raise argparse.ArgumentTypeError(f"expected a Python identifier, got {text!r}")
    return text


def add_parser(subparsers) -> None:
    """Register ``cardan export`` on the command line's subparsers."""
    p = subparsers.add_parser("export", help="write problems as files: the QPs as a "
                              "qpbenchmark test set (default), conic formulations (e.g. "
                              "--formulation min_max) as an NPZ in one standard conic form")
    p.add_argument("scene", nargs="*", help="built-in names or TOML paths (default paper)")
    p.add_argument("--formulation", action="append", type=formulation_name,
                   choices=list(FORMULATIONS),
                   help="one formulation (repeatable) among "
                        f"{', '.join(EXPORTABLE)}; default {', '.join(QP_FORMULATIONS)} "
                        "(QPs only: no conic file)")
    p.add_argument("--instants", type=whole_number(1, MAX_INSTANTS), default=INSTANTS,
                   help=f"evenly spaced instants per scene (default {INSTANTS})")
    p.add_argument("--out", type=files.folder, default="results/export",
                   help="output folder (default %(default)s)")
    p.add_argument("--name", dest="module", type=_module, default="cardan_qp",
                   help="name of the test-set module (default cardan_qp)")
    p.set_defaults(func=run)
