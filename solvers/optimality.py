"""Optimality of an answer relative to the problem data: the package's measures.

These are the *package-optimality* measures of the bench's ladder, relative to the data;
qpbenchmark's are absolute and live in :mod:`.qp_measures` (the *solver-optimality*
view), computed as qpbenchmark computes them.

Every convex problem the package builds reaches Clarabel's standard form (``LS -> QP ->
Conic``, ``LP -> Conic``), ``min 1/2 z'Pz + q'z s.t. A z + s = b, s in K``, whose
optimality conditions with multipliers ``y`` are

- primal feasibility: ``s = b - A z in K`` (the package's force residuals, ``ForceChecks``);
- dual feasibility: ``P z + q + A'y = 0`` (stationarity of the Lagrangian) and
  ``y in K*`` (the dual cone);
- zero duality gap: ``(1/2 z'Pz + q'z) - (-1/2 z'Pz - b'y) = 0``.

``dual`` is the largest of the stationarity residual ``||Pz + q + A'y||_inf`` relative to
the largest of ``||Pz||_inf, ||q||_inf, ||A'y||_inf`` and the dual-cone violation
relative to ``||y||_inf``; ``gap`` is the duality gap relative to the larger objective.
Both are dimensionless, so a level such as 1e-6 means the same for a problem in N and
for one in units of the load. In formulas, with ``r = P z + q + A'y``:

- ``primal = max(equilibrium, sign, complementarity, cone)`` of the forces, each over
  ``||b_eq||_2`` (``ForceChecks.residuals``);
- ``dual = max(||r||_inf / max(||Pz||_inf, ||q||_inf, ||A'y||_inf),
  viol_K*(y) / ||y||_inf)``;
- ``gap = |p - d| / max(|p|, |d|)``, ``p = 1/2 z'Pz + q'z``, ``d = -1/2 z'Pz - b'y``
  (or ``|p - p*| / |p*|`` against a high-precision optimal value ``p*`` where the
  multipliers are recovered).

Where they differ from qpbenchmark's (``r_p, r_d, r_g`` of :mod:`.qp_measures`) and
why: qpbenchmark's are absolute, in the units of the data, so on a least norm in
newtons (objective near 1e9) no exact solver meets a 1e-9 gap while on a small
objective the relative measure is the stricter; ``primal`` is taken on the forces and
includes end-face complementarity, which the physics asks and the QP does not; the
bench's success also asks the distance to a reference where the optimum is unique.

Where a backend returns no multipliers they are recovered (:func:`recover`) by a
nonnegative least-squares solve of stationarity on the constraints active at ``z``: a
row of the nonnegative cone with ``s_i = 0``, a cone block on its boundary (one
multiplier along the block's normal there), a block at its apex (the whole block).

All functions take a batch: ``q`` (T, n), ``A`` (T, m, n), ``b`` (T, m), ``z`` (T, n),
``y`` (T, m); ``P`` (n, n), (T, n, n) or ``None``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field, fields

import numpy as np
from cardan_forces.formulations.problems import LS, QP, Conic

from .conversions import convert

ACTIVE_RTOL = 1e-7
"""A constraint counts as active when its slack is below this, relative to
``max(1, ||b||_inf, ||A z||_inf)``."""

TINY = 1e-300


def blocks(cones) -> list[tuple[str, float, slice]]:
    """``(kind, parameter, rows)`` per cone block of ``cones`` in row order."""
    out, row = [], 0
    for kind, size in cones:
        rows = 3 if kind == "pow" else int(size)
        out.append((kind, size, slice(row, row + rows)))
        row += rows
    return out


def times_P(P, z: np.ndarray) -> np.ndarray:
    """``P z`` per instant (T, n): ``P`` ``None``, (n, n), (T, n, n) or a :class:`Pattern`."""
    if P is None:
        return np.zeros_like(z)
    if isinstance(P, Pattern):
        return P.times(z)
    P = np.asarray(P, float)
    return z @ P.T if P.ndim == 2 else (P @ z[:, :, None])[:, :, 0]


def inf_norm(v: np.ndarray) -> np.ndarray:
    """``||v||_inf`` along the last axis (0 for none, NaN where ``v`` has a NaN), from
    the largest and the least entry: two reductions that write no (T, n) temporary.
    """
    return np.maximum(v.max(axis=-1, initial=0.0), -v.min(axis=-1, initial=0.0))


@functools.lru_cache(maxsize=64)
def cone_spans(cones: tuple) -> tuple[tuple[slice, ...], tuple[slice, ...]]:
    """The zero blocks and the nonnegative blocks of ``cones`` as row slices: a
    violation read through them reads views, not gathered copies of the rows.
    """
    return tuple(tuple(rows for kind, _, rows in blocks(cones) if kind == wanted and
                       rows.stop > rows.start) for wanted in ("zero", "nonneg"))


def below_zero(v: np.ndarray, spans) -> np.ndarray:
    """``max(0, -min v)`` over the rows ``spans`` (slices) of each instant: how far the
    entries that must be nonnegative go below zero.
    """
    worst = np.zeros(len(v))
    for rows in spans:
        worst = np.maximum(worst, -v[:, rows].min(axis=1))
    return worst


@functools.lru_cache(maxsize=64)
def cone_layout(cones: tuple) -> tuple:
    """Row indices of the cone kinds: zero rows, nonneg rows, second-order blocks padded
    to the longest (apex, members, mask), power blocks (k, 3) and their alphas. The one
    reading of a cone list by index, shared by the force view and the solver view.
    """
    zero, nonneg, socs, pows, alphas = [], [], [], [], []
    for kind, size, rows in blocks(cones):
        idx = list(range(rows.start, rows.stop))
        {"zero": zero, "nonneg": nonneg}.get(kind, []).extend(idx)
        if kind == "soc":
            socs.append(idx)
        elif kind == "pow":
            pows.append(idx)
            alphas.append(float(size))
    width = max((len(r) - 1 for r in socs), default=0)
    members = np.zeros((len(socs), width), int)
    mask = np.zeros((len(socs), width))
    for k, r in enumerate(socs):
        members[k, :len(r) - 1] = r[1:]
        mask[k, :len(r) - 1] = 1.0
    return (np.array(zero, int), np.array(nonneg, int), np.array([r[0] for r in socs], int),
            members, mask, np.array(pows, int).reshape(-1, 3), np.array(alphas))


def dual_cone_violation(cones, y: np.ndarray) -> np.ndarray:
    """Distance-like violation of ``y in K*`` per instant (absolute, (T,)).

    K* of the zero cone is free; the nonnegative and second-order cones are self-dual;
    the dual power cone is ``(u/a)^a (v/(1-a))^(1-a) >= |w|, u, v >= 0``.
    """
    _, _, apex, members, mask, pows, alphas = cone_layout(tuple(cones))
    worst = below_zero(y, cone_spans(tuple(cones))[1])
    if len(apex):
        spread = y[:, members] * mask
        spread = np.sqrt(np.einsum("tkj,tkj->tk", spread, spread))
        worst = np.maximum(worst, (spread - y[:, apex]).max(axis=1))
    if len(pows):
        u, v, w = (np.maximum(y[:, pows[:, 0]], 0.0), np.maximum(y[:, pows[:, 1]], 0.0),
                   y[:, pows[:, 2]])
        mean = (u / alphas) ** alphas * (v / (1.0 - alphas)) ** (1.0 - alphas)
        negative = np.maximum(0.0, -np.minimum(y[:, pows[:, 0]], y[:, pows[:, 1]]))
        worst = np.maximum(worst, np.maximum(np.abs(w) - mean, negative).max(axis=1))
    return np.maximum(worst, 0.0)


def measures(P, q, A, b, cones, z, y) -> dict[str, np.ndarray]:
    """``{"dual", "gap", "objective"}`` per instant ((T,) arrays; see the module docstring).

    ``objective`` is the primal objective ``1/2 z'Pz + q'z`` (for an objective gap).
    """
    return stacked_measures(stacked_batch(P, q, A, b, cones), z, y)[0]


def stacked_measures(st: Stacked, z: np.ndarray, y: np.ndarray) -> tuple[dict, Parts]:
    """:func:`measures` of answers ``z`` with multipliers ``y`` to the stacked problems
    ``st``, and the :class:`Parts` they were made of (the solver's view is made of the
    same, :func:`~.qp_measures.from_parts`, so each is computed once).
    """
    parts = Parts.of(times_P(st.P, z), st.q, st.Aty(y), np.einsum("tm,tm->t", st.b, y), z,
                     y, dual_cone_violation(st.cones, y))
    return _combined(parts, st.q, y), parts


def combine(Pz, q, Aty, bty, z, y, cone_violation) -> dict[str, np.ndarray]:
    """The measures from their parts (``P z``, ``q``, ``A'y``, ``b'y``, the dual-cone
    violation), for a backend whose problem form gives them more cheaply than
    :func:`measures`' dense products.
    """
    return _combined(Parts.of(Pz, q, Aty, bty, z, y, cone_violation), q, y)


@dataclass(frozen=True)
class Parts:
    """What the measures of T answers ``z`` with multipliers ``y`` are made of, (T,)
    arrays but the products: ``Pz`` and ``Aty`` (T, n); ``dual_cone``, the dual cone's
    violation of ``y`` (``None`` where not measured); ``stationarity``
    ``||Pz + q + A'y||_inf``; ``quad`` ``z'Pz``, ``linear`` ``q'z``, ``bty`` ``b'y``;
    ``bad``: where ``z`` or ``y`` is not finite. The package's view (relative) and the
    solver's (absolute, :func:`~.qp_measures.from_parts`) are both made of them.
    """

    Pz: np.ndarray
    Aty: np.ndarray
    dual_cone: np.ndarray
    stationarity: np.ndarray
    quad: np.ndarray
    linear: np.ndarray
    bty: np.ndarray
    bad: np.ndarray

    @classmethod
    def of(cls, Pz, q, Aty, bty, z, y, dual_cone) -> Parts:
        """The parts from the products and the dual cone's violation (``None``: not
        measured, for a QP's multipliers).
        """
        bad = ~(np.isfinite(z).all(axis=1) & np.isfinite(y).all(axis=1))
        residual = Pz + q
        residual += Aty
        return cls(Pz, Aty, dual_cone, inf_norm(residual), np.einsum("ti,ti->t", z, Pz),
                   np.einsum("ti,ti->t", q, z), bty, bad)

    def take(self, rows) -> Parts:
        """The parts of the answers at ``rows`` (indices or a mask)."""
        return Parts(*(getattr(self, f.name)[rows] for f in fields(self)))


def _combined(parts: Parts, q, y) -> dict[str, np.ndarray]:
    """The package's measures (the module docstring's formulas) from their parts."""
    stationarity = parts.stationarity / np.maximum(
        np.maximum(inf_norm(parts.Pz), inf_norm(q)), np.maximum(inf_norm(parts.Aty), TINY))
    cone = parts.dual_cone / np.maximum(inf_norm(y), TINY)
    primal = 0.5 * parts.quad + parts.linear
    dual_obj = -0.5 * parts.quad - parts.bty
    gap = np.abs(primal - dual_obj) / np.maximum(np.maximum(np.abs(primal), np.abs(dual_obj)),
                                                 TINY)
    dual = np.maximum(stationarity, cone)
    dual[parts.bad], gap[parts.bad] = np.inf, np.inf
    return {"dual": dual, "gap": gap, "objective": primal}


def _normal(kind: str, alpha: float, s: np.ndarray) -> np.ndarray | None:
    """The outward normal of a cone block's boundary at ``s`` (a direction in K*
    orthogonal to ``s``), or ``None`` at the apex.
    """
    if kind == "soc":
        return None if not np.any(s) else np.concatenate([[s[0]], -s[1:]])
    x, v, w = s
    if x <= 0 or v <= 0:
        return None
    mean = x ** alpha * v ** (1.0 - alpha)
    return np.array([alpha * mean / x, (1.0 - alpha) * mean / v, -np.sign(w)])


def recover(P, q, A, b, cones, z) -> np.ndarray:
    """Multipliers ``y`` (m,) for one instance: nonnegative least squares of
    ``A_act' y_act = -(P z + q)`` on the constraints active at ``z`` (see the module
    docstring); zero on inactive rows.
    """
    from scipy.optimize import lsq_linear

    z, b = np.asarray(z, float), np.asarray(b, float)
    A = np.asarray(A, float)
    s = b - A @ z
    level = ACTIVE_RTOL * max(1.0, float(inf_norm(b)), float(inf_norm(A @ z)))
    columns, lower, owners = [], [], []  # owners: (rows, direction or None)
    for kind, alpha, rows in blocks(cones):
        block = s[rows]
        if kind == "zero":
            cols = [A[r] for r in range(rows.start, rows.stop)]
            columns += cols
            lower += [-np.inf] * len(cols)
            owners += [(slice(r, r + 1), None) for r in range(rows.start, rows.stop)]
        elif kind == "nonneg":
            for r in np.flatnonzero(block <= level) + rows.start:
                columns.append(A[r])
                lower.append(0.0)
                owners.append((slice(r, r + 1), None))
        else:
            margin = (block[0] - np.linalg.norm(block[1:]) if kind == "soc" else
                      np.clip(block[0], 0, None) ** alpha * np.clip(block[1], 0, None)
                      ** (1 - alpha) - abs(block[2]))
            if margin > level:
                continue
            normal = _normal(kind, alpha, block) if inf_norm(block) > level else None
            if normal is None:  # apex: every multiplier of the block, checked by K* later
                for r in range(rows.start, rows.stop):
                    columns.append(A[r])
                    lower.append(-np.inf)
                    owners.append((slice(r, r + 1), None))
            else:
                columns.append(normal @ A[rows])
                lower.append(0.0)
                owners.append((rows, normal))
    y = np.zeros(len(b))
    if not columns:
        return y
    target = -(times_P(P, z[None])[0] + np.asarray(q, float))
    M = np.array(columns).T
    coef = lsq_linear(M, target, bounds=(np.array(lower), np.inf), method="bvls").x
    for value, (rows, normal) in zip(coef, owners):
        y[rows] = value if normal is None else value * normal
    return y


def multipliers(st: Stacked, z: np.ndarray, given: list) -> tuple[np.ndarray, np.ndarray]:
    """``y`` (T, m) of answers ``z`` (T, n) to the stacked problems ``st``: the solver's
    ``given[k]`` where it has one of length m, else recovered (:func:`recover`); and the
    mask of the instants whose multipliers the solver gave. The one place both the
    per-instant checks and a batch's find their multipliers.
    """
    m = st.b.shape[1]
    mask = [g is not None and len(g) == m for g in given]
    y = np.array(given if all(mask) else [
        given[k] if mask[k] else recover(st.Pk(k), st.q[k], st.A(k), st.b[k], st.cones, z[k])
        for k in range(len(z))], float).reshape(len(z), m)
    return y, np.array(mask, bool)


def stacked_batch(P, q, A, b, cones) -> Stacked:
    """A batch's stacked arrays (``P`` (n, n), (T, n, n) or ``None``; ``A`` (T, m, n)) as
    a :class:`Stacked`, its products run as the per-instant checks run them
    (:func:`_blocks`; a per-instant ``P`` as its :class:`Pattern`).
    """
    if P is not None and np.ndim(P) == 3:
        P = _one_or_pattern(np.asarray(P, float))
    return Stacked(P, np.asarray(q, float), np.asarray(b, float), tuple(cones),
                   _blocks(np.asarray(A, float)))


def unique_optimum(problem) -> bool:
    """Whether the problem's optimum is one point, known from its data: a least norm
    (positive weights) or a positive definite ``P`` (strictly convex objective).
    A distance to a reference point means something only then.
    """
    if isinstance(problem, LS):
        return True
    if isinstance(problem, (QP, Conic)) and problem.P is not None:
        try:
            np.linalg.cholesky(np.asarray(problem.P, float))
        except np.linalg.LinAlgError:
            return False
        return True
    return False


def objective_value(problem, z) -> float | None:
    """The objective ``1/2 z'Pz + q'z`` of an LS, QP, LP or conic problem at ``z`` (in
    its conic form; the same value along every conversion), ``None`` for the others.
    """
    conic = convert(problem, (Conic,))
    if conic is None or z is None:
        return None
    z = np.asarray(z, float)
    return float(0.5 * z @ times_P(conic.P, z[None])[0] + np.asarray(conic.q, float) @ z)


def _stack(problems, name: str) -> np.ndarray:
    return np.array([getattr(p, name) for p in problems], float)


def _shared_P(problems) -> np.ndarray | Pattern:
    """``P`` (n, n) when every problem holds the same matrix, else a :class:`Pattern`."""
    first = problems[0].P
    if all(p.P is first for p in problems):
        return np.asarray(first, float)
    return _one_or_pattern(_stack(problems, "P"))


def _one_or_pattern(stack: np.ndarray) -> np.ndarray | Pattern:
    """A (T, n, n) stack as its one matrix where every instant's is the same, else as a
    :class:`Pattern`.
    """
    return stack[0] if np.all(stack == stack[0]) else Pattern.of(stack)


@dataclass(frozen=True)
class Pattern:
    """T matrices of one shape with one sparsity pattern (the union of their nonzeros):
    ``values`` (T, nnz) at ``rows``, ``cols`` of a ``shape`` matrix. A stacked problem's
    ``A`` and ``P`` are mostly zeros (a cone block touches a few forces), so products
    over the instants cost T x nnz instead of T x rows x columns.
    """

    values: np.ndarray
    rows: np.ndarray
    cols: np.ndarray
    shape: tuple[int, int]
    sums: tuple = field(default=(), repr=False, compare=False)
    """Sparse 0/1 matrices summing the products into rows, and into columns (made
    once per pattern, shared by the patterns :meth:`take` makes)."""

    def __post_init__(self) -> None:
        if not self.sums:
            from scipy.sparse import csr_matrix

            ones, k = np.ones(len(self.rows)), np.arange(len(self.rows))
            object.__setattr__(self, "sums", (
                csr_matrix((ones, (self.rows, k)), shape=(self.shape[0], len(k))),
                csr_matrix((ones, (self.cols, k)), shape=(self.shape[1], len(k)))))

    @classmethod
    def of(cls, dense: np.ndarray) -> Pattern:
        """The pattern of a (T, r, n) stack."""
        rows, cols = np.nonzero(np.any(dense != 0, axis=0))
        return cls(dense[:, rows, cols], rows, cols, dense.shape[1:])

    def times(self, v: np.ndarray) -> np.ndarray:
        """``M_t v_t`` per instant (T, r) for ``v`` (T, n), row-major as a dense
        product's (a sum over a row rounds by the row's layout).
        """
        return np.ascontiguousarray((self.sums[0] @ (self.values * v[:, self.cols]).T).T)

    def transposed_times(self, v: np.ndarray) -> np.ndarray:
        """``M_t' v_t`` per instant (T, n) for ``v`` (T, r), row-major."""
        return np.ascontiguousarray((self.sums[1] @ (self.values * v[:, self.rows]).T).T)

    def dense(self, k: int) -> np.ndarray:
        """Instant ``k``'s matrix."""
        out = np.zeros(self.shape)
        out[self.rows, self.cols] = self.values[k]
        return out

    def take(self, idx: np.ndarray) -> Pattern:
        """The instants ``idx``."""
        return Pattern(self.values[idx], self.rows, self.cols, self.shape, self.sums)


def _block(stack: np.ndarray) -> np.ndarray | Pattern:
    """A (T, r, n) stack of constraint rows as the products over it run fastest: dense
    where at least a quarter of its entries can be nonzero (``socp_face``: 46%, 1.3x
    faster dense), else a :class:`Pattern` (``compliance_hertz``: 15%, 4x faster).
    """
    nonzero = int(np.any(stack != 0, axis=0).sum())
    if 4 * nonzero >= stack.shape[1] * stack.shape[2]:
        return np.ascontiguousarray(stack)  # a run of rows is a strided view: copied once
    return Pattern.of(stack)


def _blocks(stack: np.ndarray) -> tuple:
    """A (T, r, n) stack of constraint rows as blocks in row order: each run of rows
    that are the same at every instant as their one (r', n) matrix (a cone's rows: one
    product serves all instants), each other run as :func:`_block` makes it. A conic
    form's cone rows are most of its rows and rarely change with the instant, so the
    stacked products read only the rows that do (a third of ``min_max``'s).
    """
    same = (np.all(stack == stack[:1], axis=(0, 2)) if len(stack)
            else np.zeros(stack.shape[1], bool)).tolist()
    starts = [r for r in range(len(same)) if r == 0 or same[r] != same[r - 1]]
    return tuple(stack[0, a:b] if same[a] else _block(stack[:, a:b])
                 for a, b in zip(starts, starts[1:] + [len(same)]))


def _times(blk, z: np.ndarray) -> np.ndarray:
    """A block's rows times ``z`` per instant: a bound block, shared, dense or a pattern."""
    return blk[0] * z[:, blk[1]] if isinstance(blk, tuple) else times_P(blk, z)


def _height(blk) -> int:
    """A block's number of rows (shared, a dense stack, a pattern or a bound block)."""
    return len(blk[1]) if isinstance(blk, tuple) else blk.shape[-2]


def _add_transposed(blk, part: np.ndarray, out: np.ndarray) -> None:
    """``out += B'part`` per instant for a block ``B`` of rows and its rows of ``y``."""
    if isinstance(blk, Pattern):
        out += blk.transposed_times(part)
    elif isinstance(blk, np.ndarray):  # stacked products: 2x einsum's
        out += part @ blk if blk.ndim == 2 else (part[:, None, :] @ blk)[:, 0]
    else:
        out[:, blk[1]] += blk[0] * part  # its columns are distinct


def _at(blk, k):
    """Instant(s) ``k`` of a block of rows (shared, a dense stack or a pattern): a matrix
    for one, a block for many.
    """
    if isinstance(blk, Pattern):
        return blk.dense(k) if np.ndim(k) == 0 else blk.take(k)
    return blk if blk.ndim == 2 else blk[k]


@dataclass(frozen=True)
class Stacked:
    """T problems of one structure in Clarabel's standard form, stacked: ``P`` (n, n)
    when shared, a :class:`Pattern`, (T, n, n) (a batch's) or ``None``; ``q`` (T, n),
    ``b`` (T, m), ``cones``; the rows of ``A`` as ``blocks`` in row order, each rows
    shared by all instants (r, n), a dense (T, r, n) stack, a :class:`Pattern`
    (:func:`_blocks`) or a bound block ``(sign, columns)`` (rows ``sign * e_j'``, a QP's
    finite bounds), so bounds are never written out as identity rows.
    """

    P: np.ndarray | Pattern | None
    q: np.ndarray
    b: np.ndarray
    cones: tuple
    blocks: tuple

    def Az(self, z: np.ndarray) -> np.ndarray:
        """``A z`` per instant (T, m)."""
        return np.concatenate([_times(blk, z) for blk in self.blocks]
                              + [np.zeros((len(z), 0))], axis=1)

    def Aty(self, y: np.ndarray) -> np.ndarray:
        """``A'y`` per instant (T, n)."""
        out, row = np.zeros_like(self.q), 0
        for blk in self.blocks:
            rows = _height(blk)
            _add_transposed(blk, y[:, row:row + rows], out)
            row += rows
        return out

    def A(self, k: int) -> np.ndarray:
        """Instant ``k``'s ``A`` (m, n), dense."""
        n = self.q.shape[1]
        return np.vstack([np.zeros((0, n))] + [
            blk[0] * np.eye(n)[blk[1]] if isinstance(blk, tuple) else _at(blk, k)
            for blk in self.blocks])

    def take(self, rows: np.ndarray) -> Stacked:
        """The instants ``rows`` of the stack."""
        P = self.P if self.P is None or np.ndim(self.P) == 2 else _at(self.P, rows)
        return Stacked(P, self.q[rows], self.b[rows], self.cones,
                       tuple(blk if isinstance(blk, tuple) else _at(blk, rows)
                             for blk in self.blocks))

    def Pk(self, k: int) -> np.ndarray | None:
        """Instant ``k``'s ``P``."""
        return self.P if self.P is None or np.ndim(self.P) == 2 else _at(self.P, k)


def _stack_qp(problems) -> Stacked | None:
    """:meth:`QP.as_conic` of T QPs of one structure at once (``None`` when their
    bounds are finite in different places, so their conic forms differ in rows).
    """
    first = problems[0]
    blocks, rhs, cones, ineq = [], [], [], None
    if first.A is not None:
        blocks += _blocks(_stack(problems, "A"))
        rhs.append(_stack(problems, "b"))
        cones.append(("zero", len(first.b)))
    if first.G is not None:
        blocks += _blocks(_stack(problems, "G"))
        rhs.append(_stack(problems, "h"))
        ineq = len(first.h)
    for name, sign in (("lb", -1.0), ("ub", 1.0)):
        if getattr(first, name) is not None:
            bounds = _stack(problems, name)
            keep = np.isfinite(bounds[0])
            if not np.array_equal(np.isfinite(bounds), np.broadcast_to(keep, bounds.shape)):
                return None
            blocks.append((sign, np.flatnonzero(keep)))
            rhs.append(sign * bounds[:, keep])
            ineq = (ineq or 0) + int(keep.sum())
    if ineq is not None:
        cones.append(("nonneg", ineq))
    b = np.concatenate(rhs, axis=1) if rhs else np.zeros((len(problems), 0))
    return Stacked(_shared_P(problems), _stack(problems, "q"), b, tuple(cones), tuple(blocks))


def _stack_ls(problems) -> Stacked:
    """``LS.as_qp().as_conic()`` of T least norms of one structure at once."""
    T, (m, n) = len(problems), np.shape(problems[0].A)
    weights = (np.ones((T, n)) if problems[0].weights is None
               else _stack(problems, "weights"))
    diagonal = np.arange(n)
    P = (np.diag(weights[0]) if np.all(weights == weights[0])
         else Pattern(weights, diagonal, diagonal, (n, n)))
    return Stacked(P, np.zeros((T, n)), _stack(problems, "b"), (("zero", m),),
                   _blocks(_stack(problems, "A")))


def conic_key(problem) -> tuple | None:
    """What T problems must share to be stacked by :func:`stack_conic` (``None``: no
    conic form).
    """
    if isinstance(problem, QP):
        return (QP, problem.n, *(None if (v := getattr(problem, k)) is None else np.shape(v)
                                 for k in ("A", "G")),
                problem.lb is None, problem.ub is None)
    if isinstance(problem, LS):
        return LS, np.shape(problem.A), problem.weights is None
    if isinstance(problem, Conic):
        return Conic, np.shape(problem.A), tuple(problem.cones), problem.P is None
    conic = convert(problem, (Conic,))
    return None if conic is None else (type(problem), *conic_key(conic)[1:])


def stack_conic(problems) -> Stacked:
    """T problems of one :func:`conic_key` in Clarabel's standard form, stacked
    (:class:`Stacked`): the same numbers as ``convert(problem, (Conic,))`` per instant,
    without building T problems where the problems' own data stack (least norms, QPs
    whose bounds are finite in the same places).
    """
    if isinstance(problems[0], LS):
        return _stack_ls(problems)
    stacked = _stack_qp(problems) if isinstance(problems[0], QP) else None
    if stacked is not None:
        return stacked
    conics = [convert(p, (Conic,)) for p in problems]
    P = None if conics[0].P is None else _shared_P(conics)
    return Stacked(P, _stack(conics, "q"), _stack(conics, "b"), conics[0].cones,
                   _blocks(_stack(conics, "A")))
