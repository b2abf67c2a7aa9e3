"""Every element kind in one line (``tests/data/every_kind.toml``: locating, floating
and angular-contact bearings, a slip joint, a disc coupling, Cardan joints, a CV joint,
a gear mesh, a centring ball): the rigid set carries its loads, the disc coupling is a
weld in it, every command runs on it or refuses in one line, and the penalty
simulation finishes on it compiled."""

from pathlib import Path

import numpy as np
import pytest
from cardan_forces.driveline import penalty
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.elements.registry import KINDS, scene_elements
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene

from cardan_forces.cli import main

SCENE = str(Path(__file__).parent / "data" / "every_kind.toml")


@pytest.fixture(scope="module")
def op():
    return build_operator(simulate(load_scene(SCENE), [0.3]))


def test_the_scene_holds_every_kind():
    held = {type(kind) for kind, *_ in scene_elements(load_scene(SCENE))}
    assert held == {type(kind) for kind in KINDS}


def test_its_loads_are_carried_and_the_disc_torque_is_the_line_torque(op):
    """A weld carries the shaft's torque: the input's over the first joint's ratio
    bounds (4 deg: cos and 1/cos), with no inertia in a quasi-static line."""
    d = determinacy(op, 0)
    assert np.linalg.norm(op.A[0] @ d.min_norm - op.b[0]) <= 1e-9 * np.linalg.norm(op.b[0])
    torque = op.names.index("disc.torque")
    assert d.determinate[torque]
    gamma, T = np.radians(4.0), op.scene.input_torque.mean_N_m
    assert T * np.cos(gamma) <= d.min_norm[torque] <= T / np.cos(gamma)


COMMANDS = {
    "sets": ["sets", SCENE, "--t", "0.3", "--release"],
    "solve": ["solve", SCENE, "--t", "0.3"],
    "report": ["report", SCENE, "--instants", "5", "--out", "{out}"],
    "repro": ["repro", SCENE, "--quick", "--no-penalty", "--methods",
              "positive,min_max,compliance", "--out", "{out}"],
    "bench": ["bench", SCENE, "--quick", "--out", "{out}"],
    "hard": ["hard", SCENE, "--quick", "--out", "{out}"],
    "life": ["life", SCENE, "--instants", "5", "--out", "{out}"],
    "tolerances": ["tolerances", SCENE, "--samples", "4", "--instants", "3", "--out", "{out}"],
    "sweep": ["sweep", SCENE, "--quick", "--out", "{out}"],
    "export": ["export", SCENE, "--instants", "2", "--out", "{out}"],
    "engine": ["engine", SCENE, "--instants", "5", "--out", "{out}"],
}
"""Every command that takes a scene with its quickest run (``scene`` is the loader's)."""

REFUSING = {"secondary": (["secondary", SCENE, "--out", "{out}"], "three shafts")}
"""Commands that cannot take the scene, and what their one line names."""


@pytest.mark.slow
@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_runs_on_every_kind(command, tmp_path, capsys):
    argv = [a.format(out=tmp_path / command) for a in COMMANDS[command]]
    assert main(argv) == 0


@pytest.mark.parametrize("command", REFUSING)
def test_a_command_that_cannot_take_a_kind_says_so_in_one_line(command, tmp_path, capsys):
    argv, named = REFUSING[command]
    assert main([a.format(out=tmp_path / command) for a in argv]) == 2
    err = capsys.readouterr().err
    assert named in err and err.count("\n") == 1


@pytest.mark.compiled
@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
def test_the_penalty_simulation_finishes_compiled_on_every_kind():
    """The line's dynamic counterpart (inertia and ``penalty_dynamics``) 0.05 s from
    rest, ``method="auto"``: the compiled BDF finishes without falling back (a failed
    compiled run would be run again by :data:`~.penalty.FALLBACK`, and the result's
    ``method`` would say so), and its forces satisfy the rigid equilibrium over the
    second half (``||A x - b||`` under 1 % of ``||A|| ||x||``, the mesh force in ``b``).
    """
    scene = load_scene(SCENE).with_changes(
        name="every-kind-released", effects=frozenset({"gravity", "inertia",
                                                       "penalty_dynamics"}))
    t = np.arange(0.0, 0.05 + 1e-9, 0.005)
    result = penalty.simulate_penalty(scene, t)
    assert result.success and result.method == penalty.COMPILED, result.message
    op = build_operator(simulate(scene, t))
    x = np.array([result.forces[n] for n in op.names]).T
    late = t >= 0.025
    residual = np.linalg.norm(np.einsum("tij,tj->ti", op.A, x) - op.b, axis=1)
    scale = np.linalg.norm(op.A, axis=(1, 2)) * np.linalg.norm(x, axis=1)
    assert np.median(residual[late] / scale[late]) < 0.01
