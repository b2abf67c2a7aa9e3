"""The public API's arguments, checked as the command line checks its options.

A wrong argument is refused at the API's boundary, before any work, by one of the
package's own exceptions whose message names the argument and what it allows:
:class:`ArgumentError` (a ``ValueError``: an instant out of range, a time that is NaN),
:class:`ArgumentTypeError` (also a ``TypeError``: a scene name where a motion belongs,
an instant given as a float or a str) and :class:`UnknownChoice` (also a ``KeyError``:
a formulation the package does not have). Never an ``IndexError`` or an
``AttributeError`` from deep inside.
"""

from __future__ import annotations

import math
import numbers
import operator as _operator

import numpy as np

from .driveline.dynamics import Motion
from .driveline.equilibrium import Operator
from .driveline.release import Release
from .driveline.scene import Scene
from .util.names import did_you_mean


class ArgumentError(ValueError):
    """An argument of the public API outside what it allows (the message says what)."""


class ArgumentTypeError(ArgumentError, TypeError):
    """An argument of the public API of the wrong type (the message says which)."""


class UnknownChoice(ArgumentError, KeyError):
    """A name the package does not know; the message lists the known ones."""

    def __str__(self) -> str:  # KeyError would print its message quoted
        return str(self.args[0]) if self.args else ""


HINTS = {Motion: "cf.simulate(scene)", Operator: "cf.build_operator(motion)",
         Scene: "cf.load_scene(name or path)"}
"""Where each of the API's objects comes from, for the message that asks for one."""


def of_type(value, cls: type, name: str):
    """``value`` if it is a ``cls``; else :class:`ArgumentTypeError` saying where one
    comes from (a scene's name where a motion belongs: how to make the motion).
    """
    if isinstance(value, cls):
        return value
    hint = f" (from {HINTS[cls]})" if cls in HINTS else ""
    article = "an" if cls.__name__[0] in "AEIOU" else "a"
    text = f"{name} must be {article} {cls.__name__}{hint}, not {_shown(value)}"
    if isinstance(value, str) and cls in (Motion, Operator):
        text += f"; for the scene {value!r}: cf.simulate(cf.load_scene({value!r}))"
        text += "" if cls is Motion else ", then cf.build_operator"
    raise ArgumentTypeError(text)


def instant(owner: Motion | Operator, i, name: str = "i") -> int:
    """Instant index ``i`` of ``owner`` (its ``t``) as an int: an integer (not a float,
    a str or a bool) in ``0 .. T-1``.
    """
    T = len(owner.t)
    if isinstance(i, bool) or not hasattr(type(i), "__index__"):
        raise ArgumentTypeError(f"{name} must be an int instant index in 0..{T - 1}, not "
                                f"{_shown(i)}")
    k = _operator.index(i)
    if not 0 <= k < T:
        raise ArgumentError(f"{name} = {k}: outside the instants 0..{T - 1} of this "
                            f"{type(owner).__name__} ({T} instants, t = {_span(owner.t)} s)")
    return k


def instants(owner: Motion | Operator, values, name: str = "instants") -> list[int] | None:
    """Instant indices of ``owner`` (``None``: every instant), each as :func:`instant`;
    at least one.
    """
    if values is None:
        return None
    if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
        raise ArgumentTypeError(f"{name} must be a sequence of int instant indices, not "
                                f"{_shown(values)}")
    picked = [instant(owner, i, f"{name}[{k}]") for k, i in enumerate(values)]
    if not picked:
        raise ArgumentError(f"{name} must name at least one instant (None: every instant)")
    return picked


def choice(value, known, name: str) -> str:
    """``value``, one of the names ``known``; else :class:`UnknownChoice` naming the
    nearest (:func:`~cardan_forces.util.names.did_you_mean`), or all when none is.
    """
    if not isinstance(value, str):
        raise ArgumentTypeError(f"{name} must be a str among {', '.join(known)}, not "
                                f"{_shown(value)}")
    if value not in known:
        near = did_you_mean(value, known)
        raise UnknownChoice(f"unknown {name} {value!r}" + (near or f"; known: "
                                                           f"{', '.join(known)}"))
    return value


def name_or_none(value, name: str) -> str | None:
    """``value``: ``None`` or a str (a backend's name; the registry says if it exists)."""
    if value is not None and not isinstance(value, str):
        raise ArgumentTypeError(f"{name} must be a backend's name (str) or None, not "
                                f"{_shown(value)}")
    return value


def positive(value, name: str, allow_none: bool = False, inf: bool = False) -> float | None:
    """``value`` as a finite number > 0 (or ``None`` where ``allow_none``, infinity
    where ``inf``: no bound).
    """
    if value is None and allow_none:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ArgumentTypeError(f"{name} must be a positive number, not {_shown(value)}")
    if not ((math.isfinite(value) or (inf and value == math.inf)) and value > 0):
        bound = "a number > 0 (inf: none)" if inf else "a finite number > 0"
        raise ArgumentError(f"{name} = {value}: must be {bound}")
    return float(value)


def times(scene: Scene, values, name: str = "times") -> np.ndarray | None:
    """Instants (s) to simulate ``scene`` at (``None``: its grid): finite numbers, at
    least one, none before the scene's start ``time.start_s``.
    """
    if values is None:
        return None
    try:
        t = np.atleast_1d(np.asarray(values, float))
    except (TypeError, ValueError):
        raise ArgumentTypeError(f"{name} must be numbers (s), not {_shown(values)}") from None
    if t.ndim != 1 or t.size == 0:
        raise ArgumentError(f"{name} must be one or more instants (s), got shape {t.shape}")
    start = scene.time.start_s
    bad = ~np.isfinite(t) | (t < start)
    if bad.any():
        raise ArgumentError(f"{name}[{int(np.argmax(bad))}] = {t[bad][0]}: every instant "
                            f"must be a finite time (s) from the scene's start {start} s on")
    return t


def releases(values, name: str = "releases") -> list:
    """A list of releases: each a :class:`Release` or its label (``"slip:intermediate"``)."""
    if isinstance(values, (str, Release)) or not hasattr(values, "__iter__"):
        raise ArgumentTypeError(f"{name} must be a list of releases (e.g. "
                                f"['slip:intermediate']), not {_shown(values)}")
    chosen = list(values)
    for k, r in enumerate(chosen):
        if not isinstance(r, (Release, str)):
            raise ArgumentTypeError(f"{name}[{k}] must be a Release or a label such as "
                                    f"'float:input.far' or 'slip:intermediate', not "
                                    f"{_shown(r)}")
    return chosen


def callable_or_none(value, name: str):
    """``value``: ``None`` or something to call."""
    if value is not None and not callable(value):
        raise ArgumentTypeError(f"{name} must be callable or None, not {_shown(value)}")
    return value


def _shown(value) -> str:
    text = repr(value)
    text = text if len(text) <= 40 else text[:37] + "..."
    return f"{type(value).__name__} {text}"


def _span(t) -> str:
    t = np.asarray(t, float)
    return f"{t[0]:g}..{t[-1]:g}" if t.size else "none"
