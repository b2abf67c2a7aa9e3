"""Convex recasts of the contact analysis at one instant (DESIGN §2).

Each builder takes the equilibrium operator and an instant index and returns a
problem object; all of them share the unknowns of the operator (the named Cartesian
contact forces, N) or map back to them with ``to_forces``.

- ``min_norm``: least ``||x||`` on ``A x = b`` (every component in N alike).
- ``min_norm_scaled``: least ``||D x||`` with ``D`` the column norms of ``A`` after its
  moment rows are divided by a reference length: every unknown weighted by how
  strongly it acts on the bodies, so the answer does not depend on whether a force
  is a bearing's or a trunnion's.
- ``positive``: ``min_norm`` with the end faces pushing only (``F3, F4, F7, F8 >= 0``);
  complementarity of each end-face pair falls out of the least norm, exactly with an
  active-set solver; at a pair that carries no load, pushing both faces by ``d`` raises
  the objective only by ``d^2``, so an interior-point solver leaves both at
  ``~sqrt(tol) ||b||`` and its record is ``inaccurate``.
- ``min_max``: least peak contact load ``t`` with ``||f_c|| <= t`` for every contact
  (a bearing's 3-vector, a trunnion's radial 2-vector, an end face), then least norm
  (weight ``MIN_MAX_NORM_WEIGHT``) to make the answer unique; end-face pairs may both
  push here (complementarity is not imposed).
- ``lcp``: the KKT system of ``positive`` as an LCP in the end-face multipliers, on the
  null-space parametrization ``x = x0 + N y`` (``x0`` the least-norm point).

Why one module this long: every recast is built from the same pieces (the equalities,
the contacts and their cones, the checks), and :data:`FORMULATIONS` lists them together.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.elements.base import FormulationExtras, Law
from cardan_forces.driveline.equilibrium import Operator

from cardan_forces.util.rank import numerical_rank

from .problems import (
    LCP,
    LS,
    QP,
    SCALE_FLOOR_N,
    Conic,
    ForceChecks,
    LastMade,
    Scaled,
    SecondOrderCone,
)

MIN_MAX_NORM_WEIGHT = 1e-4
"""Weight of the tie-breaking ``1/2 ||x / ||b|| ||^2`` term of ``min_max`` (its cost in
the peak load is below this fraction of ``||b||``)."""


def checks(op: Operator, i: int, signs: bool = True, pairs: bool = True) -> ForceChecks:
    """The rigid equilibrium at instant ``i``; ``signs``/``pairs``: whether the
    formulation imposes the end faces' sign and complementarity (a residual is only
    judged where the formulation asks for it).
    """
    unilateral = op.unilateral if signs else np.zeros_like(op.unilateral)
    return ForceChecks(A=op.A[i], b=op.b[i], names=op.names, unilateral=unilateral,
                       pairs=op.pairs if pairs else (), cones=slip_cones(op, i))


def slip_cones(op: Operator, i: int) -> tuple[SecondOrderCone, ...]:
    """The slip joints' friction bounds ``|axial| <= (mu / r) s0 torque`` as cones, ``s0``
    the sign of the spline torque in the least-norm answer (the torque through a spline
    is determinate: no self-stress of the line twists a shaft, so every solution has
    the same sign).
    """
    if not op.slip_friction:
        return ()
    least = determinacy(op, i).min_norm
    return tuple(SecondOrderCone(apex=f.torque, members=(f.axial,),
                                 scale=f.ratio_per_m * (1.0 if least[f.torque] >= 0 else -1.0))
                 for f in op.slip_friction)


def slip_rows(op: Operator, i: int, n: int | None = None) -> np.ndarray:
    """The friction bounds as linear rows ``G x <= 0`` (two per slip joint with friction),
    padded to ``n`` unknowns.
    """
    cones = slip_cones(op, i)
    G = np.zeros((2 * len(cones), len(op.names) if n is None else n))
    for r, c in enumerate(cones):
        apex = c.apex_row(G.shape[1])
        G[2 * r] = -apex
        G[2 * r + 1] = -apex
        G[2 * r, c.members[0]] += 1.0
        G[2 * r + 1, c.members[0]] -= 1.0
    return G


def _no_bounds(op: Operator, formulation: str) -> None:
    """Least-norm formulations have no inequality: refuse a bounded slip friction."""
    if op.slip_friction:
        raise NotApplicable(
            f"formulation {formulation!r} cannot bound a slip joint's friction force "
            f"({', '.join(f.slip for f in op.slip_friction)}); use positive, min_max, "
            "socp_face or compliance")


def equalities(op: Operator, i: int) -> tuple[np.ndarray, np.ndarray]:
    """``A x = b`` reduced to ``rank(A)`` independent rows (``S V' x = U' b`` from the
    SVD): the Newton-Euler rows are dependent along the motion, and several solvers
    (quadprog, ECOS) refuse dependent equality constraints.
    """
    return _independent_rows(op.A[i], op.b[i])


def _independent_rows(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    u, s, vt = np.linalg.svd(A, full_matrices=False)
    rank = numerical_rank(s)
    return s[:rank, None] * vt[:rank], u[:, :rank].T @ b


def orthogonal_equalities(A: np.ndarray, b: np.ndarray, held=()):
    """``A x = b`` with ``x[held] = 0`` as mutually orthogonal rows, and an orthonormal
    basis of their null space, from one SVD of ``A`` without the held columns: rows
    ``S V' x = U' b`` (zero in the held columns) then ``x_j = 0`` per held column; the
    basis is the SVD's remaining right singular vectors, zero in the held rows. Returns
    ``(rows, rhs, basis)``, (r + h, n), (r + h,), (n, n - r - h).

    The conic recasts hand the basis to the reduced form (``Conic.null_space``), which
    then needs no factorization of its own. Held columns must not change the column
    space (an end face is one of a pair of opposite columns): the rank stays ``A``'s.
    """
    n = A.shape[1]
    free = np.setdiff1d(np.arange(n), held)
    u, s, vt = np.linalg.svd(A[:, free])
    rank = numerical_rank(s)
    rows = np.zeros((rank + len(held), n))
    rows[:rank, free] = s[:rank, None] * vt[:rank]
    rows[rank + np.arange(len(held)), list(held)] = 1.0
    basis = np.zeros((n, len(free) - rank))
    basis[free] = vt[rank:].T
    return rows, np.concatenate([u[:, :rank].T @ b, np.zeros(len(held))]), basis


def _padded(basis: np.ndarray, extra: int) -> np.ndarray:
    """The null-space basis with ``extra`` unknowns that no equality row constrains."""
    n, k = basis.shape
    out = np.zeros((n + extra, k + extra))
    out[:n, :k] = basis
    out[n:, k:] = np.eye(extra)
    return out


def _load_scale(b: np.ndarray) -> float:
    """``||b||``, the unit in which the conic and QP recasts state their unknowns."""
    return max(float(np.linalg.norm(b)), SCALE_FLOOR_N)


def _minus_identity_rows(columns, n: int) -> np.ndarray:
    """Rows ``-e_j'`` for ``j`` in ``columns``: ``x_j >= 0`` as ``A z + s = 0, s >= 0``."""
    rows = np.zeros((len(columns), n))
    rows[np.arange(len(columns)), list(columns)] = -1.0
    return rows


def contacts(op: Operator) -> list[list[int]]:
    """Column groups that form one contact force (a bearing, a radial trunnion force, an
    end face, a slip joint's shear force, its moments and axial force apart since they
    are not one vector): each contact's kind says, by its laws' groups.
    """
    return [list(law.columns) for law in contact_laws(op)]


def min_norm(op: Operator, i: int, name: str = "") -> LS:
    _no_bounds(op, name)
    A, b = equalities(op, i)
    return LS(checks=checks(op, i, signs=False, pairs=False), formulation=name, A=A, b=b)


def min_norm_scaled(op: Operator, i: int, name: str = "",
                    reference_length_m: float = 1.0) -> LS:
    _no_bounds(op, name)
    A = op.A[i].copy()
    A[op.moment_rows] /= reference_length_m
    weights = np.linalg.norm(A, axis=0) ** 2
    A, b = equalities(op, i)
    return LS(checks=checks(op, i, signs=False, pairs=False), formulation=name,
              A=A, b=b, weights=weights)


def positive(op: Operator, i: int, name: str = "") -> QP:
    """Unknowns in units of ``||b||`` (as ``min_max``): interior-point QP solvers keep
    their relative accuracy from zero to very large loads.
    """
    n = len(op.names)
    lb = np.where(op.unilateral, 0.0, -np.inf)
    A, b = equalities(op, i)
    scale = _load_scale(b)
    G = slip_rows(op, i)
    return QP(checks=checks(op, i), formulation=name,
              to_forces=Scaled(scale), P=np.eye(n), q=np.zeros(n),
              A=A, b=b / scale, lb=lb, G=G if len(G) else None,
              h=np.zeros(len(G)) if len(G) else None)


def min_max(op: Operator, i: int, name: str = "") -> Conic:
    """Variables ``z = (x, t) / ||b||`` (forces in units of the load, which keeps the
    interior-point iterates well scaled); cones: equality, end faces >= 0, one SOC per
    contact. An end face's ``|x| <= t`` stays a cone here: as the linear row ``x <= t``
    next to ``x >= 0`` (the same optimum, 8 cones fewer) it left moreau's full form
    ``AlmostSolved`` at one paper instant of 1001; the solvers' reduced form folds it into
    that row, for every backend alike.
    """
    A, b, basis = orthogonal_equalities(op.A[i], op.b[i])
    m, n = A.shape
    t = n
    scale = _load_scale(b)
    blocks, rhs, cones = [np.hstack([A, np.zeros((m, 1))])], [b / scale], [("zero", m)]
    uni = np.flatnonzero(op.unilateral)
    G = slip_rows(op, i, n + 1)
    blocks.append(np.vstack([_minus_identity_rows(uni, n + 1), G]))
    rhs.append(np.zeros(len(uni) + len(G)))
    cones.append(("nonneg", len(uni) + len(G)))
    for group in contacts(op):
        soc = np.zeros((len(group) + 1, n + 1))
        soc[0, t] = -1.0
        soc[np.arange(1, len(group) + 1), group] = -1.0
        blocks.append(soc)
        rhs.append(np.zeros(len(group) + 1))
        cones.append(("soc", len(group) + 1))
    P = np.zeros((n + 1, n + 1))
    P[:n, :n] = MIN_MAX_NORM_WEIGHT * np.eye(n)
    q = np.zeros(n + 1)
    q[t] = 1.0
    return Conic(checks=checks(op, i, pairs=False), formulation=name,
                 to_forces=Scaled(scale, n), P=P, q=q, A=np.vstack(blocks),
                 b=np.concatenate(rhs), cones=tuple(cones), null_space=_padded(basis, 1))


def lcp(op: Operator, i: int, name: str = "") -> LCP:
    """``positive`` as ``0 <= lam ⟂ M lam + q >= 0`` with ``M = N_u N_u'``, ``q = x0_u``.

    With ``x = x0 + N y`` (``N'x0 = 0``), ``positive`` is ``min 1/2 y'y`` s.t.
    ``N_u y + x0_u >= 0``; its KKT conditions give ``y = N_u' lam`` and the LCP.
    """
    _no_bounds(op, name)
    d = determinacy(op, i)
    x0, N = d.min_norm, d.null_basis
    Nu = N[op.unilateral]
    return LCP(checks=checks(op, i), formulation=name,
               to_forces=NullSpaceMap(x0, N, tuple(np.flatnonzero(op.unilateral).tolist())),
               M=Nu @ Nu.T, q=x0[op.unilateral])


@dataclass(frozen=True, eq=False)
class NullSpaceMap:
    """The LCP's map from the end-face multipliers ``lam`` to the forces (N): ``x = x0 +
    N N_u' lam`` (``x0`` the least-norm answer, ``N`` the null-space basis, ``N_u`` its
    rows ``unilateral``). Called on one point; :meth:`stacked` maps the points of a
    run's instants at once (the check pass's hook, as :class:`~.problems.Scaled`'s).
    """

    x0: np.ndarray
    N: np.ndarray
    unilateral: tuple[int, ...]

    def __call__(self, lam) -> np.ndarray:
        return self.x0 + self.N @ (self.N[list(self.unilateral)].T @ np.asarray(lam, float))

    @staticmethod
    def stacked(maps: list[NullSpaceMap], Z: np.ndarray) -> np.ndarray:
        """The forces (T, n) of the points ``Z`` (T, u), row ``k`` by ``maps[k]``: the
        same products per instant, stacked (they agree with a call each to rounding).
        A ``ValueError`` for maps of other structures (other shapes or end faces).
        """
        if len({(m.N.shape, m.unilateral) for m in maps}) != 1:
            raise ValueError("the maps are of different structures")
        N = np.array([m.N for m in maps])
        y = np.matmul(N[:, list(maps[0].unilateral)].transpose(0, 2, 1),
                      np.asarray(Z, float)[:, :, None])
        return np.array([m.x0 for m in maps]) + np.matmul(N, y)[:, :, 0]


def socp_face(op: Operator, i: int, name: str = "") -> Conic:
    """``positive`` with each end face also carrying a moment ``m`` normal to its
    trunnion axis, inside its centre-of-pressure cone ``||m|| <= rt f``: the paper's
    rim contact (eqs. 33-36, 42-43) made convex. The face may press anywhere on its
    disc of radius ``rt`` instead of at one rim point.

    Unknowns: the operator's forces, then ``<face>.m_<e>`` (N·m) per end face, acting
    on the pin and the opposite on the yoke. Objective: least ``||x||^2 + ||m / rt||^2``.

    Complementarity is imposed as in ``friction``: with moments, pushing both faces of
    a pair would buy moment capacity that the axial clearance does not allow (only one
    face of a pair can touch), so the face idle in the least-norm answer is held at 0.
    """
    extra = [(members, _cone(spec)) for c in _extended_contacts(op)
             for members, spec in c.element_kind.rim_moments(op, i, c)]
    if not extra:
        raise NotApplicable(f"formulation {name!r} adds moments to end faces; scene "
                            f"{op.scene.name!r} has none (its joints have no cross-pins)")
    return _extended(op, i, extra, name,
                     idle=_idle_faces(op, determinacy(op, i).min_norm))


def friction(op: Operator, i: int, name: str = "") -> Conic:
    """``positive`` plus Coulomb friction in the joints (the scene's ``friction``
    effect, coefficient ``friction_coefficient``); rolling bearings take none.

    - end faces: a tangential force ``t`` in the face plane at the face centre,
      ``||t|| <= mu f``;
    - trunnion radial contacts: a force along the trunnion axis ``a``,
      ``|a| <= mu n0 · r`` with ``n0`` the direction of the frictionless least-norm
      radial force at the same instant: Coulomb's cone about that contact normal, an
      inner approximation of ``|a| <= mu ||r||`` (which is not convex).

    With friction, pushing both end faces of a trunnion pair would buy friction that
    the clearance does not allow, so complementarity is imposed: the face that pushes
    in the frictionless least-norm answer is the active one, the other is held at zero.
    Objective: least ``||x||^2`` over forces and friction forces.
    """
    scene = op.scene
    if not scene.has("friction"):
        raise NotApplicable(f"formulation {name!r} needs a scene whose effects include "
                            "'friction'")
    mu = scene.contact.friction_coefficient
    frameless = determinacy(op, i).min_norm
    extra = [(members, _cone(spec)) for c in _extended_contacts(op)
             for members, spec in c.element_kind.friction_forces(op, i, c, frameless, mu)]
    return _extended(op, i, extra, name, idle=_idle_faces(op, frameless))


def _extended_contacts(op: Operator) -> list:
    """The contacts whose kind adds formulations' unknowns
    (:class:`~cardan_forces.driveline.elements.base.FormulationExtras`), in column order.
    """
    return [c for c in op.contacts if isinstance(c.element_kind, FormulationExtras)]


def _cone(spec: dict):
    """The cone maker of :func:`_extended` from a kind's cone ``spec`` (apex, scale,
    apex terms): its members are the new unknowns' indices.
    """
    return lambda idx: SecondOrderCone(members=idx, **spec)


class NotApplicable(ValueError):
    """A formulation the scene does not call for (e.g. ``friction`` without friction)."""


def _idle_faces(op: Operator, least: np.ndarray) -> list[int]:
    """Per end-face pair, the face that does not push in the least-norm answer ``least``
    (the pair's columns are opposite, so exactly one of the two is >= 0 there).
    """
    return [a if least[b] - least[a] >= 0 else b for a, b in op.pairs]


def _extended(op: Operator, i: int, extra, formulation: str, idle=()) -> Conic:
    """``positive`` on the operator's forces plus extra named columns; ``extra`` lists
    ``([(name, column, weight), ...], make_cone(indices))`` groups, each group's new
    unknowns bound by the cone ``make_cone`` builds from their indices; ``idle`` are
    columns held at zero. Objective: least ``||x||^2 + sum weight * extra^2``. The
    solver's unknowns are the forces in units of ``||b||`` (as in ``min_max``), which
    keeps interior-point iterates well scaled from zero to very large loads.
    """
    names, columns, weights, cones = list(op.names), [], [], []
    for members, make_cone in extra:
        idx = []
        for name, col, weight in members:
            idx.append(len(names))
            names.append(name)
            columns.append(col)
            weights.append(weight)
        cones.append(make_cone(tuple(idx)))
    A = np.column_stack([op.A[i], *columns])
    n0, n = len(op.names), A.shape[1]
    unilateral = np.concatenate([op.unilateral, np.zeros(n - n0, bool)])
    check = ForceChecks(A=A, b=op.b[i], names=tuple(names), unilateral=unilateral,
                        pairs=op.pairs, cones=tuple(cones) + slip_cones(op, i))
    rows, rhs_eq, basis = orthogonal_equalities(A, op.b[i], held=_held(idle, cones))
    blocks = [rows]
    scale = _load_scale(op.b[i])
    rhs = [rhs_eq / scale]
    cone_list = [("zero", len(rows))]
    uni = np.flatnonzero(unilateral)
    G = slip_rows(op, i, n)
    blocks.append(np.vstack([_minus_identity_rows(uni, n), G]))
    rhs.append(np.zeros(len(uni) + len(G)))
    cone_list.append(("nonneg", len(uni) + len(G)))
    for c in cones:
        soc = np.zeros((1 + len(c.members), n))
        soc[0] = -c.apex_row(n)
        soc[np.arange(1, 1 + len(c.members)), list(c.members)] = -1.0
        blocks.append(soc)
        rhs.append(np.zeros(1 + len(c.members)))
        cone_list.append(("soc", 1 + len(c.members)))
    P = np.diag(np.concatenate([np.ones(n0), weights]))
    return Conic(checks=check, formulation=formulation, to_forces=Scaled(scale),
                 P=P, q=np.zeros(n), A=np.vstack(blocks), b=np.concatenate(rhs),
                 cones=tuple(cone_list), null_space=basis)


def _held(idle, cones) -> list[int]:
    """Columns held at zero: the idle ones and the members of every cone whose apex is
    an idle column alone (``||members|| <= scale * 0`` forces them to zero anyway; held,
    they leave the reduced form's unknowns, which the cone would only pin down).
    """
    idle = list(idle)
    return idle + [k for c in cones if c.apex in idle and not c.apex_terms
                   for k in c.members]


@LastMade
def contact_laws(op: Operator) -> tuple[Law, ...]:
    """Every contact force (a group of columns) with its compliance law, in column
    order, as each contact's kind gives them (:meth:`~cardan_forces.driveline.elements.
    base.ElementKind.laws`): bearings and slip joints linear, the Cardan joints' contacts
    Hertz (eqs. 76-77), each kind's module saying why. The same at every instant: made
    once per operator.
    """
    return tuple(law for c in op.contacts for law in c.element_kind.laws(c, op.scene))


def compliance(op: Operator, i: int, name: str = "", law: str = "linear",
               clearance: bool | None = None):
    """Least complementary energy ``sum phi*_c(f_c) + gap_c ||f_c||`` on ``A x = b`` with
    end faces >= 0 (Menabrea): the member of the rigid set that a compliant world picks.

    ``law="linear"``: ``phi* = ||f||^2 / (2 k)`` with the joints' Hertz K made linear by
    its secant at the scene's ``damping_full_depth_m`` (d_max): a QP when there are no
    gaps. ``law="hertz"``: ``f = K d^n`` (bearings stay linear), ``phi* = n/(n+1)
    K^(-1/n) ||f||^((n+1)/n)`` through power cones. Gaps are the scene's clearances and
    enter only when it calls for ``clearance`` (or ``clearance=True``).

    In the conic form each end-face pair (opposite columns, the same law and gap) is one
    signed axial force ``a`` with ``F_a = max(a, 0)``, ``F_b = max(-a, 0)``: the same
    problem, since its optimum never presses both faces, but with complementarity exact
    by construction instead of to the interior-point tolerance (the Hertz energy
    ``~ f^(5/3)`` is too flat near 0 to pin an idle face down).

    The solver's unknowns are the forces in units of ``sb = ||b||`` and the objective is
    divided by its largest coefficient, so the data stay O(1) from zero to very large
    loads (the power-cone epigraphs scale by ``sb^((n+1)/n)``, which leaves their cone
    rows unchanged).
    """
    scene = op.scene
    use_gaps = scene.has("clearance") if clearance is None else clearance
    n_exp, d_ref = scene.contact.exponent, scene.contact.damping_full_depth_m
    given = contact_laws(op)
    laws = [(list(law.columns), law.stiffness, law.gap_m) for law in given]
    is_bearing = [not law.hertz for law in given]  # a linear law
    A, b = equalities(op, i)
    m, n = A.shape
    sb = _load_scale(b)
    b = b / sb
    if law == "linear" and not use_gaps:
        G = slip_rows(op, i)
        p = np.zeros(n)
        for (group, k, _), bearing in zip(laws, is_bearing):
            p[group] = 1.0 / (k if bearing else k * d_ref ** (n_exp - 1.0))
        return QP(checks=checks(op, i), formulation=name, to_forces=Scaled(sb),
                  P=np.diag(p / p.max()), q=np.zeros(n), A=A, b=b,
                  lb=np.where(op.unilateral, 0.0, -np.inf), G=G if len(G) else None,
                  h=np.zeros(len(G)) if len(G) else None)
    return _compliance_conic(op, i, laws, is_bearing, law == "hertz", use_gaps, sb, name)


def _compliance_conic(op: Operator, i: int, laws, is_bearing, hertz: bool, use_gaps: bool,
                      sb: float, name: str) -> Conic:
    """:func:`compliance`'s conic form, ``z = (x, then r_c and s_c per contact)``; the
    second face of each end-face pair is held at 0, the first one signed.

    Every contact has ``r_c >= ||f_c||`` (a second-order cone) and its energy on
    ``r_c`` (``P`` for a linear law), plus ``s_c`` (a power cone) for a Hertz law. The
    energy sits on ``r_c``, not on the force itself, for every contact, end faces too:
    the shortcuts with the same optimum leave an interior point stalled where idle faces
    sit at a cone's apex, or less accurate under very large loads.
    """
    n = len(op.names)
    merged = {b_: a_ for a_, b_ in op.pairs}
    kept = [c for c, (group, _, _) in enumerate(laws) if group[0] not in merged]
    laws, is_bearing = [laws[c] for c in kept], [is_bearing[c] for c in kept]
    power = [hertz and not bearing for bearing in is_bearing]
    nz = n + len(laws) + sum(power)
    rows, rhs_eq, basis = orthogonal_equalities(op.A[i], op.b[i], held=list(merged))
    blocks = [np.hstack([rows, np.zeros((len(rows), nz - n))])]
    rhs, cones = [rhs_eq / sb], [("zero", len(rows))]
    uni = [j for j in np.flatnonzero(op.unilateral) if j not in merged and j not in
           merged.values()]
    G = slip_rows(op, i, nz)
    blocks.append(np.vstack([_minus_identity_rows(uni, nz), G]))
    rhs.append(np.zeros(len(uni) + len(G)))
    cones.append(("nonneg", len(uni) + len(G)))
    P, q = _contact_energies(op.scene, laws, is_bearing, power, use_gaps, sb, n,
                             (blocks, rhs, cones))
    unit = max(np.abs(q).max(), P.max())
    signed = tuple((a_, b_) for b_, a_ in merged.items())
    return Conic(checks=checks(op, i), formulation=name, to_forces=Scaled(sb, n, signed),
                 P=P / unit, q=q / unit, A=np.vstack(blocks), b=np.concatenate(rhs),
                 cones=tuple(cones), null_space=_padded(basis, nz - n))


def _contact_energies(scene, laws, is_bearing, power, use_gaps, sb, n, out):
    """``P`` and ``q`` of :func:`_compliance_conic`'s energies; each contact's cone rows
    are appended to ``out`` = ``(blocks, rhs, cones)``. Units as in :func:`compliance`.
    """
    n_exp, d_ref = scene.contact.exponent, scene.contact.damping_full_depth_m
    nz = n + len(laws) + sum(power)
    P, q = np.zeros((nz, nz)), np.zeros(nz)
    blocks, rhs, cones = out
    unknowns = iter(range(n, nz))
    for (group, k, gap), bearing, pw in zip(laws, is_bearing, power):
        load = next(unknowns)  # r_c, what the energy acts on
        soc = np.zeros((len(group) + 1, nz))
        soc[0, load] = -1.0
        soc[np.arange(1, len(group) + 1), group] = -1.0
        blocks.append(soc)
        rhs.append(np.zeros(len(group) + 1))
        cones.append(("soc", len(group) + 1))
        q[load] = gap if use_gaps else 0.0
        if pw:
            s = next(unknowns)
            q[s] = n_exp / (n_exp + 1.0) * k ** (-1.0 / n_exp) * sb ** (1.0 / n_exp)
            cone = np.zeros((3, nz))
            cone[0, s], cone[2, load] = -1.0, -1.0
            blocks.append(cone)
            rhs.append(np.array([0.0, 1.0, 0.0]))
            cones.append(("pow", n_exp / (n_exp + 1.0)))
        else:
            P[load, load] = sb / (k if bearing else k * d_ref ** (n_exp - 1.0))
    return P, q

