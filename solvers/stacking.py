"""The layout of the problems an answer is judged on: cone rows, and problems stacked
over their instants.

A cone list ``((kind, size), ...)`` lays out the rows of Clarabel's standard form
``min 1/2 z'Pz + q'z s.t. A z + s = b, s in K`` block by block (:func:`blocks`,
:func:`cone_layout`: the one reading of a cone list by row index, shared by the judge
and by the adapters that reorder or fold rows).

T problems of one structure (one formulation's instants) in that form as stacked arrays
(:class:`Stacked`), built from the problems' own data where they stack (least norms,
QPs) and from their conic forms otherwise (:func:`stack_conic`). The rows of ``A`` are
kept as blocks: rows the same at every instant once, rows that change as a dense stack
or as a sparse :class:`Pattern`, a QP's bounds as the columns they bound, so the
products ``A z`` and ``A'y`` over all instants read only the numbers that are there.
:class:`Stacks` adds the same problems' force checks (``A``, ``b``), stacked once
(:func:`stack_all`) for a caller that judges the same problems more than once.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np
from cardan_forces.formulations.problems import LCP, LS, NLS, QP, Conic

from .conversions import convert


def times_P(P, z: np.ndarray) -> np.ndarray:
    """``P z`` per instant (T, n): ``P`` ``None``, (n, n), (T, n, n) or a :class:`Pattern`."""
    if P is None:
        return np.zeros_like(z)
    if isinstance(P, Pattern):
        return P.times(z)
    P = np.asarray(P, float)
    return z @ P.T if P.ndim == 2 else (P @ z[:, :, None])[:, :, 0]


def stacked_batch(P, q, A, b, cones) -> Stacked:
    """A batch's stacked arrays (``P`` (n, n), (T, n, n) or ``None``; ``A`` (T, m, n)) as
    a :class:`Stacked`, its products run as the per-instant checks run them
    (:func:`_blocks`; a per-instant ``P`` as its :class:`Pattern`).
    """
    if P is not None and np.ndim(P) == 3:
        P = _one_or_pattern(np.asarray(P, float))
    return Stacked(P, np.asarray(q, float), np.asarray(b, float), tuple(cones),
                   _blocks(np.asarray(A, float)))


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
    where at least a quarter of its entries can be nonzero (``socp_face``: 46%, faster
    dense), else a :class:`Pattern` (``compliance_hertz``: 15%, faster as a pattern).
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
    elif isinstance(blk, np.ndarray):  # stacked products: faster than einsum's
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


def blocks(cones) -> list[tuple[str, float, slice]]:
    """``(kind, parameter, rows)`` per cone block of ``cones`` in row order."""
    out, row = [], 0
    for kind, size in cones:
        rows = 3 if kind == "pow" else int(size)
        out.append((kind, size, slice(row, row + rows)))
        row += rows
    return out


@functools.lru_cache(maxsize=64)
def cone_spans(cones: tuple) -> tuple[tuple[slice, ...], tuple[slice, ...]]:
    """The zero blocks and the nonnegative blocks of ``cones`` as row slices: a
    violation read through them reads views, not gathered copies of the rows.
    """
    return tuple(tuple(rows for kind, _, rows in blocks(cones) if kind == wanted and
                       rows.stop > rows.start) for wanted in ("zero", "nonneg"))


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


def groups(items, key) -> list[np.ndarray]:
    """Indices of ``items`` grouped by ``key(item)``, groups in order of appearance."""
    out: dict = {}
    for k, item in enumerate(items):
        out.setdefault(key(item), []).append(k)
    return [np.array(v, int) for v in out.values()]


def checks_key(problem) -> tuple:
    """What T problems' force checks must share to be stacked: the shape of ``A``, the
    unilateral columns, the pairs and the cones.
    """
    c = problem.checks
    return np.shape(c.A), np.asarray(c.unilateral, bool).tobytes(), c.pairs, c.cones


@dataclass(frozen=True)
class Stacks:
    """The data the checks of T problems of one structure read, stacked once
    (:func:`stack_all`): the force checks' ``A`` (T, m, n) and ``b`` (T, m), and the
    problems' conic form (:class:`~.stacking.Stacked`, ``None`` for an LCP or a
    nonlinear system; its ``P`` (n, n) where the same at every instant). A caller that
    checks the same problems again (a bench running several backends over one
    formulation's instants) hands them to :func:`finalize_all` instead of having each
    pass stack every instant's matrices.
    """

    problems: tuple
    A: np.ndarray
    b: np.ndarray
    conic: Stacked | None

    def holds(self, problems) -> bool:
        """Whether these are the stacks of exactly ``problems`` (the same objects)."""
        return len(problems) == len(self.problems) and all(
            a is b for a, b in zip(problems, self.problems))

    def take(self, rows) -> Stacks:
        """The stacks of the problems at positions ``rows``."""
        rows = np.asarray(rows, int)
        return Stacks(tuple(self.problems[k] for k in rows), self.A[rows], self.b[rows],
                      None if self.conic is None else self.conic.take(rows))


def stack_all(problems) -> Stacks | None:
    """:class:`Stacks` of ``problems``, or ``None`` when their checks or their conic
    forms differ in structure (then :func:`finalize_all` groups them itself).
    """
    problems = list(problems)
    if not problems or len(groups(problems, checks_key)) != 1:
        return None
    kinds = groups(problems, kind_key)
    if len(kinds) != 1:
        return None
    first = problems[0]
    conic = None
    if not isinstance(first, (LCP, NLS)) and conic_key(first) is not None:
        conic = stack_conic(problems)
    return Stacks(tuple(problems), np.array([p.checks.A for p in problems], float),
                  np.array([p.checks.b for p in problems], float), conic)


def kind_key(problem) -> tuple:
    """What T problems must share for one measure of their optimality: an LCP's or a
    nonlinear system's class and number of forces, else the conic form's
    :func:`conic_key`.
    """
    if isinstance(problem, (LCP, NLS)):
        return type(problem), len(problem.checks.names)
    return "conic", conic_key(problem)
