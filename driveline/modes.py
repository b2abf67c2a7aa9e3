"""The null space of ``A``, named: which redundancy each free direction is, and the
release that removes it (DESIGN §1, modes).

Found from the operator's structure, not fitted to the numbers:

- **pairs**: pushing both of a pair of opposite unilateral columns equally,
  ``e_a + e_b``, named by the kind that made them (an **end-face pair**: both end
  faces of one trunnion pair). Complementarity (only one face of a pair can touch,
  paper eqs. 39, 46) resolves it; no release is needed.
- **axial split**: equal and opposite axial forces in two locating bearings (whose
  kind carries axial force both ways) of one shaft body (``s`` in the first
  bearing's components, ``-s`` in the next one's): ``n - 1`` per body with ``n``
  locating bearings. Released by making one of them floating.
- **closed loop**: what remains of the null space, its orthogonal complement of the
  two kinds above: a self-stress running around a loop of bodies through the ground
  (in the paper's line: an axial force in the intermediate shaft through both
  cross-pins, closed by the bearings). Released by a slip joint in a shaft of the
  loop (or by floating every bearing that closes it); :func:`loop_releases` finds
  which single releases remove one.

The count of all the kinds equals the nullity (checked, :class:`ModeError`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .determinacy import Determinacy
from .equilibrium import Operator

SHOWN_TOL = 0.05
"""A mode "moves" a component whose entry exceeds this fraction of its largest."""


class ModeError(RuntimeError):
    """The named modes do not span the null space (a modelling error, never input)."""


@dataclass(frozen=True)
class Mode:
    """One free direction of ``A x = b``: ``direction`` over the operator's columns."""

    kind: str
    description: str
    components: tuple[str, ...]
    release: str
    direction: np.ndarray

    def to_json(self) -> dict:
        return {"kind": self.kind, "description": self.description,
                "components": list(self.components), "release": self.release}


def structural_modes(op: Operator, i: int) -> list[Mode]:
    """Pair and axial split modes at instant ``i`` (unit vectors)."""
    n = len(op.names)
    modes = []
    link_of = {c: link for link in op.contacts for c in link.columns}
    for a, b in op.pairs:
        v = np.zeros(n)
        v[[a, b]] = 1.0 / np.sqrt(2.0)
        named = link_of[a].element_kind.pair_mode(link_of[a], link_of[b])
        modes.append(Mode(named.kind, named.description, (op.names[a], op.names[b]),
                          named.release, v))
    for body, group in _locating_by_body(op).items():
        axis = op.shaft_frames[op.bodies[body].shaft, 2]
        for first, second in zip(group, group[1:]):
            v = np.zeros(n)
            v[list(first.columns)] = axis / np.sqrt(2.0)
            v[list(second.columns)] = -axis / np.sqrt(2.0)
            modes.append(Mode(
                "axial split", f"equal and opposite axial forces in bearings {first.element} "
                f"and {second.element} of {op.bodies[body].name}",
                tuple(op.names[c] for c in (*first.columns, *second.columns) if abs(v[c]) > 0),
                f"make bearing {first.element} or {second.element} floating", v))
    return modes


def _locating_by_body(op: Operator) -> dict:
    by: dict[int, list] = {}
    for c in op.bearings():
        if c.element_kind.locates:
            by.setdefault(c.body, []).append(c)
    return {k: v for k, v in by.items() if len(v) > 1}


def name_modes(op: Operator, i: int, det: Determinacy, loop_release: str = "") -> list[Mode]:
    """Every null-space direction at instant ``i``, named; closed loops are the
    complement of the structural modes in the null space.
    """
    modes = structural_modes(op, i)
    N = det.null_basis
    if modes:
        S = np.array([m.direction for m in modes]).T
        if np.linalg.norm(op.A[i] @ S) > 1e-9 * max(np.linalg.norm(op.A[i]), 1.0):
            raise ModeError("a structural mode is not in the null space of A")
        if np.linalg.matrix_rank(S, tol=1e-9) != S.shape[1]:
            raise ModeError("the structural modes are dependent")
        Q, _ = np.linalg.qr(S)
        rest = N - Q @ (Q.T @ N)
    else:
        rest = N
    u, s, _ = np.linalg.svd(rest, full_matrices=False)
    loops = u[:, s > 1e-6]
    if len(modes) + loops.shape[1] != det.nullity:
        raise ModeError(f"{len(modes)} structural + {loops.shape[1]} loop modes for nullity "
                        f"{det.nullity}")
    for v in loops.T:
        v = v if v[np.argmax(np.abs(v))] > 0 else -v
        modes.append(Mode("closed loop", f"self-stress through {_path(op, v)}",
                          _moved(op, v), loop_release, v))
    return modes


def _moved(op: Operator, v: np.ndarray) -> tuple[str, ...]:
    big = np.abs(v) > SHOWN_TOL * np.abs(v).max()
    return tuple(name for name, b in zip(op.names, big) if b)


def _path(op: Operator, v: np.ndarray) -> str:
    """The bodies the loop's contacts load, in chain order, closed through the ground."""
    big = np.abs(v) > SHOWN_TOL * np.abs(v).max()
    bodies, ground = set(), False
    for c in op.contacts:
        if big[list(c.columns)].any():
            bodies.add(c.body)
            if c.other is None:
                ground = True
            else:
                bodies.add(c.other)
    names = [op.bodies[b].name for b in sorted(bodies, key=lambda b: _chain(op.bodies[b], b))]
    return ", ".join(["ground", *names, "ground"] if ground else names)


def _chain(body, index: int) -> tuple[int, int]:
    """Position along the line: shaft k at 2k, the cross-pin of joint j at 2j + 1 (a
    shaft's segments in body order).
    """
    return (2 * body.shaft, index) if body.joint is None else (2 * body.joint + 1, index)


def counts(modes: list[Mode]) -> dict[str, int]:
    """How many modes of each kind: every pair kind present, axial splits and closed
    loops (those two always, as the ones a release removes).
    """
    kinds = dict.fromkeys([m.kind for m in modes] + ["axial split", "closed loop"])
    return {kind: sum(m.kind == kind for m in modes) for kind in kinds}
