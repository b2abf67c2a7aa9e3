"""Which formulations ``cardan repro`` draws, which it sets beside the penalty
simulation, and what each costs a worker: the report's choices, keyed by the
registry's names (:mod:`cardan_forces.formulations` defines the formulations and says
nothing of these).
"""

from __future__ import annotations

METHODS = ("paper", "positive", "min_max", "compliance")
"""Methods (formulations) drawn in the figures, in the registry's order, each by the
study layer's default backend (:func:`cardan_forces.experiments.study.default_backend`).
``min_norm`` is left out: its end faces pull, so it is no contact force."""

COMPLIANCE_VS_PENALTY = ("min_norm", "positive", "compliance", "compliance_hertz")
"""Methods compared with the penalty simulation (each by its default backend), on the
released scene's operator (the same effects, so the compliance formulations see the
same clearances as gaps), in the registry's order."""

JOB_COST = {"paper": 4.0, "min_norm": 0.6, "min_max": 2.0, "compliance": 0.5,
            "compliance_hertz": 2.7}
"""Relative CPU cost of a method's run over the whole time grid by its default backend
(1 for one not named here): the worker queue starts the dearest first, so that the
workers end together."""
