"""The formulation registry: one :class:`Formulation` record per contact formulation,
the one place that says what it is (DESIGN §2): how its problem is built, its problem
classes, its label, its physical meaning, the backends that take it and whether it can
be exported. The study layer, the bench, the hard cases, sweeps, the paper's figures,
reports and export read these records; a command's own choices (the bench's targets,
the figures' methods, export's default set) are tables of that command, keyed by the
names spelled here. Nothing here knows the commands: the data flows one way.

``FORMULATIONS[name](op, i)`` builds formulation ``name``'s problem at instant ``i`` of
the equilibrium operator ``op`` (a record is called as its builder is).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cardan_forces.util.names import did_you_mean

from .convex import (
    compliance,
    friction,
    lcp,
    min_max,
    min_norm,
    min_norm_scaled,
    positive,
    socp_face,
)
from .paper import build_paper, end_faces_words
from .problems import LCP, LP, LS, NLS, QP, Conic

FALLBACK = "clarabel"
"""Tried after a formulation's own backends (a core dependency that takes every convex
class)."""

SELECTION = "positive"
"""The physical selection shown where one member of the rigid set is drawn or printed
(``sets``' member column, ``report``'s lines, the figures' reference curve): the least
norm with end faces >= 0, so it lies inside every interval."""

EXPORTED_FORMS = (LS, QP, LP, Conic)
"""The problem classes ``cardan export`` writes: a least norm and a QP as a QP, an LP
and a conic problem in the standard conic form (each reaches one by the conversions)."""

BASELINE = "paper"
"""The paper's method: the bench's baseline, the reference of the paper's figures."""


@dataclass(frozen=True)
class Formulation:
    """One contact formulation: what it is, not how a command uses it (the bench's
    targets, the figures' choice of methods, the export's default set live with those
    commands).

    ``build(op, i)`` makes its problem, of one of the classes ``problem``; ``label`` names it in
    figures and reports; ``physical``: its answer is a physical selection of the rigid
    solution set (a contact force law the line could obey), else a comparison only;
    ``backends``: the backends that solve it by default, best first (then
    :data:`FALLBACK`, then any that takes it; a batched backend serves runs over
    time, the first per-instant one a single instant); ``least_norm_batch``: the stacked
    least-norm batch (``numpy-batched``) takes it; ``batch_weights(A, first)``: the
    least-norm batch's weights from the stacked ``A`` (T, m, n) and the first instant's
    problem (``None``: unit weights); ``compliant``: its contacts have a stiffness (a
    compliance law), so a seat misfit enters as work on them (``cardan tolerances``);
    ``design``: a physical selection whose loads the design answers report (``cardan
    life``); :attr:`exportable`: its problems are in a form ``cardan export`` writes.

    The builder is called with the record's ``name`` (``build(op, i, name=...)``), which
    its problems carry as their ``formulation``: each name is spelled here only.
    """

    name: str
    build: Callable[..., object]
    problem: tuple[type, ...]
    label: str
    physical: bool
    backends: tuple[str, ...]
    least_norm_batch: bool = False
    batch_weights: Callable[..., np.ndarray] | None = None
    compliant: bool = False
    design: bool = False

    def __call__(self, op, i: int):
        """The problem at instant ``i`` of ``op``, named after this record."""
        return self.build(op, i, name=self.name)

    @property
    def exportable(self) -> bool:
        """Its problems are QPs (a least norm as its QP) or conic problems (an LP as
        one): the solver-independent forms ``cardan export`` writes, the one test of
        what it accepts and lists.
        """
        return all(issubclass(cls, EXPORTED_FORMS) for cls in self.problem)


def _column_norms(A: np.ndarray, first) -> np.ndarray:
    """``min_norm_scaled``'s weights at each instant: the squared norms of ``A``'s
    columns (reference length 1 m: the moment rows as they are).
    """
    return np.einsum("tij,tij->tj", A, A)


def _stiffness_weights(A: np.ndarray, first) -> np.ndarray:
    """``compliance``'s weights: its ``P``'s diagonal (the same at every instant)."""
    return np.broadcast_to(np.diag(first.P), (len(A), first.n))


def _hertz(op, i: int, name: str = ""):
    """``compliance`` with Hertz's law (exponent 3/2 for the joints' line contacts)."""
    return compliance(op, i, name, law="hertz")


_BATCH_FIRST = ("numpy-batched", "newton-batched", "qpsolvers-daqp", "newton", "clarabel")
"""The least-norm family with end faces: over time the package's own batch, the least
norm's or (a clearance makes the problem conic) the contact energies' (NumPy, core
dependencies), so a run over time gives the same answers on any install; per instant
DAQP where installed, else the package's ``newton`` (NumPy; Clarabel at its default
tolerances leaves some instants of every built-in scene inaccurate)."""

_ENERGY_FIRST = ("newton-batched", "newton", "clarabel")
"""Hertz's contact energies: the package's own Newton method (over time as one batch),
which reaches the unique optimum to rounding where an interior point's gap of 1e-8
leaves the forces about 1e-4 of the load away (the distance goes as the gap's square
root)."""


REGISTRY: tuple[Formulation, ...] = (
    Formulation("paper", build_paper, (NLS,),
                f"the paper's method (as computed here; {end_faces_words(True)})",
                physical=False, backends=("scipy-fsolve", "scipy-root-lm")),
    Formulation("min_norm", min_norm, (LS,), "min_norm (least norm: end faces may pull)",
                physical=False, backends=("numpy-kkt",), least_norm_batch=True),
    Formulation("min_norm_scaled", min_norm_scaled, (LS,),
                "min_norm_scaled (least norm, moments per reference length)",
                physical=False, backends=("numpy-kkt",), least_norm_batch=True,
                batch_weights=_column_norms),
    Formulation("positive", positive, (QP,), "positive (least norm, end faces push)",
                physical=True, backends=_BATCH_FIRST, least_norm_batch=True, design=True),
    Formulation("min_max", min_max, (Conic,),
                "min_max (comparison only: both end faces of a pair may push)",
                physical=False, backends=("clarabel",)),
    Formulation("socp_face", socp_face, (Conic,),
                "socp_face (end faces with a centre-of-pressure cone)",
                physical=True, backends=("clarabel",)),
    Formulation("lcp", lcp, (LCP,), "lcp (positive as a complementarity problem)",
                physical=True, backends=("lcp-lemke",), least_norm_batch=True),
    Formulation("friction", friction, (Conic,), "friction (positive with Coulomb friction)",
                physical=True, backends=("clarabel",)),
    Formulation("compliance", compliance, (QP, Conic), "compliance (linear contact stiffness)",
                physical=True, backends=_BATCH_FIRST, least_norm_batch=True,
                batch_weights=_stiffness_weights, compliant=True, design=True),
    Formulation("compliance_hertz", _hertz, (Conic,), "compliance_hertz (Hertz contact law)",
                physical=True, backends=_ENERGY_FIRST, compliant=True, design=True),
)

FORMULATIONS: dict[str, Formulation] = {f.name: f for f in REGISTRY}
"""The formulations by name, in the order tables and figures list them."""


class UnknownFormulation(KeyError):
    """A formulation name the registry does not hold."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "unknown formulation"


def formulation(name: str) -> Formulation:
    """The record of ``name``; :class:`UnknownFormulation` naming the nearest known ones
    (:func:`~cardan_forces.util.names.did_you_mean`), or all when none is near.
    """
    try:
        return FORMULATIONS[name]
    except (KeyError, TypeError):
        near = did_you_mean(name, FORMULATIONS)
        raise UnknownFormulation(f"unknown formulation {name!r}" + (
            near or f"; known: {', '.join(FORMULATIONS)}")) from None


def default_backends() -> tuple[str, ...]:
    """Every formulation's default backends, then :data:`FALLBACK`, each once: at least
    one backend per formulation (the ``--quick`` runs' set).
    """
    names = [b for f in REGISTRY for b in f.backends] + [FALLBACK]
    return tuple(dict.fromkeys(names))


def where(**wanted) -> tuple[str, ...]:
    """Names of the formulations whose fields equal ``wanted`` (e.g. ``design=True``)."""
    return tuple(f.name for f in REGISTRY
                 if all(getattr(f, key) == value for key, value in wanted.items()))
