"""Backends ``lcp-lemke``, ``lcp-pgs``, ``lcp-fb-newton``: the package's own LCP methods
(:mod:`.lcp_methods`) on an :class:`LCP`, Lemke's without a start, the iterative two
warm-started from ``initvals``.
"""

from __future__ import annotations

import time

import numpy as np
from cardan_forces.formulations.problems import LCP

from . import settings
from .backend import Backend
from .lcp_methods import fb_newton, lemke, pgs
from .record import Outcome

EXTRAS: dict[str, str | None] = dict.fromkeys(("lcp-lemke", "lcp-pgs", "lcp-fb-newton"))


def _adapter(method, key: str, warm: bool):
    """Wrap one method, named ``key`` in :data:`.settings.TOLERANCES`, as a backend
    function (``initvals`` used only by ``warm`` methods).
    """

    def solve_lcp(problem: LCP, tol=None, initvals=None, **options) -> Outcome:
        start = time.perf_counter()
        M, q = np.asarray(problem.M, float), np.asarray(problem.q, float)
        kwargs = settings.solver_options(key, tol) | options
        if warm and initvals is not None:
            kwargs["z0"] = initvals
        setup_done = time.perf_counter()
        result = method(M, q, **kwargs)
        return Outcome(result.status, result.z, iterations=result.iterations,
                       message=result.message, setup_s=setup_done - start,
                       solve_s=time.perf_counter() - setup_done)

    return solve_lcp


def backends() -> list[Backend]:
    """The three LCP methods (NumPy only, always present)."""
    dist = ("cardan-forces", "numpy")
    return [
        Backend(name=f"lcp-{key}", family="lcp", distributions=dist, accepts=(LCP,),
                solve=_adapter(method, key, warm), tolerances=settings.TOLERANCES[key],
                warm_start=warm)
        for key, method, warm in (("lemke", lemke, False), ("pgs", pgs, True),
                                  ("fb-newton", fb_newton, True))
    ]
