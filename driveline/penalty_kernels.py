"""Compiled right-hand side, Jacobian and integrator of the penalty-contact simulation.

The same Newton-Euler equations and contact law (paper eqs. 75-78) as the NumPy model
of :mod:`cardan_forces.driveline.penalty_model` (their oracle: the tests hold each
compiled path to it), written as loops over bodies and contacts and compiled by numba:
one state costs a few thousand flops, far less than the interpreter's overhead of array
calls on a few bodies and dozens of contacts.
This module is their public face; the kernels live by concern:

- :mod:`.penalty_contact`: contact geometry, the contact law and the right-hand side;
- :mod:`.penalty_jacobian`: the Jacobian by the chain rule, by hand;
- :mod:`.penalty_linear`: the structured factorization and solve of ``I - c J``;
- :mod:`.penalty_bdf`: SciPy's variable-order BDF as numba loops (:func:`start`,
  :func:`advance`): the whole integration runs compiled, the kernels called with no
  Python in between.

**Named state.** Every array the kernels share is a field of a named tuple: the model
(:class:`~.penalty_contact.ModelArrays`, the kernels' one model argument), the frames
and contact kinematics (:class:`~.penalty_contact.ContactState`), the Jacobian's
scratch, the factors, a run's work arrays (:class:`~.penalty_bdf.Run`); a run's clock
and counters are the named fields of one record each (:data:`~.penalty_bdf.CLOCK`,
:data:`~.penalty_bdf.COUNTS`). Each array a kernel is handed costs a reference count
each way, so the hot kernels take the arrays they use, not whole tuples.

**Inlined calls.** A compiled call takes and drops a reference to every array it is
handed, one atomic count each way, and the integrator hands its state down as tuples
of dozens of arrays: a few hundred counts a step, about as dear as the arithmetic of a
Newton iteration. So the kernels the step calls many times (right-hand side, Newton
iteration and solve, the Jacobian's and the factorization's parts, the step itself)
are inlined (``inline="always"``), leaving as calls only the factorization and the
Jacobian, made less than once a step: each kernel cheaper, the same numbers to the
bit, for a longer compilation (once). An integrator inlines kernels of all four files:
each kernel's disk cache is keyed by all of their contents
(:data:`~.penalty_contact.KERNEL_FILES`, :func:`.compiled.njit`'s ``depends``), so an
edit of any of them compiles them all again instead of loading stale copies.

**Numbers, not exceptions.** Compiled with NumPy's error model (:mod:`.compiled`): a
division by zero gives an infinity or a NaN, and the integrator ends with a failed
status and its reason, as SciPy's does; it never raises from compiled code.

Without numba the functions still run (as plain Python, slowly); the simulation then
uses the NumPy model and SciPy's integrators instead (:data:`HAVE_NUMBA`).
"""

from __future__ import annotations

from cardan_forces.util.compiled import HAVE_NUMBA

from .penalty_bdf import (
    FINISHED,
    MESSAGES,
    NOT_FINITE,
    RUNNING,
    STEP_TOO_SMALL,
    Run,
    advance,
    start,
)
from .penalty_contact import (
    FACE,
    LINE,
    RADIAL,
    SPRING,
    TWIST,
    ModelArrays,
    contact_forces,
    rhs,
)
from .penalty_jacobian import jacobian

__all__ = ["COMPLEX_STEP", "FACE", "FINISHED", "HAVE_NUMBA", "LINE", "MESSAGES", "ModelArrays",
           "NOT_FINITE", "RADIAL", "RUNNING", "SPRING", "STEP_TOO_SMALL", "TWIST", "Run",
           "advance", "contact_forces", "jacobian", "rhs", "start"]

COMPLEX_STEP = 1e-30
"""Imaginary step (per unit of a quantity's scale) of the NumPy model's Jacobian; far
below round-off, so the derivative is exact to the precision of the function."""
