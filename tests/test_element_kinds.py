"""The element kinds' protocol, held on every built-in scene: what each kind gives
covers its own columns exactly, so a kind that forgets a component (or claims another
kind's) fails here, whichever kind it is."""

import numpy as np
import pytest
from cardan_forces.driveline import penalty
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.elements.registry import KINDS, LINK_KINDS
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import builtin_names, load_scene


def test_every_link_kind_belongs_to_one_kind():
    names = [name for kind in KINDS for name in kind.link_kinds]
    assert len(names) == len(set(names)) == len(LINK_KINDS)


@pytest.mark.parametrize("name", builtin_names())
def test_each_kind_covers_its_columns(name):
    """Per link: its compliance laws' groups partition its columns; its pairs are
    opposite unilateral columns of its own links; its words name it; the bearings'
    directions stop what their columns carry."""
    op = build_operator(simulate(load_scene(name), [0.3]))
    for link in op.contacts:
        kind = link.element_kind
        groups = [c for law in kind.laws(link, op.scene) for c in law.columns]
        assert sorted(groups) == list(link.columns), link.name
        assert kind.words(link)
    own = {c for link in op.contacts for c in link.columns}
    for a, b in op.pairs:
        assert op.unilateral[a] and op.unilateral[b] and {a, b} <= own
        assert np.allclose(op.A[0][:, a], -op.A[0][:, b], atol=1e-12 * np.abs(op.A[0]).max())


@pytest.mark.parametrize("name", ["paper-slip", "propshaft", "axle-pinion"])
def test_each_link_has_penalty_contacts_on_its_own_bodies(name):
    """The penalty model's contacts of a link join the link's two bodies (the ground
    the last index), and every link has some."""
    model = penalty._Model(load_scene(name), penalty.DAMPING_LENGTH_UNIT_M)
    for link, rows in zip(model.operator.contacts, model.parts):
        other = model.n_bodies if link.other is None else link.other
        assert rows, link.name
        assert set(model.c.a[rows]) == {link.body} and set(model.c.b[rows]) == {other}
