"""Where a conic problem's contacts are: the structure the ``newton`` family reads in a
problem's data (:func:`parse`), the numbers it takes per instant (:func:`numbers`) and
the answer it hands back in the problem's own variable and rows (:func:`answer`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from cardan_forces.formulations.batch import ConicBatch
from cardan_forces.formulations.problems import Conic

from ._newton_numpy import Groups, evaluate, groups_of, spread
from .stacking import cone_layout


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
        if power is None and not diag[r]:
            raise NotContact("a contact without stiffness (its energy only linear)")
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
    E = np.swapaxes(block(A, lay.force, lay.eq, transposed=True), 1, 2)
    e = b[:, lay.eq] - np.einsum("tmh,th->tm", block(A, lay.eq, lay.held), held)
    power = lay.c_idx >= 0
    k = np.where(power, lay.p * q[:, lay.c_idx], P_diag[:, lay.a_idx])
    g = np.where(lay.g_idx >= 0, q[:, lay.g_idx], 0.0)
    return E, e, k, g, held


def block(A, first, second, transposed=False) -> np.ndarray:
    """``A[:, first][:, :, second]`` (T, len(first), len(second)) by one flat take, a
    contiguous copy (``transposed``: ``first`` indexes ``A``'s columns, ``second`` its
    rows: the transpose of ``A[:, second][:, :, first]``, as the kernel reads ``E``).
    """
    T, rows, n_z = A.shape
    flat = (second[None, :] * n_z + first[:, None] if transposed
            else first[:, None] * n_z + second[None, :]).ravel()
    return np.reshape(A, (T, rows * n_z)).take(flat, axis=1).reshape(
        T, len(first), len(second))


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
    z[:, lay.force] = spread(r, unit, grp, d.shape)
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
        rest = np.einsum("tmh,tm->th", block(A, lay.eq, lay.held),
                         y[:, lay.eq])
        y[:, lay.held_rows] = -(rest + P_diag[:, lay.held] * held + q[:, lay.held]) / A[
            :, lay.held_rows, lay.held]
    return z, y


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


def parse_conic(problem: Conic) -> Layout | None:
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
"""Layouts by structure (:func:`parse_conic`), with their unit entries."""


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


def parse_batch(batch: ConicBatch) -> Layout | None:
    P_pattern, q_pattern, A_pattern = _patterns(batch.P, batch.q, batch.A)
    try:
        return parse(P_pattern, q_pattern, A_pattern, batch.A[0], batch.b[0], batch.cones)
    except NotContact:
        return None
