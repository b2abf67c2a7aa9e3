"""Releases: the design changes that remove a redundancy of the rigid model.

Each element kind offers its own (:mod:`.elements`; the kinds' modules say what each
does), the ways real drive lines avoid redundant constraints; those of the built-in
kinds:

- ``float:<shaft>.<bearing>``: make a locating bearing floating (it keeps its radial
  support and lets the shaft slide through it axially);
- ``slip:<shaft>``: put a frictionless slip (spline) joint in a shaft.

Neither changes the 1-DOF motion: the kinematics and the reduced inertia are those
of the shafts, which turn as before; so a released operator is built on the same
:class:`~cardan_forces.driveline.dynamics.Motion`. A release set that leaves a part of
the line unheld is refused with a :class:`~cardan_forces.driveline.scene.SceneError`
(the scene's own element checks, and the operator's rank: a line held with one
degree of freedom has exactly one dependent Newton-Euler row, the motion's).
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from itertools import combinations
from math import comb

import numpy as np

from .determinacy import Determinacy, determinacy, holding
from .dynamics import Motion
from .elements.base import Release
from .elements.checks import check_elements
from .elements.registry import BEARING_KINDS, RELEASES
from .equilibrium import Operator, build_operator
from .modes import Mode, counts, name_modes
from .scene import Scene, SceneError
from .support import check_loads

__all__ = ["Advice", "MAX_RELEASES", "MAX_RELEASE_SETS", "Release", "ReleaseSearchTooLarge",
           "advise", "at_instant", "candidates", "named_modes", "parse_release",
           "released_operator", "released_scene", "search_size"]


def parse_release(text: str, scene: Scene) -> Release:
    """``<prefix>:<target>`` (``float:<shaft>.<bearing>``, ``slip:<shaft>``, as the
    kinds offer them), checked against ``scene``.
    """
    prefix, _, target = text.partition(":")
    for kind in RELEASES.values():
        if kind.release_form.partition(":")[0] == prefix:
            found = kind.parse_release(target, scene)
            if found is not None:
                return found
    forms = " or ".join(k.release_form for k in RELEASES.values())
    raise SceneError(f"release {text!r}: expected {forms} with names of scene "
                     f"{scene.name!r}")


def candidates(scene: Scene) -> list[Release]:
    """Every single release the scene admits, as its kinds offer them (slips first: a
    slip removes loops; then each locating bearing floating).
    """
    return [r for kind in RELEASES.values() for r in kind.releases(scene)]


def released_scene(scene: Scene, releases: list[Release] | tuple[Release, ...]) -> Scene:
    """``scene`` with ``releases`` applied, validated again: SceneError with the
    validation's own message where the released scene is refused (a part of the line
    left unheld, ...).
    """
    labels = ", ".join(r.label for r in releases) or "none"
    variant = _variant(scene, releases)
    try:
        return scene.with_changes(shafts=variant.shafts, elements=variant.elements,
                                  name=variant.name, description=variant.description)
    except SceneError as err:
        raise SceneError(f"releases {labels} do not apply: {err}") from None


def _variant(scene: Scene, releases) -> Scene:
    """``scene`` with ``releases`` applied, not yet validated: what the search builds
    its operators from (:func:`released_scene` validates it).
    """
    shafts, elements = list(scene.shafts), list(scene.elements)
    for r in releases:
        r.offered_by.apply_release(r, shafts, elements)
    order = {s.name: k for k, s in enumerate(shafts)}
    elements.sort(key=lambda e: (order[e.shaft], e.offset_m))
    labels = ", ".join(r.label for r in releases) or "none"
    return dataclasses.replace(scene, shafts=tuple(shafts), elements=tuple(elements),
                               name=f"{scene.name}+released",
                               description=f"{scene.name} with releases: {labels}")


def released_operator(motion: Motion, releases) -> Operator:
    """The operator of the released scene on the same motion; SceneError when the
    releases leave a mechanism (more than the motion's one dependent row).
    """
    op = build_operator(dataclasses.replace(motion, scene=released_scene(motion.scene,
                                                                         releases)))
    _refuse_mechanism(op, releases)
    return op


def _refuse_mechanism(op: Operator, releases) -> None:
    """SceneError when ``op`` has more than one dependent row at some instant."""
    free = max(holding(A).free for A in op.A)
    if free > 1:
        labels = ", ".join(r.label for r in releases)
        raise SceneError(f"releases {labels} leave a mechanism: {free - 1} "
                         "direction(s) in which the released line moves without deforming "
                         "(besides its rotation)")


def at_instant(motion: Motion, i: int) -> Motion:
    """``motion`` at its instant ``i`` alone (every time-indexed array keeps that one
    instant: axis 0 of the 1-D arrays, axis 1 of the others): a question about one
    instant builds operators and rank tests there, not over the whole grid.
    """
    def take(a: np.ndarray) -> np.ndarray:
        return a[[i]] if a.ndim == 1 else a[:, [i]]

    def cut(obj):
        return dataclasses.replace(obj, **{f.name: take(getattr(obj, f.name))
                                           for f in dataclasses.fields(obj)
                                           if isinstance(getattr(obj, f.name), np.ndarray)})

    return dataclasses.replace(cut(motion), kin=cut(motion.kin))


MAX_RELEASES = 4
"""The advisor tries every set of up to this many releases."""

MAX_RELEASE_SETS = 400
"""Most release sets the advisor may have to try (every set of up to
:data:`MAX_RELEASES` of the scene's candidates), known before any is built: each costs
an operator and SVDs, dearer with every shaft. The built-in scenes need at
most 99; a line with every bearing of eight shafts locating would need thousands."""


class ReleaseSearchTooLarge(SceneError):
    """The release search a scene would need exceeds :data:`MAX_RELEASE_SETS`."""


def search_size(scene: Scene) -> int:
    """Release sets of up to :data:`MAX_RELEASES` of ``scene``'s :func:`candidates`."""
    n = len(candidates(scene))
    return sum(comb(n, k) for k in range(MAX_RELEASES + 1))


@dataclass(frozen=True)
class Advice:
    """The smallest release set that leaves only pair modes (end-face pairs, ...), verified.

    ``modes``/``released_modes`` and ``determinacy``/``released`` before and after at
    the same instant; ``alternatives``: other sets of the same size that also work;
    ``tried``: release sets built and checked.
    """

    releases: tuple[Release, ...]
    scene: Scene
    modes: tuple[Mode, ...]
    released_modes: tuple[Mode, ...]
    determinacy: Determinacy
    released: Determinacy
    operator: Operator
    alternatives: tuple[tuple[Release, ...], ...]
    tried: int

    def to_json(self) -> dict:
        return {
            "releases": [r.to_json() for r in self.releases],
            "alternatives": [[r.label for r in alt] for alt in self.alternatives],
            "tried": self.tried,
            "before": {"rank": self.determinacy.rank, "nullity": self.determinacy.nullity,
                       "modes": counts(list(self.modes))},
            "after": {"rank": self.released.rank, "nullity": self.released.nullity,
                      "modes": counts(list(self.released_modes))},
        }


def named_modes(motion: Motion, i: int, op: Operator | None = None) -> list[Mode]:
    """The modes of ``motion``'s scene at instant ``i`` (of ``op`` when given, built at
    that instant otherwise), each closed loop with the single releases that remove one
    loop (tried at the same instant; each such release validated as a scene).
    """
    one = at_instant(motion, i)
    here, k = (build_operator(one), 0) if op is None else (op, i)
    modes = name_modes(here, k, determinacy(here, k))
    loops = counts(modes)["closed loop"]
    if not loops:
        return modes
    helps = [r.words for r in candidates(motion.scene)
             if _fewer_loops(one, (r,), loops) and _valid_release(motion.scene, r)]
    text = "; or ".join(helps) or "no single release (combine several)"
    return [dataclasses.replace(m, release=_friction_words(here, m) + text)
            if m.kind == "closed loop" else m for m in modes]


def _fewer_loops(one: Motion, releases, loops: int) -> bool:
    """Whether ``releases`` leave fewer than ``loops`` closed loops on ``one``."""
    after = _try(one, releases)
    return after is not None and counts(after[1])["closed loop"] < loops


def _friction_words(op: Operator, mode: Mode) -> str:
    """A loop through a slip joint's friction force is bounded (``|axial| <= mu T / r``);
    a frictionless spline removes it.
    """
    slips = [f.slip for f in op.slip_friction if op.names[f.axial] in mode.components]
    return "".join(f"bounded by the friction of slip joint {s}; a frictionless spline "
                   "removes it; or " for s in slips)


def _try(one: Motion, releases):
    """(operator, modes, determinacy) of the released line on the one-instant motion
    ``one``, None if the releases leave it a mechanism there. The variant is not
    validated here (:func:`_validated` does that for the sets the search keeps): its
    elements are checked and its rank tested, which refuse what validation would.
    """
    scene = _variant(one.scene, releases)
    try:
        check_elements(scene)
        op = build_operator(dataclasses.replace(one, scene=scene))
    except SceneError:
        return None
    if holding(op.A[0]).free > 1:
        return None
    det = determinacy(op, 0)
    return op, name_modes(op, 0, det), det


def _validated(scene: Scene, releases) -> Scene | None:
    """:func:`released_scene`, or None where validation refuses it."""
    try:
        return released_scene(scene, releases)
    except SceneError:
        return None


@functools.lru_cache(maxsize=256)
def _valid_release(scene: Scene, release: Release) -> bool:
    """Whether ``scene`` with ``release`` alone passes validation (once per release)."""
    return _validated(scene, (release,)) is not None


def _valid_set(scene: Scene, releases) -> bool:
    """Whether a release set that passed the search's checks (:func:`_try`: element
    checks, rank at the instant) is valid as a scene, validating only what a set adds to
    its releases. The fields a release writes are its own element's (a bearing's kind;
    a slip joint inside its shaft, off its bearings, one per shaft), so they are valid
    when each release alone validates (:func:`_valid_release`, cached); releases change
    neither inertias nor torques, so the motion's bound stays the scene's; the support
    check is implied by the rank test (a line held at one instant is held at the
    generic configuration, where the rank is not lower); what remains is the loads a
    line at rest can carry (:func:`check_loads`).
    """
    if not all(_valid_release(scene, r) for r in releases):
        return False
    try:
        check_loads(_variant(scene, releases))
    except SceneError:
        return False
    return True


def _preference(scene: Scene, releases) -> tuple[int, int, int]:
    """Smaller is better: shafts with two or more bearings that all let it slide
    (a design keeps one locating bearing per such shaft; a lone centre bearing may
    float), elements added (a slip joint: a floating bearing is the cheaper release),
    of them those in shafts with bearings (real lines put the spline in a propshaft).
    """
    shafts = {s.name: s for s in scene.shafts}
    slips = [r for r in releases if r.offered_by.adds_joint]
    return (sum(len(s.bearings) > 1 and all(BEARING_KINDS[b.kind].slides for b in s.bearings)
                for s in scene.shafts),
            len(slips), sum(bool(shafts[r.shaft].bearings) for r in slips))


def advise(motion: Motion, i: int) -> Advice:
    """Try release sets of growing size (at most :data:`MAX_RELEASES`) until one leaves
    only pair modes; among those of the smallest size prefer by
    :func:`_preference`, then the first in :func:`candidates` order. Each set is
    verified by re-running determinacy on the released line at instant ``i`` (the
    search builds every operator at that instant alone, :func:`at_instant`); the sets
    kept are valid as scenes (:func:`_valid_set`), the one advised validated whole
    (:func:`released_scene`), and its operator is the released line's over all of
    ``motion``'s instants. SceneError when no set
    of up to :data:`MAX_RELEASES` works; :class:`ReleaseSearchTooLarge` (a SceneError),
    before any work, when the search could need more than :data:`MAX_RELEASE_SETS` sets.
    """
    size = search_size(motion.scene)
    if size > MAX_RELEASE_SETS:
        raise ReleaseSearchTooLarge(
            f"scene {motion.scene.name!r}: the release search would try {size} release sets "
            f"(every set of up to {MAX_RELEASES} of {len(candidates(motion.scene))} "
            f"candidates); at most {MAX_RELEASE_SETS}: name the releases to apply instead")
    one = at_instant(motion, i)
    op = build_operator(one)
    det = determinacy(op, 0)
    modes = named_modes(one, 0, op)
    pool, tried = candidates(motion.scene), 0
    for size in range(0, MAX_RELEASES + 1):
        found = []
        for combo in combinations(pool, size):
            tried += 1
            result = _try(one, combo)
            if result is None:
                continue
            c = counts(result[1])
            if c["axial split"] == 0 and c["closed loop"] == 0:
                found.append((_preference(result[0].scene, combo), combo, result))
        found.sort(key=lambda f: f[0])  # stable: candidates order breaks ties
        kept = [f for f in found if _valid_set(motion.scene, f[1])]
        for _, combo, (_, rmodes, rdet) in kept:
            scene = _validated(motion.scene, combo)  # the advice's scene, validated whole
            if scene is None:
                continue
            return Advice(releases=combo, scene=scene, modes=tuple(modes),
                          released_modes=tuple(rmodes), determinacy=det, released=rdet,
                          operator=build_operator(dataclasses.replace(motion, scene=scene)),
                          alternatives=tuple(f[1] for f in kept if f[1] != combo),
                          tried=tried)
    raise SceneError(f"scene {motion.scene.name!r}: no set of up to {MAX_RELEASES} releases "
                     "leaves only pair modes (end-face pairs, ...)")
