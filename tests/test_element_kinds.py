"""The element kinds' protocol, held on every built-in scene: what each kind gives
covers its own columns exactly, so a kind that forgets a component (or claims another
kind's) fails here, whichever kind it is."""

from pathlib import Path

import numpy as np
import pytest
from cardan_forces.driveline import penalty
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.elements.base import (
    DRAKE,
    MUJOCO,
    RELEASES,
    ElementKind,
    EngineJoint,
    EngineLoop,
    FormulationExtras,
    Loads,
    Paired,
    Releasable,
)
from cardan_forces.driveline.elements.registry import KINDS, LINK_KINDS, PAIRED, refusals
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import builtin_names, load_scene

EVERY_KIND = Path(__file__).resolve().parent / "data" / "every_kind.toml"


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


CORE = ("holds", "add_links")
"""The core every kind writes; :data:`PER_LINK` every kind that makes links."""
PER_LINK = ("laws", "penalty", "words")
CAPABILITIES = (Paired, Releasable, Loads, EngineJoint, EngineLoop, FormulationExtras)


def _written(kind, name: str) -> bool:
    """Whether ``kind``'s class writes ``name`` (not the core's or a capability's default)."""
    owner = next(c for c in type(kind).__mro__ if name in vars(c))
    return owner not in (ElementKind, *CAPABILITIES)


@pytest.mark.parametrize("kind", KINDS, ids=lambda k: k.name)
def test_each_kind_writes_the_core_and_its_capabilities_required_methods(kind):
    """The core's required methods, the per-link ones where it makes links, and in each
    capability it mixes in the methods that capability requires."""
    assert kind.name
    for name in CORE + (PER_LINK if kind.link_kinds else ()):
        assert _written(kind, name), name
    required = {Paired: ("pairs", "pair_mode"), Loads: ("load",),
                Releasable: ("releases", "parse_release", "release_label", "release_words",
                             "apply_release"),
                EngineLoop: ("mjcf_loop",), FormulationExtras: ()}
    for capability, names in required.items():
        if isinstance(kind, capability):
            assert all(_written(kind, n) for n in names), capability.__name__
    if isinstance(kind, EngineJoint):  # one joint, or a chain of them
        assert _written(kind, "mjcf_joint") or _written(kind, "mjcf_steps"), kind.name
    if isinstance(kind, Releasable):
        assert kind.release_name and kind.release_form and isinstance(kind.release_rank, int)


def test_the_registry_lists_the_capable_kinds():
    assert list(RELEASES.values()) == sorted(
        (k for k in KINDS if isinstance(k, Releasable)), key=lambda k: k.release_rank)
    assert PAIRED == tuple(k for k in KINDS if isinstance(k, Paired))


@pytest.mark.parametrize("name", [*builtin_names(), str(EVERY_KIND)])
def test_a_kind_that_joins_bodies_without_an_engine_joint_refuses_the_engines(name):
    """The engines build their tree from :class:`EngineJoint` kinds and close
    :class:`EngineLoop` ones outside it: a link between two bodies of any other kind is
    refused before any work."""
    scene = load_scene(name)
    op = build_operator(simulate(scene, [0.3]))
    for engine in (MUJOCO, DRAKE):
        refused = {line.split("'")[1] for line in refusals(scene, engine)}
        for link in op.contacts:
            if link.other is not None and not isinstance(link.element_kind,
                                                         (EngineJoint, EngineLoop)):
                assert link.element in refused, link.name


def test_the_how_to_names_every_capability_and_its_methods():
    page = (Path(__file__).resolve().parents[1] / "docs/how-to/element.md").read_text()
    for capability in CAPABILITIES:
        assert f"| `{capability.__name__}` |" in page, capability.__name__
        for name, member in vars(capability).items():
            if callable(member) and not name.startswith("_"):
                assert f"| `{name}(" in page, name
