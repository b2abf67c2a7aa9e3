"""Backends ``newton``, ``newton-batched``, ``newton-batched-warm``: the contact problems
of the compliance family solved as the physics engines solve contact, by Newton's
method on an unconstrained convex dual (MuJoCo's default solver on the reduced primal,
Drake's SAP), with an exact line search.

Every formulation this family takes is ``min sum_c psi_c(||f_c||)`` over the contact
forces ``f`` (each contact ``c`` a group of columns) on the equilibrium ``E f = e``,
``psi_c`` a contact's complementary energy: ``k r^2 / 2`` (least norm, linear law) or
``(n / (n+1)) k^(-1/n) r^((n+1)/n)`` (Hertz, ``n = 3/2``), plus ``g r`` for a
clearance ``g``; a column that may only push is a group of one with ``f >= 0``. With
``d = E'u`` the contacts' deformations (``u`` the bodies' displacements, one per row,
the multiplier of ``E f = e``), its dual is

    min_u  Phi(u) = sum_c phi_c(d_c) - e'u,   phi_c(d) = (s - g)_+ r(s) / (n + 1),

``s = ||d_c||`` (``max(d, 0)`` for a pushing column), ``r(s) = ((s - g)_+ / k)^n`` the
contact's load and ``f_c = r(s) d_c / s`` its force (``k`` the stiffness of the
linear law, ``n = 1``; ``p c`` for Hertz's ``c r^p`` energy, ``n = 1 / (p - 1)``).
``Phi`` is convex and once (Hertz: twice) continuously differentiable; its gradient
is the equilibrium residual ``E f - e`` and its Hessian ``sum_c E_c H_c E_c'`` with
``H_c = r' u u' + (r / s)(I - u u')`` (``u = d_c / s``).

Newton's method: the step solves ``(H + rho V V' + mu I) du = -(I - V V') grad``, a
Cholesky factor of ``m x m``; ``V`` spans the left null space of ``E`` (the directions
along which no contact does work: the drive line's own motion), found once per instant
from the factor of the nominal Hessian ``H0`` (every contact loaded at the scale of
``e``) and held out of ``u`` explicitly, so a dependent equilibrium row (the operator's
rows are dependent along the motion) never decides a step; ``mu = REG_RTOL rho``
(``rho`` the mean diagonal of ``H0``) keeps the factor defined where no contact does
work along a direction (idle end faces, open clearances), whose step the line search
then bounds. The line search minimizes ``Phi`` along the step exactly (a safeguarded
Newton iteration on the slope, ``O(n)`` an evaluation). A cold start takes its first
step with ``H0``; a warm start fits ``u`` to the deformations ``d`` of a neighbouring
answer. The iteration stops when ``||(I - V V') grad|| <= tol ||e||``.

``soften`` (option, >= 0): the equilibrium softened as MuJoCo and SAP soften their
constraints, ``+ soften rho ||u||^2 / 2`` in the dual, i.e. the primal
``min sum psi_c + ||E f - e||^2 / (2 soften rho)``: the answer is unique for any
``soften > 0`` and leaves the rigid set by ``O(soften)``
(:mod:`cardan_forces.experiments.regularization` measures the cost).

The problem's data are read as they are, never trusted: :func:`parse` recognizes the
structure above in a problem's conic form (zero rows, sign rows, one second-order cone
per contact, a power cone per Hertz contact) and refuses anything else. The answer is
handed back in the problem's own variable with every multiplier of its conic rows,
derived from ``u`` (``y = -u`` on the equilibrium rows), so the package judges it as
any other backend's. The method runs compiled where numba is installed (extra
``numba``, :mod:`._newton_kernels`); :func:`newton_numpy` is its NumPy reference.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from cardan_forces.formulations.batch import ConicBatch, LeastNormBatch
from cardan_forces.formulations.problems import LCP, Conic, LastMade

from .batch import BatchOutcome
from .optimality import cone_layout
from .record import Outcome
from .registry import Backend

EXTRAS: dict[str, str | None] = {"newton": None, "newton-batched": None,
                                 "newton-batched-warm": None}

TOL = 1e-12
"""Default stopping rule: ``||E f - e|| <= TOL ||e||`` (the equilibrium residual, the
only optimality condition the dual iteration leaves inexact)."""
MAX_ITER = 60
"""Newton steps before an instant is left ``inaccurate``."""
NULL_RTOL = 1e-10
"""A pivot of ``H0``'s Cholesky factor below this, relative to its diagonal entry,
marks a row dependent on the rows before it (a left null direction of ``E``)."""
REG_RTOL = 1e-13
"""``mu / rho``: the shift that keeps a step's factor positive definite."""
LS_RTOL = 1e-10
"""The line search stops at a slope below this fraction of its start's."""
LS_MAX = 60
"""Line-search evaluations per step."""

STATUS = ("solved", "inaccurate", "inaccurate", "failed", "failed")
"""Status codes of :func:`newton_numpy` and the kernel, by index."""
REASONS = ("", "no convergence in the iteration limit", "the line search made no progress",
           "non-finite numbers", "a step's factor is not positive definite")
"""Why, by status code."""


@dataclass(frozen=True)
class Groups:
    """The contacts' structure: ``members`` (G, w) columns of ``E`` per contact (padded
    with 0, ``mask`` 1 where real), ``signed`` (G,) a pushing column (a group of one
    with ``f >= 0``), ``n`` (G,) the law's exponent (1 linear).
    """

    members: np.ndarray
    mask: np.ndarray
    signed: np.ndarray
    n: np.ndarray


def groups_of(lists, signed, n) -> Groups:
    """:class:`Groups` of column lists ``lists`` with their ``signed`` flags and ``n``."""
    width = max(len(c) for c in lists)
    members = np.zeros((len(lists), width), np.int64)
    mask = np.zeros((len(lists), width))
    for k, cols in enumerate(lists):
        members[k, :len(cols)] = cols
        mask[k, :len(cols)] = 1.0
    return Groups(members, mask, np.asarray(signed, bool), np.asarray(n, float))


def evaluate(d, groups: Groups, k, g):
    """Per contact at deformations ``d`` (..., nv): load ``r``, slope ``r'``, ``r / s``,
    the unit direction (..., G, w) and the energy; pushing columns are one-sided, an
    exactly touching linear contact counts as loaded (its one-sided slope).
    """
    dg = d[..., groups.members] * groups.mask
    norm = np.sqrt(np.einsum("...gw,...gw->...g", dg, dg))
    s = np.where(groups.signed, dg[..., 0], norm)
    n = groups.n
    over = np.maximum(s - g, 0.0)
    loaded = (s > g) | ((n == 1.0) & (s >= g))
    r = np.where(loaded, (over / k) ** n, 0.0)
    slope = np.where(loaded, n * (over / k) ** (n - 1.0) / k, 0.0)
    ratio = np.where(s > 0, r / np.where(s > 0, s, 1.0), slope)
    unit = np.where(groups.signed[:, None], groups.mask,
                    dg / np.where(norm > 0, norm, 1.0)[..., None])
    return r, slope, ratio, unit, over * r / (n + 1.0)


def forces(d, groups: Groups, k, g) -> np.ndarray:
    """The forces (..., nv) at deformations ``d`` (every column is in one contact)."""
    r, _, _, unit, _ = evaluate(d, groups, k, g)
    f = np.zeros(np.shape(d))
    real = groups.mask > 0
    f[..., groups.members[real]] = (r[..., None] * unit)[..., real]
    return f


def _hessian(E, groups: Groups, ratio, slope, unit, rho_soft):
    """``sum_c E_c H_c E_c' + rho_soft I``."""
    beta = np.zeros(E.shape[1])
    np.add.at(beta, groups.members, ratio[:, None] * groups.mask)
    Y = np.einsum("mgw,gw->mg", E[:, groups.members], unit * groups.mask)
    H = (E * beta) @ E.T + (Y * (slope - ratio)) @ Y.T
    return H + rho_soft * np.eye(len(H))


def nominal(E, e, groups: Groups, k):
    """``H0 = sum_c c0 E_c E_c'`` with ``c0 = n F^(1 - 1/n) / k`` the slope at a load
    ``F = ||e||``, and ``rho`` its mean diagonal.
    """
    F = max(float(np.linalg.norm(e)), 1e-300)
    c0 = groups.n * F ** (1.0 - 1.0 / groups.n) / k
    beta = np.zeros(E.shape[1])
    np.add.at(beta, groups.members, c0[:, None] * groups.mask)
    H0 = (E * beta) @ E.T
    return H0, max(float(np.trace(H0)) / len(H0), 1e-300)


def null_basis(H0) -> np.ndarray:
    """An orthonormal basis (m, k) of ``H0``'s null space (the left null space of ``E``):
    the eigenvectors whose eigenvalue is below ``NULL_RTOL`` of the largest diagonal
    entry (the reference of the kernel's pivoted Cholesky).
    """
    w, vecs = np.linalg.eigh(H0)
    return vecs[:, w <= NULL_RTOL * max(float(np.max(np.diag(H0))), 1e-300)]


def line_search(d, delta, u, du, e, groups: Groups, k, g, rho_soft) -> float:
    """The step length ``t >= 0`` minimizing ``Phi(u + t du)`` (``delta = E'du``):
    safeguarded Newton on the slope, the bracket grown until the slope turns.
    """
    def slope(t):
        r, sl, ratio, unit, _ = evaluate(d + t * delta, groups, k, g)
        dg = delta[groups.members] * groups.mask
        along = np.einsum("gw,gw->g", unit, dg)
        first = r @ along - e @ du + rho_soft * (u + t * du) @ du
        second = (ratio @ np.einsum("gw,gw->g", dg, dg) + (sl - ratio) @ along ** 2
                  + rho_soft * du @ du)
        return first, second

    start = slope(0.0)[0]
    if not start < 0:
        return 0.0
    lo, hi, t = 0.0, np.inf, 1.0
    for _ in range(LS_MAX):
        first, second = slope(t)
        if abs(first) <= LS_RTOL * abs(start):
            return t
        lo, hi = (t, hi) if first < 0 else (lo, t)
        guess = t - first / second if second > 0 else np.inf
        if not lo < guess < hi:
            guess = 2.0 * t if hi == np.inf else 0.5 * (lo + hi)
        t = guess
    return lo if hi == np.inf else 0.5 * (lo + hi)


def newton_numpy(E, e, groups: Groups, k, g, d0=None, start=None, chain=False,
                 tol=TOL, max_iter=MAX_ITER, soften=0.0):
    """The method at T instants, one after the other (the kernel's NumPy reference).

    ``E`` (T, m, nv), ``e`` (T, m), ``k``, ``g`` (T, G); ``d0`` (T, nv) deformations to
    start from where ``start`` (T,) is set; ``chain``: each instant after the first
    starts from the answer before it. Returns ``u`` (T, m), ``d`` (T, nv), status codes
    and iterations (T,).
    """
    T, m, nv = E.shape
    u_out, d_out = np.zeros((T, m)), np.zeros((T, nv))
    status, iters = np.zeros(T, np.int64), np.zeros(T, np.int64)
    for i in range(T):
        hint = d_out[i - 1] if chain and i else (
            d0[i] if start is not None and start[i] else None)
        u_out[i], status[i], iters[i] = _one(E[i], e[i], groups, k[i], g[i], hint, tol,
                                             max_iter, soften)
        d_out[i] = E[i].T @ u_out[i]
    return u_out, d_out, status, iters


def _one(E, e, groups, k, g, hint, tol, max_iter, soften):
    """One instant of :func:`newton_numpy`: ``(u, status, iterations)``."""
    if not (np.all(np.isfinite(E)) and np.all(np.isfinite(e)) and np.all(np.isfinite(k))
            and np.all(np.isfinite(g)) and np.all(k > 0)):
        return np.zeros(len(e)), 3, 0
    H0, rho = nominal(E, e, groups, k)
    V = null_basis(H0)
    project = np.eye(len(e)) - V @ V.T
    rho_soft = soften * rho
    u = np.zeros(len(e)) if hint is None else project @ np.linalg.lstsq(E.T, hint,
                                                                        rcond=None)[0]
    scale = max(float(np.linalg.norm(e)), 1e-300)
    for it in range(max_iter + 1):
        d = E.T @ u
        r, slope, ratio, unit, _ = evaluate(d, groups, k, g)
        grad = project @ (E @ forces(d, groups, k, g) - e + rho_soft * u)
        if not np.all(np.isfinite(grad)):
            return u, 3, it
        if np.linalg.norm(grad) <= tol * scale:
            return u, 0, it
        if it == max_iter:
            break
        H = H0 if it == 0 and hint is None else _hessian(E, groups, ratio, slope, unit,
                                                         rho_soft)
        try:
            factor = np.linalg.cholesky(H + rho * V @ V.T + REG_RTOL * rho * np.eye(len(e)))
        except np.linalg.LinAlgError:
            return u, 4, it
        du = -np.linalg.solve(factor.T, np.linalg.solve(factor, grad))
        t = line_search(d, E.T @ du, u, du, e, groups, k, g, rho_soft)
        if t == 0.0:
            return u, 2, it
        u = u + t * du
    return u, 1, max_iter


@dataclass(frozen=True)
class Layout:
    """Where a conic problem's contacts are (:func:`parse`): ``force`` the variables that
    are forces (the columns of ``E``), ``groups`` their contacts, ``eq`` the equilibrium
    rows kept, ``held`` variables a row of their own fixes (``held_rows``); per contact
    the variable whose ``P`` diagonal is a linear law's ``k`` (``a_idx``), whose ``q`` is
    the gap (``g_idx``) or the power cone's coefficient (``c_idx``), ``p`` its power
    (``r^p``), the load variable ``r_col`` and the first rows of its second-order cone
    (``soc_row``), power cone (``pow_row``) and sign row (``nn_row``), -1 where none.
    """

    force: np.ndarray
    groups: Groups
    eq: np.ndarray
    held: np.ndarray
    held_rows: np.ndarray
    a_idx: np.ndarray
    g_idx: np.ndarray
    c_idx: np.ndarray
    p: np.ndarray
    r_col: np.ndarray
    soc_row: np.ndarray
    pow_row: np.ndarray
    nn_row: np.ndarray


class NotContact(ValueError):
    """A problem without the structure this family solves."""


def _single(pattern, row) -> int:
    """The one column of ``row`` with a nonzero (``NotContact`` otherwise)."""
    cols = np.flatnonzero(pattern[row])
    if len(cols) != 1:
        raise NotContact(f"row {row} is not a single variable")
    return int(cols[0])


def parse(P_pattern, q_pattern, A_pattern, A, b, cones) -> Layout:
    """The :class:`Layout` of a conic problem's structure (``*_pattern``: nonzeros at
    some instant; ``A``, ``b`` one instant's numbers, whose unit entries are checked):
    ``NotContact`` for anything else than the energies of :mod:`this family <.newton_>`.
    """
    if np.any(P_pattern & ~np.eye(len(P_pattern), dtype=bool)):
        raise NotContact("P is not diagonal")
    zero, nonneg, apex, members, mask, pows, alphas = cone_layout(tuple(cones))
    signed = {}
    for row in nonneg:
        j = _single(A_pattern, row)
        if A[row, j] != -1.0 or b[row] != 0.0:
            raise NotContact("a sign row is not x >= 0")
        signed[j] = int(row)
    socs = _cones(A_pattern, A, b, apex, members, mask, pows, alphas)
    return _layout(P_pattern, q_pattern, A_pattern, A, zero, signed, socs)


def _cones(pattern, A, b, apex, members, mask, pows, alphas):
    """Per second-order cone ``(r, members, soc row, (s, pow row, p) or None)``."""
    found, loads = [], {}
    for row, alpha in zip(pows, alphas):
        s, r = _single(pattern, row[0]), _single(pattern, row[2])
        if (np.any(pattern[row[1]]) or tuple(b[row]) != (0.0, 1.0, 0.0)
                or A[row[0], s] != -1.0 or A[row[2], r] != -1.0):
            raise NotContact("a power cone is not s >= r^p")
        loads[r] = (s, int(row[0]), 1.0 / alpha)
    for a, rows, m in zip(apex, members, mask):
        rows = rows[m > 0]
        r = _single(pattern, a)
        cols = [_single(pattern, row) for row in rows]
        if np.any(A[[a, *rows], [r, *cols]] != -1.0) or np.any(b[[a, *rows]] != 0.0):
            raise NotContact("a second-order cone is not r >= ||f||")
        found.append((r, cols, int(a), loads.pop(r, None)))
    if loads:
        raise NotContact("a power cone on no contact's load")
    return found


def _layout(P_pattern, q_pattern, pattern, A, zero, signed, socs) -> Layout:
    """:func:`parse`'s contacts: the cones' and then every variable with a ``P`` entry
    of its own; the rest must be held by a row of their own.
    """
    diag = np.diag(P_pattern)
    lists, rows = [], []  # rows: (signed, n, a, g, c, p, r, soc, pow, nn)
    taken = set()
    for r, cols, soc, power in socs:
        if any(diag[cols]) or any(q_pattern[cols]) or (len(cols) > 1 and any(
                c in signed for c in cols)):
            raise NotContact("a contact's force carries energy of its own")
        if power is not None and diag[r]:
            raise NotContact("a contact with both a linear and a power law")
        s, prow, p = power if power is not None else (-1, -1, 0.0)
        lists.append(cols)
        rows.append((cols[0] in signed and len(cols) == 1, 1.0 / (p - 1.0) if p else 1.0,
                     -1 if power else r, r if q_pattern[r] else -1, s, p, r, soc, prow,
                     signed.get(cols[0], -1) if len(cols) == 1 else -1))
        taken.update([r, *cols, s])
    for j in np.flatnonzero(diag):
        if j in taken:
            continue
        if q_pattern[j] and j not in signed:
            raise NotContact("a two-sided force with a linear term")
        lists.append([int(j)])
        rows.append((j in signed, 1.0, j, j if q_pattern[j] else -1, -1, 0.0, -1, -1, -1,
                     signed.get(j, -1)))
        taken.add(int(j))
    return _assemble(pattern, A, zero, lists, rows, taken)


def _assemble(pattern, A, zero, lists, rows, taken) -> Layout:
    """The :class:`Layout` of the contacts found, the held variables checked."""
    n_z = pattern.shape[1]
    held, held_rows = [], []
    for j in sorted(set(range(n_z)) - taken):
        hits = [r for r in zero if pattern[r, j]]
        if len(hits) != 1 or np.count_nonzero(pattern[hits[0]]) != 1:
            raise NotContact(f"variable {j} has no energy and is not held")
        held.append(j)
        held_rows.append(hits[0])
    if not lists:
        raise NotContact("no contact")
    force = np.array([c for cols in lists for c in cols], np.int64)
    where = {int(c): i for i, c in enumerate(force)}
    eq = np.array([r for r in zero if r not in held_rows], np.int64)
    extra = np.setdiff1d(np.flatnonzero(pattern[eq].any(axis=0)), force)
    if len(extra) and any(c not in held for c in extra):
        raise NotContact("an equilibrium row acts on a load variable")
    cols = list(zip(*rows))
    groups = groups_of([[where[c] for c in cs] for cs in lists], cols[0], cols[1])
    ints = [np.array(c, np.int64) for c in cols[2:5]] + [np.array(cols[5], float)] + [
        np.array(c, np.int64) for c in cols[6:]]
    return Layout(force, groups, eq, np.array(held, np.int64),
                  np.array(held_rows, np.int64), *ints)


def numbers(lay: Layout, P_diag, q, A, b):
    """The instants' numbers in a layout: ``E`` (T, m, nv), ``e`` (T, m), ``k``, ``g``
    (T, G) and the held variables' values (T, h) (``P_diag``, ``q`` (T, n_z), ``A``
    (T, rows, n_z), ``b`` (T, rows)).
    """
    held = b[:, lay.held_rows] / A[:, lay.held_rows, lay.held]
    # E gathered as its transpose (the kernel's layout) from A's rows, in one pass
    E = np.swapaxes(np.swapaxes(A, 1, 2)[:, lay.force[:, None], lay.eq[None, :]], 1, 2)
    e = b[:, lay.eq] - np.einsum("tmh,th->tm", A[:, lay.eq[:, None], lay.held[None, :]],
                                 held)
    power = lay.c_idx >= 0
    k = np.where(power, lay.p * q[:, lay.c_idx], P_diag[:, lay.a_idx])
    g = np.where(lay.g_idx >= 0, q[:, lay.g_idx], 0.0)
    return E, e, k, g, held


def answer(lay: Layout, A, P_diag, q, u, d, k, g, held):
    """The problem's variable ``z`` (T, n_z) and its multipliers ``y`` (T, rows) in
    Clarabel's convention (``P z + q + A'y = 0``) at the dual point ``u`` (deformations
    ``d``): forces, loads ``r = ||f_c||`` and power epigraphs ``r^p`` on their cones'
    boundaries, each cone's multiplier complementary to its slack by construction.
    """
    T, rows, n_z = A.shape
    grp = lay.groups
    r, _, _, unit, _ = evaluate(d, grp, k, g)
    dg = d[:, grp.members] * grp.mask
    s = np.where(grp.signed, dg[..., 0], np.sqrt(np.einsum("tgw,tgw->tg", dg, dg)))
    z, y = np.zeros((T, n_z)), np.zeros((T, rows))
    z[:, lay.force] = forces(d, grp, k, g)
    z[:, lay.held] = held
    y[:, lay.eq] = -u
    cone, power, sign = lay.soc_row >= 0, lay.c_idx >= 0, lay.nn_row >= 0
    z[:, lay.r_col[cone]] = r[:, cone]
    z[:, lay.c_idx[power]] = r[:, power] ** lay.p[power]
    linear_y0 = np.where(power, 0.0, k) * r + g
    y0 = np.where(power, np.maximum(s, g), linear_y0)
    y[:, lay.soc_row[cone]] = y0[:, cone]
    pushed = np.where(grp.signed[:, None], np.maximum(dg, 0.0), dg)
    real = grp.mask[cone] > 0
    member_rows = (lay.soc_row[cone, None] + 1 + np.arange(grp.mask.shape[1]))[real]
    y[:, member_rows] = -pushed[:, cone][:, real]
    qp = sign & ~cone  # a sign row on a force with its own P: y = P x + q - d
    y[:, lay.nn_row[qp]] = linear_y0[:, qp] - dg[:, qp, 0]
    socs = sign & cone
    y[:, lay.nn_row[socs]] = np.maximum(-dg[:, socs, 0], 0.0)
    c = q[:, lay.c_idx[power]]
    at = lay.pow_row[power]
    y[:, at], y[:, at + 1] = c, c * (lay.p[power] - 1.0) * r[:, power] ** lay.p[power]
    y[:, at + 2] = g[:, power] - y0[:, power]
    if len(lay.held):  # the held rows' multipliers from their variables' stationarity
        rest = np.einsum("tmh,tm->th", A[:, lay.eq[:, None], lay.held[None, :]],
                         y[:, lay.eq])
        y[:, lay.held_rows] = -(rest + P_diag[:, lay.held] * held + q[:, lay.held]) / A[
            :, lay.held_rows, lay.held]
    return z, y


def solve_duals(E, e, groups: Groups, k, g, d0=None, start=None, chain=False, tol=TOL,
                max_iter=MAX_ITER, soften=0.0, compiled=None):
    """:func:`newton_numpy`'s answer, compiled where numba is installed (``compiled``:
    force one path; ``True`` without numba is an ``ImportError``).
    """
    use = compiled
    if use is None or use:
        try:
            from ._newton_kernels import newton as kernel
        except ImportError:
            if use:
                raise
            use = False
        else:
            use = True
    if not use:
        return newton_numpy(E, e, groups, k, g, d0, start, chain, tol, max_iter, soften)
    T, m, nv = E.shape
    d0 = np.zeros((T, nv)) if d0 is None else np.ascontiguousarray(d0, float)
    start = np.zeros(T, np.bool_) if start is None else np.asarray(start, np.bool_)
    return kernel(np.ascontiguousarray(np.swapaxes(E, 1, 2), float), spans(E),
                  np.ascontiguousarray(e, float),
                  groups.members, groups.mask, groups.signed, groups.n,
                  np.ascontiguousarray(k, float), np.ascontiguousarray(g, float), d0, start,
                  bool(chain), float(tol), int(max_iter), float(soften),
                  (NULL_RTOL, REG_RTOL, LS_RTOL, float(LS_MAX)))


def spans(E) -> np.ndarray:
    """Per column of ``E`` (T, m, nv), the rows ``[lo, hi)`` outside which it is zero at
    every instant (a contact loads at most two bodies: the kernel skips the rest).
    """
    nonzero = np.any(E != 0, axis=0)
    lo = np.argmax(nonzero, axis=0)
    hi = len(nonzero) - np.argmax(nonzero[::-1], axis=0)
    empty = ~nonzero.any(axis=0)
    return np.stack([np.where(empty, 0, lo), np.where(empty, 0, hi)], axis=1).astype(np.int64)


def deformations(f, groups: Groups, k, g) -> np.ndarray:
    """Deformations (..., nv) that load the contacts with forces ``f`` (a warm start):
    ``d_c = (g + k r^(1/n)) f_c / r`` where ``r = ||f_c|| > 0``, else 0.
    """
    fg = f[..., groups.members] * groups.mask
    r = np.where(groups.signed, np.maximum(fg[..., 0], 0.0),
                 np.sqrt(np.einsum("...gw,...gw->...g", fg, fg)))
    safe = np.where(r > 0, r, 1.0)
    push = np.where(r > 0, (g + k * safe ** (1.0 / groups.n)) / safe, 0.0)
    d = np.zeros(np.shape(f))
    real = groups.mask > 0
    d[..., groups.members[real]] = (push[..., None] * fg)[..., real]
    return d


def _patterns(P, q, A):
    """Nonzero patterns of ``P`` (n, n) or (T, n, n) or None, ``q`` and ``A`` (leading T
    axis optional), over every instant.
    """
    n = np.shape(q)[-1]
    P = np.zeros((n, n)) if P is None else np.asarray(P, float)
    lead = lambda a: a.reshape(-1, *a.shape[-2:]) if a.ndim > 2 else a[None]  # noqa: E731
    q2 = np.asarray(q, float).reshape(-1, n)
    return lead(P).any(axis=0), (q2 != 0).any(axis=0), lead(np.asarray(A, float)) .any(
        axis=0) != 0


def _parse_conic(problem: Conic) -> Layout | None:
    """The problem's layout: found once per structure (its cones and where its data are
    nonzero; an instant of a formulation shares its neighbours'), its unit entries
    checked at every instant.
    """
    P_pattern, q_pattern, A_pattern = _patterns(problem.P, problem.q, problem.A)
    A, b = np.asarray(problem.A, float), np.asarray(problem.b, float)
    key = (tuple(problem.cones), A_pattern.shape, *(np.packbits(x).tobytes() for x in (
        P_pattern, q_pattern, A_pattern)))
    if key not in _STRUCTURES:
        try:
            found = parse(P_pattern, q_pattern, A_pattern, A, b, problem.cones)
        except NotContact:
            found = None
        while len(_STRUCTURES) >= 16:
            _STRUCTURES.pop(next(iter(_STRUCTURES)))
        _STRUCTURES[key] = (found, None if found is None else _unit_entries(found))
    found, units = _STRUCTURES[key]
    if found is None or np.any(A[units] != -1.0) or np.any(b[units[0]] != 0.0):
        return None
    return found


_STRUCTURES: dict = {}
"""Layouts by structure (:func:`_parse_conic`), with their unit entries."""


def _unit_entries(lay: Layout) -> tuple[np.ndarray, np.ndarray]:
    """(rows, columns) of the entries ``-1`` of a layout's cone and sign rows."""
    rows, cols = [], []
    for c in range(len(lay.soc_row)):
        members = lay.force[lay.groups.members[c][lay.groups.mask[c] > 0]]
        if lay.soc_row[c] >= 0:
            rows += list(lay.soc_row[c] + np.arange(len(members) + 1))
            cols += [lay.r_col[c], *members]
        if lay.pow_row[c] >= 0:
            rows += [lay.pow_row[c], lay.pow_row[c] + 2]
            cols += [lay.c_idx[c], lay.r_col[c]]
        if lay.nn_row[c] >= 0:
            rows.append(lay.nn_row[c])
            cols.append(members[0])
    return np.array(rows, np.int64), np.array(cols, np.int64)


def _parse_batch(batch: ConicBatch) -> Layout | None:
    P_pattern, q_pattern, A_pattern = _patterns(batch.P, batch.q, batch.A)
    try:
        return parse(P_pattern, q_pattern, A_pattern, batch.A[0], batch.b[0], batch.cones)
    except NotContact:
        return None


_layout_of = LastMade(_parse_conic)
_batch_layout = LastMade(_parse_batch)
"""A problem's (a batch's) layout, found once for its support check and its solve."""


def _scalars(signed) -> Groups:
    """Every column its own contact, ``signed`` where it may only push."""
    signed = np.asarray(signed, bool)
    return groups_of([[j] for j in range(len(signed))], signed, np.ones(len(signed)))


def supports(problem) -> bool:
    """Whether the family solves ``problem``: the ``lcp`` (through ``positive``, from its
    force checks) or a conic problem of contact energies (:func:`parse`).
    """
    if isinstance(problem, LCP):
        return (problem.formulation == "lcp"
                and problem.n == int(np.sum(problem.checks.unilateral)))
    return _layout_of(problem) is not None


def _message(code: int) -> str:
    return REASONS[int(code)]


def solve_problem(problem, tol=None, initvals=None, soften: float = 0.0,
                  max_iter: int = MAX_ITER, compiled=None) -> Outcome:
    """One instant: ``initvals`` (the problem's variable) starts it from the contacts'
    deformations under those forces; ``soften`` as in the module's text.
    """
    start = time.perf_counter()
    tol = TOL if tol is None else float(tol)
    if isinstance(problem, LCP):
        return _solve_lcp(problem, tol, soften, max_iter, compiled, start)
    lay = _layout_of(problem)
    n_z = problem.n
    P_diag = (np.zeros((1, n_z)) if problem.P is None else np.diag(problem.P)[None])
    q, A, b = (np.asarray(problem.q, float)[None], np.asarray(problem.A, float)[None],
               np.asarray(problem.b, float)[None])
    E, e, k, g, held = numbers(lay, P_diag, q, A, b)
    d0 = None
    if initvals is not None and np.shape(initvals) == (n_z,):
        d0 = deformations(np.asarray(initvals, float)[lay.force][None], lay.groups, k, g)
    setup = time.perf_counter()
    u, d, status, iters = solve_duals(E, e, lay.groups, k, g, d0, None if d0 is None else
                                      np.ones(1, bool), tol=tol, max_iter=max_iter,
                                      soften=soften, compiled=compiled)
    z, y = answer(lay, A, P_diag, q, u, d, k, g, held)
    objective = 0.5 * float(z[0] @ (P_diag[0] * z[0])) + float(q[0] @ z[0])
    return Outcome(STATUS[status[0]], z[0], iterations=int(iters[0]),
                   message=_message(status[0]), objective=objective,
                   setup_s=setup - start, solve_s=time.perf_counter() - setup, y=y[0])


def _solve_lcp(problem: LCP, tol, soften, max_iter, compiled, start) -> Outcome:
    """The ``lcp`` through ``positive`` on its force checks (the operator's rows): the
    end faces' multipliers ``lam = max(-d_u, 0)``.
    """
    c = problem.checks
    uni = np.asarray(c.unilateral, bool)
    groups = _scalars(uni)
    ones = np.ones((1, len(uni)))
    setup = time.perf_counter()
    u, d, status, iters = solve_duals(np.asarray(c.A, float)[None], np.asarray(c.b, float)[
        None], groups, ones, 0.0 * ones, tol=tol, max_iter=max_iter, soften=soften,
        compiled=compiled)
    return Outcome(STATUS[status[0]], np.maximum(-d[0, uni], 0.0), iterations=int(iters[0]),
                   message=_message(status[0]), setup_s=setup - start,
                   solve_s=time.perf_counter() - setup)


def solve_batch(batch, tol=None, soften: float = 0.0, max_iter: int = MAX_ITER,
                chain: bool = False, compiled=None) -> BatchOutcome:
    """Every instant of a least-norm or conic batch (``chain``: each instant after the
    first warm-started from the one before it).
    """
    clock = time.perf_counter()
    tol = TOL if tol is None else float(tol)
    if isinstance(batch, LeastNormBatch):
        groups = _scalars(batch.signed)
        k = np.ones(batch.A.shape[::2]) if batch.weights is None else batch.weights
        E, e, g = batch.A, batch.b, np.zeros_like(k)
    else:
        lay = _batch_layout(batch)
        T, _, n_z = batch.A.shape
        P = np.zeros((n_z, n_z)) if batch.P is None else np.asarray(batch.P, float)
        P_diag = np.broadcast_to(np.diagonal(P, axis1=-2, axis2=-1), (T, n_z))
        E, e, k, g, held = numbers(lay, P_diag, batch.q, batch.A, batch.b)
        groups = lay.groups
    stages = {"setup": time.perf_counter() - clock}
    clock = time.perf_counter()
    u, d, status, iters = solve_duals(E, e, groups, k, g, chain=chain, tol=tol,
                                      max_iter=max_iter, soften=soften, compiled=compiled)
    stages["newton"] = time.perf_counter() - clock
    clock = time.perf_counter()
    if isinstance(batch, LeastNormBatch):
        z = forces(d, groups, k, g)
        y = np.concatenate([-u, np.maximum(-d[:, batch.signed], 0.0)], axis=1)
    else:
        z, y = answer(lay, batch.A, P_diag, batch.q, u, d, k, g, held)
    stages["answer"] = time.perf_counter() - clock
    messages = tuple(map(_message, status)) if np.any(status) else ()
    return BatchOutcome(status=np.array([STATUS[c] for c in status], object), z=z, y=y,
                        iterations=iters, setup_s=stages["setup"],
                        solve_s=stages["newton"] + stages["answer"], stages=stages,
                        messages=messages)


def _batch_supported(batch) -> bool:
    return isinstance(batch, LeastNormBatch) or _batch_layout(batch) is not None


def backends() -> list[Backend]:
    """The family (NumPy is a core dependency; numba, where installed, compiles it)."""
    common = dict(family="newton", distributions=("cardan-forces", "numpy"),
                  tolerances=("tol",), smallest_tol=1e-15)
    return [Backend(name="newton", accepts=(Conic, LCP), solve=solve_problem,
                    supports=supports, warm_start=True, **common),
            Backend(name="newton-batched", batch=solve_batch, supports=_batch_supported,
                    batch_accepts=(LeastNormBatch, ConicBatch), **common),
            Backend(name="newton-batched-warm", batch=_solve_chained,
                    supports=_batch_supported, batch_accepts=(LeastNormBatch, ConicBatch),
                    **common)]


def _solve_chained(batch, tol=None, **options) -> BatchOutcome:
    """:func:`solve_batch` with each instant warm-started from the one before it."""
    return solve_batch(batch, tol, chain=True, **options)
