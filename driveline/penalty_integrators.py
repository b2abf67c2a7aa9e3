"""Integrator drivers of the penalty simulation
(:func:`~cardan_forces.driveline.penalty.simulate_penalty`): each runs one integrator
from the start to the last instant asked for, fills the sampled states, reports
progress marks and turns a failure into a status and message, never an exception.

``run_odeint``: LSODA through ``odeint`` (its stepping loop in Fortran);
``run_stepped``: SciPy's ``BDF`` and ``Radau`` stepped here as ``solve_ivp`` does;
``run_compiled``: the compiled BDF of :mod:`~cardan_forces.driveline.penalty_kernels`,
advanced from one progress mark to the next. ``timed`` wraps a model's right-hand side
and Jacobian with wall clocks for the SciPy integrators.
"""

from __future__ import annotations

import time as _time
import warnings

import numpy as np
from scipy.integrate import ODEintWarning, odeint

from . import penalty_kernels as kernels

RTOL = 1e-10
"""Relative tolerance of every integrator (at its floor: the tolerances are absolute)."""


class Marks:
    """Calls ``progress(mark)`` once the integration has reached each mark, every
    ``every`` seconds of simulated time up to ``end``.
    """

    def __init__(self, progress, t0: float, end: float, every: float):
        self.progress, self.end, self.every = progress, end, every
        self.next = t0 + every

    def reached(self, time: float) -> None:
        while self.progress is not None and time >= self.next - 1e-12 \
                and self.next <= self.end + 1e-12:
            self.progress(self.next)
            self.next += self.every


FAILURES = (ArithmeticError, ValueError, np.linalg.LinAlgError)
"""What a failing SciPy integration raises: turned into status -1 and its message."""


def run_odeint(_, fun, jac, t0, y0, t, atol, states, marks: Marks):
    """LSODA through ``odeint``, whose stepping loop is Fortran (SciPy's ``LSODA`` class
    is the same ODEPACK code stepped from Python, dearer a step); ``states`` rows
    are filled at the instants ``t``. Returns status, message and (steps, Jacobians,
    LU factorizations: one with each Jacobian in LSODA).
    """
    order = np.argsort(t)
    later = order[t[order] > t0]
    grid = np.concatenate([[t0], t[later]])

    def watched(time, y):
        marks.reached(time)
        return fun(time, y)

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ODEintWarning)
            ys, info = odeint(watched, y0, grid, Dfun=jac, tfirst=True, rtol=RTOL, atol=atol,
                              full_output=True, mxstep=2**31 - 1)
    except FAILURES as err:
        return -1, f"{type(err).__name__}: {err}", (0, 0, 0)
    ok = info["message"] == "Integration successful."
    reached = np.r_[True, info["tcur"] >= grid[1:] - 1e-12 * max(abs(grid[-1]), 1.0)]
    valid = np.cumprod(reached & np.all(np.isfinite(ys), axis=1)).astype(bool)
    states[later] = np.where(valid[1:, None], ys[1:], np.nan)
    steps = int(info["nst"][-1]) if len(info["nst"]) else 0
    jacobians = int(info["nje"][-1]) if len(info["nje"]) else 0
    return (0 if ok and valid.all() else -1, "finished" if ok else str(info["message"]),
            (steps, jacobians, jacobians))


def run_compiled(model, t0, y0, t, atol, states, marks: Marks):
    """``BDF-numba``: the compiled integrator (:func:`penalty_kernels.advance`) run from
    one progress mark to the next; ``states`` rows are filled at the instants ``t``
    from its dense output. Returns status, message and (steps, Jacobians, LU
    factorizations, right-hand sides).
    """
    order = np.argsort(t)
    later = order[t[order] > t0]
    end, arrays = float(t.max()), model.arrays
    out = np.full((len(later), len(y0)), np.nan)
    run = kernels.start(t0, y0, end, atol, RTOL, arrays)
    counts, clock = run.counts, run.clock  # arrays of one record each
    stops = np.append(np.arange(t0 + marks.every, end, marks.every), end)
    for stop in stops:
        kernels.advance(run, stop, end, atol, RTOL, arrays, t[later], out)
        if counts["status"][0] != kernels.RUNNING:
            break
        marks.reached(clock["t"][0])
    marks.reached(clock["t"][0])
    states[later] = out
    ok = counts["status"][0] == kernels.FINISHED and np.all(np.isfinite(out))
    message = kernels.MESSAGES.get(int(counts["status"][0]), "failed")
    if not ok and message == "finished":
        message = "the state is not finite"
    totals = (counts["steps"][0], counts["jev"][0], counts["nlu"][0], counts["fev"][0])
    return (0 if ok else -1), (f"{message} at t = {clock['t'][0]:.6g} s" if not ok
                               else message), tuple(int(c) for c in totals)


def run_stepped(solver_class, fun, jac, t0, y0, t, atol, states, marks: Marks):
    """SciPy's ``OdeSolver`` (``BDF``, ``Radau``) stepped here, as ``solve_ivp`` does;
    ``states`` rows are filled at the instants ``t`` from its dense output.
    """
    solver = solver_class(fun, t0, y0, float(t.max()), rtol=RTOL, atol=atol, jac=jac)
    order, n_steps, message = np.argsort(t), 0, None
    i = int(np.searchsorted(t[order], t0, side="right"))
    try:
        while solver.status == "running":
            message = solver.step()
            n_steps += 1
            if solver.status == "failed":
                break
            if not np.all(np.isfinite(solver.y)):
                solver.status, message = "failed", f"non-finite state at t = {solver.t} s"
                break
            stop = int(np.searchsorted(t[order], solver.t, side="right"))
            if stop > i:
                states[order[i:stop]] = solver.dense_output()(t[order[i:stop]]).T
                i = stop
            marks.reached(solver.t)
    except FAILURES as err:
        solver.status, message = "failed", f"{type(err).__name__}: {err}"
    status = 0 if solver.status == "finished" else -1
    return (status, message or ("finished" if status == 0 else "failed"),
            (n_steps, int(solver.njev), int(solver.nlu)))


def timed(model, kernel: str, step: np.ndarray, clock: dict):
    """The right-hand side and Jacobian of ``kernel`` for the integrator, adding the wall
    time spent in each to ``clock``.
    """
    if kernel == "numba":
        rhs, jacobian = model.rhs_compiled, model.jacobian_compiled
    else:
        rhs = lambda time, y: model.rhs(time, y[:, None])[:, 0]  # noqa: E731
        jacobian = lambda time, y: model.jacobian(time, y, step)  # noqa: E731
    tick = _time.perf_counter

    def fun(time, y):
        begin = tick()
        out = rhs(time, y)
        clock["rhs"] += tick() - begin
        return out

    def jac(time, y):
        begin = tick()
        out = jacobian(time, y)
        clock["jacobian"] += tick() - begin
        return out

    return fun, jac
