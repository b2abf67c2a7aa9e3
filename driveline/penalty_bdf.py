"""Compiled implicit integrator of the penalty simulation.

SciPy's variable-order BDF (``solve_ivp(method="BDF")``: the numerical differentiation
formulas of Shampine & Reichelt, *The MATLAB ODE suite*, SIAM J. Sci. Comput. 18
(1997), orders 1-3 here (:data:`MAX_ORDER`), quasi-constant step size, the
backward-difference array ``D`` rescaled on every change of step) written as numba
loops, so that every step calls the compiled right-hand side and Jacobian with
no Python in between; its Newton systems are solved by :mod:`.penalty_linear`.
SUNDIALS CVODE's rules where they save work: the LU is kept while ``c`` changes by less
than 30 % (:data:`LU_KEEP`), and a first Newton correction already within tolerance is
accepted (:func:`_newton`). The rows of the velocities and rates skip the blocks of
bodies that share no contact (:func:`penalty_jacobian._linked`), and a Newton iteration
restarted after a fresh Jacobian reuses the right-hand side at the prediction. Measured
and not taken (5 s of ``paper-penalty``, or 2.5 s of it and of ``paper-fig15-axial``):
CVODE's scaling of a kept LU's correction by ``2 / (1 + c / c_lu)`` (no fewer Jacobians
or iterations; with a 50 % band 30 % more error-test failures and 11 % more steps), a
step safety factor of 0.8 instead of 0.9 (45 % fewer error-test failures, 8 % more
steps, the same time), refactoring before re-evaluating the Jacobian after a failed
iteration (no fewer Jacobians).

Why not a library: ODEPACK and SUNDIALS reach these kernels only
through a Python callback per call (``odeint``, ``scikit-sundae``), ``numbalsoda`` does
not build for this Python, and ``diffrax``'s own overhead per step on a 65-state
system, even with a trivial right-hand side, exceeds the penalty model's whole step.

Same error control as SciPy's ``BDF``: the local error estimate of every component
below ``atol + rtol |y|``. One difference: the Newton iteration stops at
:data:`NEWTON_TOL` (SciPy's value for ordinary tolerances) of that error scale, where
SciPy would tie it to ``sqrt(rtol)`` (1e-5 at the floor ``rtol = 1e-10`` that the
penalty model's absolute control uses); a converged Newton iterate within 3 % of the
error tolerance does not move the accepted solution beyond that tolerance, and the
tighter rule costs a Jacobian every two steps. CVODE's rules instead (stop at 0.1,
give up only on a growing correction) took 17 % fewer Jacobians and 9 % more
right-hand sides over 5 s of ``paper-penalty``: no fewer steps, no less time.

A step allocates nothing: its vectors, the rescaling's matrices and the right-hand
side's frames and contact arrays are made once by :func:`start` (``work``), since on
65 states a NumPy temporary costs as much as the arithmetic it holds.

A run's state is one :class:`Run` (named tuples of arrays: its clock, counters, the
differences, the Jacobian, the factors and the scratch), made by :func:`start` and
stepped by :func:`advance`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .penalty_contact import ContactState, _rhs_into, kernel, new_contact_state, rhs
from .penalty_jacobian import JacobianScratch, _jacobian_into, _linked, new_jacobian_scratch
from .penalty_linear import Factors, _factor, _solve, new_factors

MAX_ORDER = 3
"""The highest order of the formulas (SciPy's: 5). The rattle's forces have kinks (a
contact closing, eq. 75's ``f >= 0`` switching while pressed) every few dozen steps;
orders 4 and 5 extrapolate across them worse and fail the error test more often. With
orders up to 3, the same error control on ``paper-penalty`` takes ~7 % fewer steps, each
cheaper (fewer differences to predict and rescale), and the forces' 0.1 s averages and
the speeds differ from the order-5 run's no more than two order-5 runs whose starts
differ by 1e-15 differ from each other (the rattle is chaotic). Up to order 2 it takes
45 % more steps (each cheaper), up to order 4 1 % more, each dearer (5 s of
``paper-penalty``)."""
NEWTON_MAXITER = 4
NEWTON_TOL = 0.03
"""Newton's stopping tolerance, in units of the error tolerance (see above)."""
MIN_FACTOR, MAX_FACTOR = 0.2, 10.0
LU_KEEP = 0.3
"""The LU of ``I - c J`` is kept while ``c`` stays within 30 % of the ``c`` it was
factored with (SUNDIALS CVODE's rule, ``dgmax``); SciPy refactors on every change of
step. A Newton iteration with the kept matrix converges to the same solution, a little
slower, and its rate test rejects it where it would not converge."""

_KAPPA = np.array([0.0, -0.1850, -1.0 / 9.0, -0.0823, -0.0415, 0.0])[:MAX_ORDER + 1]
_GAMMA = np.concatenate([[0.0], np.cumsum(1.0 / np.arange(1, MAX_ORDER + 1))])
_ALPHA = (1.0 - _KAPPA) * _GAMMA
_ERROR_CONST = _KAPPA * _GAMMA + 1.0 / np.arange(1, MAX_ORDER + 2)
_COEFFS = np.stack([_GAMMA, _ALPHA, _ERROR_CONST])
"""Rows: gamma, alpha, error constants of the NDF of each order (SciPy's ``BDF``)."""


RUNNING, FINISHED, STEP_TOO_SMALL, NOT_FINITE = 0, 1, 2, 3
"""A run's status (:data:`COUNTS` ``status``)."""
MESSAGES = {FINISHED: "finished", STEP_TOO_SMALL: "required step size is less than spacing "
            "between numbers", NOT_FINITE: "the right-hand side is not finite"}


CLOCK = np.dtype([("t", np.float64), ("h", np.float64), ("c", np.float64),
                  ("rate", np.float64)])
"""A run's times (s), the fields of one record: the time ``t`` reached, the step ``h``
to try next, the ``c`` (step over the formula's coefficient) of the LU held, and the
last Newton ``rate`` seen with it. A record (compiled code reads and writes its fields
by name in place), not a named tuple of arrays: every array a kernel is handed costs a
reference count, and the step's kernels hand these down at every step."""

COUNTS = np.dtype([(name, np.int64) for name in (
    "order", "equal", "has_lu", "jac_current", "steps", "fev", "jev", "nlu", "status",
    "out")])
"""A run's integers, the fields of one record (as :data:`CLOCK`): the formula's
``order``, the steps taken at ``equal`` size, whether an LU is held (``has_lu``) and
the Jacobian is at the current step (``jac_current``), the numbers of ``steps``,
right-hand sides (``fev``), Jacobians (``jev``) and factorizations (``nlu``), the
``status`` (:data:`RUNNING` ...), and the rows of the output filled (``out``)."""


class Vectors(NamedTuple):
    """A step's vectors (n,): the prediction, its error ``scale``, ``psi`` (the
    differences' share of the BDF equation), the Newton iterate ``y``, its difference
    ``d`` from the prediction, its correction ``dy``, the right-hand side ``f`` and that
    at the prediction, ``f_predict``; two rows for :func:`penalty_linear._solve`.
    """

    predict: np.ndarray
    scale: np.ndarray
    psi: np.ndarray
    y: np.ndarray
    d: np.ndarray
    dy: np.ndarray
    f: np.ndarray
    f_predict: np.ndarray
    solve_q: np.ndarray
    solve_r: np.ndarray


class Rescale(NamedTuple):
    """:func:`_change_d`'s scratch: SciPy's ``R`` and ``U`` maps and their product
    (MAX_ORDER + 1 square), and the old differences (MAX_ORDER + 1, n).
    """

    r: np.ndarray
    u: np.ndarray
    ru: np.ndarray
    old: np.ndarray


class Work(NamedTuple):
    """A run's scratch, made once by :func:`start`: its :class:`Vectors`, the
    :class:`Rescale` matrices, the contacts' :class:`ContactState` (shared by the
    right-hand side and the Jacobian) and the :class:`JacobianScratch`.
    """

    vectors: Vectors
    rescale: Rescale
    contacts: ContactState
    jacobian: JacobianScratch


class Run(NamedTuple):
    """A run between calls of :func:`advance`: its ``clock`` (:data:`CLOCK`) and
    ``counts`` (:data:`COUNTS`), each an array of one record,
    the backward differences ``d`` (MAX_ORDER + 3, n), the Jacobian ``jac`` (n, n), the
    :class:`Factors` of ``I - c J`` and the :class:`Work` arrays.
    """

    clock: np.ndarray
    counts: np.ndarray
    d: np.ndarray
    jac: np.ndarray
    factors: Factors
    work: Work


@kernel(inline="always")
def _norm(x, scale):
    """RMS norm of ``x / scale``."""
    s = 0.0
    for i in range(x.shape[0]):
        s += (x[i] / scale[i]) ** 2
    return np.sqrt(s / x.shape[0])


@kernel(inline="always")
def _scaled_norm(factor, x, scale):
    """RMS norm of ``factor x / scale`` (no temporary for ``factor x``)."""
    s = 0.0
    for i in range(x.shape[0]):
        s += (factor * x[i] / scale[i]) ** 2
    return np.sqrt(s / x.shape[0])


@kernel(inline="always")
def _r_matrix(order, factor, m):
    """SciPy's ``compute_R`` into ``m``: the map of backward differences for a step
    times ``factor``.
    """
    m[0, :order + 1] = 1.0
    for i in range(1, order + 1):
        m[i, 0] = 0.0
        for j in range(1, order + 1):
            m[i, j] = (i - 1 - factor * j) / i
    for i in range(1, order + 1):
        for j in range(order + 1):
            m[i, j] *= m[i - 1, j]


@kernel(inline="always")
def _change_d(d, order, factor, rescale):
    """Rescale the differences ``d`` for a step size times ``factor`` (in place):
    ``D <- (R U)^T D`` over the first ``order + 1`` rows, as SciPy's ``change_D``;
    ``rescale``: its scratch (:class:`Rescale`).
    """
    r, u, ru, old = rescale.r, rescale.u, rescale.ru, rescale.old
    _r_matrix(order, factor, r)
    _r_matrix(order, 1.0, u)
    for i in range(order + 1):
        for j in range(order + 1):
            total = 0.0
            for k in range(order + 1):
                total += r[i, k] * u[k, j]
            ru[i, j] = total
    n = d.shape[1]
    for i in range(order + 1):
        for k in range(n):
            old[i, k] = d[i, k]
    for i in range(order + 1):
        row = d[i]
        row[:] = 0.0
        for j in range(order + 1):
            weight = ru[j, i]
            if weight != 0.0:
                for k in range(n):
                    row[k] += weight * old[j, k]


@kernel()
def initial_step(t0, y0, t_bound, atol, rtol, counts, model):
    """SciPy's ``select_initial_step`` for a first-order estimate (Hairer, Norsett and
    Wanner, Solving ODEs I, sec. II.4); returns it and ``f(t0, y0)``. Its two
    right-hand sides are :func:`rhs`'s (one compiled copy; the integrator's own is
    inlined into its Newton iteration). Counts them in ``counts`` (a :data:`COUNTS`
    record).
    """
    scale = atol + rtol * np.abs(y0)
    counts.fev += 2
    f0 = rhs(t0, y0, model)
    d0, d1 = _norm(y0, scale), _norm(f0, scale)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, t_bound - t0)
    f1 = rhs(t0 + h0, y0 + h0 * f0, model)
    d2 = _norm(f1 - f0, scale) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** 0.5
    return min(100.0 * h0, h1, t_bound - t0), f0


@kernel()
def start(t0, y0, t_bound, atol, rtol, model):
    """A run's state at ``t0`` (a :class:`Run`) for :func:`advance`: its first step
    (:func:`initial_step`), differences ``D`` and Jacobian, and every scratch array a
    step needs, made here once: a step allocates nothing.
    """
    n, nb = y0.shape[0], model.mass.shape[0]
    linked = _linked(nb, model.topology)
    vectors = np.zeros((10, n))
    rescale = np.zeros((3, MAX_ORDER + 1, MAX_ORDER + 1))
    work = Work(
        vectors=Vectors(predict=vectors[0], scale=vectors[1], psi=vectors[2], y=vectors[3],
                        d=vectors[4], dy=vectors[5], f=vectors[6], f_predict=vectors[7],
                        solve_q=vectors[8], solve_r=vectors[9]),
        rescale=Rescale(r=rescale[0], u=rescale[1], ru=rescale[2],
                        old=np.zeros((MAX_ORDER + 1, n))),
        contacts=new_contact_state(y0, nb, model.topology.shape[0]),
        jacobian=new_jacobian_scratch(nb, n))
    counts_record, clock_record = np.zeros(1, dtype=COUNTS), np.zeros(1, dtype=CLOCK)
    counts, clock = counts_record[0], clock_record[0]
    counts.order = 1
    h, f0 = initial_step(t0, y0, t_bound, atol, rtol, counts, model)
    d = np.zeros((MAX_ORDER + 3, n))
    d[0], d[1] = y0, f0 * h
    counts.jev += 1
    jac = np.empty((n, n))
    _jacobian_into(t0, y0, model, jac, linked, work.contacts, work.jacobian)
    counts.jac_current = 1
    clock.t, clock.h, clock.c, clock.rate = t0, h, h, 1.0
    return Run(clock=clock_record, counts=counts_record, d=d, jac=jac,
               factors=new_factors(linked), work=work)


@kernel(inline="always")
def _newton(t_new, c, jac, factors, vec, clock, counts, contacts, model, again):
    """SciPy's ``solve_bdf_system``: the simplified Newton iteration of one step from
    the prediction (:class:`Vectors` ``predict``, ``psi``, ``scale``) into ``y`` and
    ``d = y - y_predict``; (converged, iterations). As CVODE
    (and unlike SciPy), a first correction already below the tolerance times the last
    rate seen with this LU is accepted without a second evaluation. ``again``: the
    iteration restarts from the same prediction (after a fresh Jacobian), whose
    right-hand side is kept in ``f_predict`` from the first start.
    """
    y_predict, scale, psi = vec.predict, vec.scale, vec.psi
    y, d, dy, f = vec.y, vec.d, vec.dy, vec.f
    n = y.shape[0]
    for i in range(n):
        y[i], d[i] = y_predict[i], 0.0
    dy_norm_old, converged, iterations = -1.0, False, 0
    while iterations < NEWTON_MAXITER:
        iterations += 1
        if iterations == 1 and again:
            f[:] = vec.f_predict
        else:
            counts.fev += 1
            _rhs_into(t_new, y, model, contacts, f)
            if iterations == 1:
                vec.f_predict[:] = f
        finite = True
        for i in range(n):
            finite &= np.isfinite(f[i])
            dy[i] = c * f[i] - psi[i] - d[i]
        if not finite:
            break
        _solve(jac, c, factors, dy, vec.solve_q, vec.solve_r)
        dy_norm = _norm(dy, scale)
        rate = dy_norm / dy_norm_old if dy_norm_old > 0.0 else -1.0
        if rate >= 0.0 and (rate >= 1.0 or rate ** (NEWTON_MAXITER - iterations + 1)
                            / (1.0 - rate) * dy_norm > NEWTON_TOL):
            break
        for i in range(n):
            y[i] += dy[i]
            d[i] += dy[i]
        if rate >= 0.0:
            clock.rate = rate
        if dy_norm == 0.0 or (rate >= 0.0 and rate / (1.0 - rate) * dy_norm < NEWTON_TOL) or (
                rate < 0.0 and min(1.0, clock.rate) * dy_norm < NEWTON_TOL):
            converged = True
            break
        dy_norm_old = dy_norm
    return converged, iterations


@kernel(inline="always")
def _predict(d, order, alpha, gamma, atol, rtol, y_predict, scale, psi):
    """The prediction ``y_predict`` of the next step, its error ``scale`` and ``psi``
    (the differences' share of the BDF equation), into those (:class:`Vectors`' rows).
    """
    for i in range(d.shape[1]):
        y_predict[i], psi[i] = d[0, i], 0.0
        for j in range(1, order + 1):
            y_predict[i] += d[j, i]
            psi[i] += d[j, i] * (gamma[j] / alpha[order])
        scale[i] = atol[i] + rtol * abs(y_predict[i])


@kernel(inline="always")
def _attempt(clock, counts, d, jac, factors, work, t_bound, atol, rtol, model):
    """SciPy's ``BDF._step_impl`` up to the accepted step: shrink the step until Newton
    converges (with a fresh Jacobian once per step) and the error test passes; returns
    (t_new, Newton iterations) with the new state, its difference from the prediction
    and its error scale in :class:`Vectors` ``y``, ``d``, ``scale``; or
    ``t_new = nan`` with the status set when the step would fall below the spacing of
    floats at ``t``.
    """
    t, h_abs, order = clock.t, clock.h, counts.order
    gamma, alpha, error_const = _COEFFS[0], _COEFFS[1], _COEFFS[2]
    vec, rescale, contacts = work.vectors, work.rescale, work.contacts
    min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
    if h_abs < min_step:
        _change_d(d, order, min_step / h_abs, rescale)
        h_abs, counts.equal = min_step, 0
    while True:
        if not h_abs >= min_step:  # also a NaN step: a state gone bad
            counts.status = STEP_TOO_SMALL if h_abs < min_step else NOT_FINITE
            return np.nan, 0
        t_new = t + h_abs
        if t_new > t_bound:
            t_new = t_bound
            _change_d(d, order, (t_new - t) / h_abs, rescale)
            counts.equal = 0
        h_abs = t_new - t
        _predict(d, order, alpha, gamma, atol, rtol, vec.predict, vec.scale, vec.psi)
        c, again = h_abs / alpha[order], False
        while True:
            if counts.has_lu == 0 or abs(c / clock.c - 1.0) > LU_KEEP:
                _factor(jac, c, factors)
                counts.nlu += 1
                counts.has_lu, clock.c, clock.rate = 1, c, 1.0
            converged, n_iter = _newton(t_new, c, jac, factors, vec, clock, counts, contacts,
                                        model, again)
            if converged or counts.jac_current == 1:
                break
            _jacobian_into(t_new, vec.predict, model, jac, factors.linked, contacts,
                           work.jacobian)
            counts.jev += 1
            counts.has_lu, counts.jac_current, again = 0, 1, True
        if not converged:
            h_abs *= 0.5
            _change_d(d, order, 0.5, rescale)
            counts.equal, counts.has_lu = 0, 0
            continue
        safety = 0.9 * (2 * NEWTON_MAXITER + 1) / (2 * NEWTON_MAXITER + n_iter)
        y_new, scale = vec.y, vec.scale
        for i in range(y_new.shape[0]):
            scale[i] = atol[i] + rtol * abs(y_new[i])
        error_norm = _scaled_norm(error_const[order], vec.d, scale)
        if error_norm <= 1.0:
            clock.h = h_abs
            return t_new, n_iter
        factor = max(MIN_FACTOR, safety * error_norm ** (-1.0 / (order + 1)))
        h_abs *= factor
        _change_d(d, order, factor, rescale)  # the LU stays: Newton converged with it
        counts.equal = 0


@kernel(inline="always")
def _accept(t_new, n_iter, clock, counts, d, dd, scale, rescale):
    """The rest of one accepted step of SciPy's ``BDF`` after :func:`_attempt` (which
    reached ``t_new`` in ``n_iter`` Newton iterations, the new state's difference from
    the prediction in ``dd``, its error scale in ``scale``): the differences updated
    and, after ``order + 1`` steps of one size, the order and step chosen from the
    error estimates of the orders either side.
    """
    order, error_const = counts.order, _COEFFS[2]
    counts.steps += 1
    counts.equal += 1
    clock.t = t_new
    for k in range(dd.shape[0]):
        d[order + 2, k] = dd[k] - d[order + 1, k]
        d[order + 1, k] = dd[k]
    for i in range(order, -1, -1):
        for k in range(dd.shape[0]):
            d[i, k] += d[i + 1, k]
    if counts.equal < order + 1:
        return
    safety = 0.9 * (2 * NEWTON_MAXITER + 1) / (2 * NEWTON_MAXITER + n_iter)
    norm = _scaled_norm(error_const[order], dd, scale)
    down = _scaled_norm(error_const[order - 1], d[order], scale) if order > 1 else np.inf
    up = _scaled_norm(error_const[order + 1], d[order + 2], scale) \
        if order < MAX_ORDER else np.inf
    best, delta = -1.0, 0
    for k, value in enumerate((down, norm, up)):  # the first largest, as argmax
        factor = np.inf if value == 0.0 else value ** (-1.0 / (order + k))
        if factor > best:
            best, delta = factor, k - 1
    counts.order = order + delta
    factor = min(MAX_FACTOR, safety * best)
    clock.h *= factor
    _change_d(d, order + delta, factor, rescale)
    counts.equal = 0


@kernel()
def _dense(d, t, h, order, tq, out):
    """SciPy's ``BdfDenseOutput`` at ``tq``: the interpolating polynomial of the last
    step from its backward differences (step ``h``, ending at ``t``).
    """
    out[:] = d[0]
    p = 1.0
    for i in range(order):
        p *= (tq - (t - h * i)) / (h * (1 + i))
        out += d[i + 1] * p


@kernel()
def advance(run, t_stop, t_bound, atol, rtol, model, t_out, out):
    """Step the run (:func:`start`'s :class:`Run`) until ``t >= t_stop`` (or
    ``t_bound``, the end, where the status becomes finished), filling the rows of ``out``
    at the sorted instants ``t_out`` as they are passed; the status and counters are in
    ``run.counts``.
    A time or step that is not a number (the right-hand side at the start was not
    finite) or a step that falls below the spacing of numbers ends the run with that
    status: it never raises and never loops on a NaN. A step is :func:`_attempt` and
    :func:`_accept`, both inlined here (handing ``work`` down once a step).
    """
    clock, counts, d, jac, factors, work = run.clock[0], run.counts[0], run.d, run.jac, \
        run.factors, run.work
    if not (np.isfinite(clock.t) and np.isfinite(clock.h)):
        counts.status = NOT_FINITE
    vec = work.vectors
    while counts.status == RUNNING and clock.t < t_stop:
        counts.jac_current = 0
        t_new, n_iter = _attempt(clock, counts, d, jac, factors, work, t_bound, atol, rtol,
                                 model)
        if not np.isnan(t_new):
            _accept(t_new, n_iter, clock, counts, d, vec.d, vec.scale, work.rescale)
        if counts.status != RUNNING:
            break
        t = clock.t
        while counts.out < t_out.shape[0] and t_out[counts.out] <= t:
            at = counts.out
            _dense(d, t, clock.h, counts.order, t_out[at], out[at])
            counts.out += 1
        if t >= t_bound:
            counts.status = FINISHED
