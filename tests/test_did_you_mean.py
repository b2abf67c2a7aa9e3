"""A mistyped name, of a solver backend, a formulation or a scene, is refused in one
line with exit code 2 that names the name meant (``util.names``, the one helper of
every lookup by name); a name near none lists the known ones.
"""

from __future__ import annotations

import pytest
from cardan_forces.driveline.loading import builtin_names
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.solvers.registry import available, known_backends

from cardan_forces.cli import main
from cardan_forces.util.names import did_you_mean, nearest

KINDS = {
    "solver": (lambda: list(known_backends()), ["solve", "--solver"]),
    "formulation": (lambda: list(FORMULATIONS), ["solve", "--formulation"]),
    "scene": (builtin_names, ["scene", "show"]),
}
"""Each kind of name: its known names and the command that looks one up."""


def typos(name: str) -> list[str]:
    """One-letter typos of ``name``: its middle letter dropped, replaced, doubled."""
    k = len(name) // 2
    other = "x" if name[k] != "x" else "y"
    return [name[:k] + name[k + 1:], name[:k] + other + name[k + 1:],
            name[:k] + name[k] + name[k:]]


def refusal(argv: list[str], capsys) -> str:
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, (argv, err)
    assert len(err.splitlines()) == 1 and err.startswith("cardan: error: "), err
    return err


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_a_one_letter_typo_of_every_known_name_names_it(kind, capsys):
    names, command = KINDS[kind]
    known = names()
    assert len(known) >= 7
    for name in known:
        for typo in typos(name):
            assert typo not in known
            err = refusal([*command, typo], capsys)
            hint = err.split("did you mean ", 1)
            assert len(hint) == 2 and f"'{name}'" in hint[1], (typo, err)


def test_a_family_name_suggests_its_backends(capsys):
    err = refusal(["solve", "--solver", "osqp"], capsys)
    assert err.rstrip().endswith("did you mean 'qpsolvers-osqp' or 'cvxpy-osqp'?")


def test_the_nearest_name_alone_when_others_are_far(capsys):
    err = refusal(["solve", "--solver", "clarabl"], capsys)
    assert err.rstrip().endswith("unknown backend 'clarabl'; did you mean 'clarabel'?")


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_a_name_near_none_lists_the_known_ones(kind, capsys):
    names, command = KINDS[kind]
    err = refusal([*command, "zzzz"], capsys)
    listed = list(available()) if kind == "solver" else names()  # installed backends
    assert "did you mean" not in err and all(name in err for name in listed)


def test_repro_methods_and_the_api_use_the_same_hint(capsys):
    err = refusal(["repro", "--methods", "papr"], capsys)
    assert err.rstrip().endswith("--methods: unknown papr; did you mean 'paper'?")
    import cardan_forces as cf

    op = cf.build_operator(cf.simulate(cf.load_scene("paper"), [0.5]))
    with pytest.raises(KeyError) as found:
        cf.build_formulation("positiv", op, 0)
    assert str(found.value) == "unknown formulation 'positiv'; did you mean 'positive'?"


def test_nearest_sets_case_aside_and_keeps_the_known_spelling():
    assert nearest("c_n", ["C_N", "C0_N"]) == ["C_N"]
    assert nearest("zzzz", ["C_N"]) == [] and did_you_mean("zzzz", ["C_N"]) == ""
    assert did_you_mean("ab", ["abc", "abd"]) == "; did you mean 'abc' or 'abd'?"


def test_a_mistyped_extends_names_the_built_in_scene(tmp_path, capsys):
    path = tmp_path / "line.toml"
    path.write_text('extends = "propshat"\n')
    err = refusal(["scene", "check", str(path)], capsys)
    assert err.rstrip().endswith("did you mean 'propshaft'?")
