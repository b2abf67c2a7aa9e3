"""The names a mistyped name was probably meant to be, for every lookup by name: a
scene's keys, the built-in scenes, the formulations, the solver backends and the
methods ``cardan repro`` draws. A refusal names them so that a typo costs one look.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterable

MARGIN = 0.1
"""Names scored this much below the nearest one are left out: ``clarabl`` suggests
``clarabel`` alone, not also ``cvxpy-clarabel``."""


def nearest(name, known: Iterable, cutoff: float = 0.6, most: int = 3) -> list:
    """At most ``most`` of ``known``, nearest ``name`` first, with case set aside (so
    ``c_N`` is nearest ``C_N``): those whose similarity (:class:`difflib.SequenceMatcher`)
    reaches ``cutoff`` and is within :data:`MARGIN` of the nearest's; when none does,
    those holding ``name`` as one of their words between ``-``, ``_`` or ``.`` (``osqp``:
    ``qpsolvers-osqp`` and ``cvxpy-osqp``). Empty when none is near.
    """
    folded = {str(k).lower(): k for k in known}
    typed = str(name).lower()
    scored = sorted(((difflib.SequenceMatcher(None, typed, k).ratio(), k) for k in folded),
                    key=lambda pair: -pair[0])
    best = scored[0][0] if scored else 0.0
    close = [k for score, k in scored if score >= cutoff and score >= best - MARGIN]
    if not close:
        close = [k for k in folded if typed in re.split(r"[-_.]", k)]
    return [folded[k] for k in close[:most]]


def did_you_mean(name, known: Iterable) -> str:
    """``"; did you mean 'a'?"`` (``'a' or 'b'``, ...) naming :func:`nearest`'s names for
    a refusal to end with; empty when none is near.
    """
    near = [f"'{k}'" for k in nearest(name, known)]
    if not near:
        return ""
    listed = near[0] if len(near) == 1 else f"{', '.join(near[:-1])} or {near[-1]}"
    return f"; did you mean {listed}?"
